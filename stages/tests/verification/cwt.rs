//! The Morlet continuous wavelet transform (`wavelet` stage) against its defining sum,
//! evaluated directly, on every route the fast transform takes: the whole record or
//! overlap-save blocks, complex coefficients or a sampled envelope for the power; and a
//! decimated output against every d-th sample of the full one.

use rustfft::num_complex::Complex64;
use serde::Deserialize;
use squeal_stages::signal::log_spaced;
use squeal_stages::signal::wavelet::{MorletCwt, scale_of_frequency};

use crate::reference;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Cwt {
    /// The Morlet wavelet's centre frequency k0 (rad).
    k0: f64,
    /// Terms beyond |t_n − t_m| = reach · a are left out of the direct sum.
    reach: f64,
    /// Largest coefficient error relative to the largest coefficient of the scale, and the
    /// same for the power.
    tolerance: f64,
    /// Decimated against full output, relative to the largest coefficient.
    decimation_tolerance: f64,
}

/// `W(a, t_m) = Δt Σ_n s_n a^{−1/2} φ*((t_n − t_m)/a)`, written out: the independent code
/// path.
fn direct_cwt(signal: &[f64], dt: f64, scale: f64, case: &Cwt) -> Vec<Complex64> {
    let reach = (case.reach * scale / dt).ceil() as usize;
    (0..signal.len())
        .map(|m| {
            let first = m.saturating_sub(reach);
            let end = (m + reach + 1).min(signal.len());
            (first..end)
                .map(|n| {
                    let x = (n as f64 - m as f64) * dt / scale;
                    let mother = Complex64::from_polar((-0.5 * x * x).exp(), case.k0 * x);
                    signal[n] * mother.conj() * dt / scale.sqrt()
                })
                .sum()
        })
        .collect()
}

fn max_norm(values: &[Complex64]) -> f64 {
    values.iter().map(|v| v.norm()).fold(0.0, f64::max)
}

/// A deterministic broadband signal: every scale sees content.
fn broadband(n: usize) -> Vec<f64> {
    let mut random = squeal_linalg::rng::SplitMix64::new(0x2545_f491_4f6c_dd1d);
    (0..n).map(|_| 0.5 * random.next_signed()).collect()
}

/// Which evaluation a scale must take: overlap-save blocks or the whole record, and for the
/// power the sampled envelope or the complex transform.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Route {
    blocks: bool,
    envelope: bool,
}

const RECORD: Route = Route {
    blocks: false,
    envelope: false,
};
const RECORD_ENVELOPE: Route = Route {
    blocks: false,
    envelope: true,
};
const BLOCKS: Route = Route {
    blocks: true,
    envelope: false,
};
const BLOCKS_ENVELOPE: Route = Route {
    blocks: true,
    envelope: true,
};

/// Checks every scale of `freqs` against [`direct_cwt`], the coefficients and the power;
/// `expected` says which route each scale must take, so that every route is covered.
fn check_against_direct_sum(n: usize, dt: f64, freqs: &[f64], expected: &[Route]) {
    let case: Cwt = reference::load("cwt");
    let signal = broadband(n);
    let scales: Vec<f64> = freqs
        .iter()
        .map(|&f| scale_of_frequency(case.k0, f))
        .collect();
    let cwt = MorletCwt::new(&signal, dt, case.k0, &scales, 1);
    let power = cwt.power();
    for (scale_idx, (&freq, &scale)) in freqs.iter().zip(&scales).enumerate() {
        let route = Route {
            blocks: cwt.uses_blocks(scale_idx),
            envelope: cwt.uses_envelope(scale_idx),
        };
        assert_eq!(route, expected[scale_idx], "{freq} Hz");
        let fast = cwt.coefficients(scale_idx);
        let direct = direct_cwt(&signal, dt, scale, &case);
        let error: Vec<Complex64> = fast.iter().zip(&direct).map(|(a, b)| a - b).collect();
        let relative = max_norm(&error) / max_norm(&direct);
        assert!(
            relative < case.tolerance,
            "{freq} Hz: relative error {relative:e}"
        );

        let row = &power[scale_idx * n..][..n];
        let peak = max_norm(&direct).powi(2);
        let power_error = row
            .iter()
            .zip(&direct)
            .map(|(p, d)| (p - d.norm_sqr()).abs())
            .fold(0.0, f64::max);
        assert!(
            power_error < case.tolerance * peak,
            "{freq} Hz: power error {:e} of the peak",
            power_error / peak
        );
    }
}

#[test]
fn whole_record_evaluation_equals_the_direct_sum() {
    // Up to Nyquist (500 Hz), where the aliased images of the daughter's spectrum matter and
    // the band is too wide for the envelope.
    let freqs = log_spaced(5.0, 500.0, 7);
    let expected = [
        RECORD_ENVELOPE,
        RECORD_ENVELOPE,
        RECORD_ENVELOPE,
        RECORD,
        RECORD,
        RECORD,
        RECORD,
    ];
    check_against_direct_sum(600, 1e-3, &freqs, &expected);
}

#[test]
fn envelope_of_a_long_record_equals_the_direct_sum() {
    // Wide scales on a long record: narrow bands, sampled at a few hundred points of the
    // padded length.
    check_against_direct_sum(40_000, 1e-3, &[3.0, 8.0], &[RECORD_ENVELOPE; 2]);
}

#[test]
fn block_evaluation_equals_the_direct_sum() {
    // Short scales on a long record go through overlap-save blocks of 1024 (sharing the
    // margin of the wider one); the widest scale through the whole record.
    let freqs = [40.0, 150.0, 500.0];
    check_against_direct_sum(4200, 1e-3, &freqs, &[RECORD_ENVELOPE, BLOCKS, BLOCKS]);
}

#[test]
fn block_envelope_equals_the_direct_sum() {
    // Blocks of 2048 for 40 Hz, whose band covers an eighth of them: the envelope route.
    check_against_direct_sum(20_000, 1e-3, &[40.0, 500.0], &[BLOCKS_ENVELOPE, BLOCKS]);
}

#[test]
fn decimated_output_is_every_dth_sample_of_the_full_one() {
    let case: Cwt = reference::load("cwt");
    let (n, dt) = (1000, 1e-3);
    let signal = broadband(n);
    let scale = scale_of_frequency(case.k0, 40.0);
    let full = MorletCwt::new(&signal, dt, case.k0, &[scale], 1).coefficients(0);
    let decimation = 7;
    let decimated = MorletCwt::new(&signal, dt, case.k0, &[scale], decimation).coefficients(0);
    assert_eq!(decimated.len(), (n - 1) / decimation + 1);
    let peak = max_norm(&full);
    for (q, value) in decimated.iter().enumerate() {
        let error = (value - full[q * decimation]).norm() / peak;
        assert!(error < case.decimation_tolerance, "sample {q}: {error:e}");
    }
}
