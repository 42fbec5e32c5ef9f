use std::f64::consts::PI;
use std::sync::Arc;

use super::*;
use crate::stage::{Input, Value};
use crate::table::ColumnData;

fn noise(n: usize) -> Vec<f64> {
    let mut random = squeal_linalg::rng::SplitMix64::new(0x9e37_79b9_7f4a_7c15);
    (0..n).map(|_| 0.5 * random.next_signed()).collect()
}

#[test]
fn parseval_holds_to_round_off_with_the_rect_window() {
    // Tolerance 1e-12 relative, for even and odd lengths.
    for n in [1024, 1001] {
        let values: Vec<f64> = noise(n).iter().map(|v| 3.0 + v).collect();
        let spectrum = power_spectrum(&values, 1e-3, Window::Rect, Detrend::None);
        let mean_square = values.iter().map(|v| v * v).sum::<f64>() / n as f64;
        let total: f64 = spectrum.power.iter().sum();
        assert!(
            (total / mean_square - 1.0).abs() < 1e-12,
            "n = {n}: {total} vs {mean_square}"
        );
    }
}

#[test]
fn parseval_holds_for_the_window_weighted_signal() {
    // Tolerance 1e-12 relative: Σ power = (1/n) Σ (w x)² / U for every window.
    let values = noise(777);
    for window in [Window::Hann, Window::Hamming, Window::Blackman] {
        let weights = window.samples(values.len());
        let window_power = weights.iter().map(|w| w * w).sum::<f64>() / 777.0;
        let expected = values
            .iter()
            .zip(&weights)
            .map(|(v, w)| (v * w) * (v * w))
            .sum::<f64>()
            / 777.0
            / window_power;
        let total: f64 = power_spectrum(&values, 1.0, window, Detrend::None)
            .power
            .iter()
            .sum();
        assert!((total / expected - 1.0).abs() < 1e-12, "{window:?}");
    }
}

#[test]
fn tone_on_a_bin_holds_half_its_squared_amplitude() {
    // rect window, tone exactly on bin 50: power A²/2 there to 1e-12, the rest ~0.
    let (n, dt, amplitude) = (1000, 1e-3, 2.5);
    let values: Vec<f64> = (0..n)
        .map(|i| amplitude * (2.0 * PI * 50.0 * i as f64 * dt + 0.3).sin())
        .collect();
    let spectrum = power_spectrum(&values, dt, Window::Rect, Detrend::None);
    assert!((spectrum.freqs_hz[50] - 50.0).abs() < 1e-12);
    let expected = amplitude * amplitude / 2.0;
    assert!((spectrum.power[50] / expected - 1.0).abs() < 1e-12);
    let rest: f64 = spectrum.power.iter().sum::<f64>() - spectrum.power[50];
    assert!(rest < 1e-20, "{rest}");
}

fn signal_table(dt: f64, values: Vec<f64>) -> Table {
    let time: Vec<f64> = (0..values.len()).map(|i| i as f64 * dt).collect();
    Table::new().with("t", time).with("x", values)
}

fn params(window_s: f64, window: &str, n_peaks: i64, threshold_db: f64) -> Params {
    Params(BTreeMap::from([
        ("column".into(), Value::Str("x".into())),
        ("window_s".into(), Value::Float(window_s)),
        ("window".into(), Value::Str(window.into())),
        ("detrend".into(), Value::Str("mean".into())),
        ("n_peaks".into(), Value::Int(n_peaks)),
        ("threshold_db".into(), Value::Float(threshold_db)),
    ]))
}

fn run(table: Table, params: &Params) -> Result<Outputs, StageError> {
    let inputs = crate::stage::Inputs(BTreeMap::from([(
        "signal".to_string(),
        Input::One(Arc::new(Artifact::Table(table))),
    )]));
    Spectrum.run(params, &inputs)
}

#[test]
fn multi_tone_peaks_are_found_within_one_bin() {
    // Tones off the bin grid, a DC offset and a transient start that the window excludes.
    // Tolerance: one bin (1/window_s = 2 Hz).
    let dt = 2e-5;
    let tones = [(1234.5, 1.0), (3517.3, 0.3), (11_100.7, 0.05)];
    let values: Vec<f64> = (0..100_000)
        .map(|i| {
            let t = i as f64 * dt;
            let startup = if t < 1.0 { 10.0 * (1.0 - t) } else { 0.0 };
            5.0 + startup
                + tones
                    .iter()
                    .map(|(f, a)| a * (2.0 * PI * f * t).sin())
                    .sum::<f64>()
        })
        .collect();
    let outputs = run(signal_table(dt, values), &params(0.5, "hann", 3, -60.0)).unwrap();
    let peaks = outputs["peaks"].as_table().unwrap();
    let Some(ColumnData::F64(freqs)) = peaks.column("freq_hz") else {
        panic!()
    };
    let Some(ColumnData::F64(levels)) = peaks.column("level") else {
        panic!()
    };
    assert_eq!(freqs.len(), 3);
    for (found, (expected, _)) in freqs.iter().zip(tones) {
        assert!(
            (found - expected).abs() <= 2.0,
            "{found} Hz vs {expected} Hz"
        );
    }
    assert!(levels[0] > levels[1] && levels[1] > levels[2]);
    let spectrum = outputs["spectrum"].as_table().unwrap();
    let Some(ColumnData::F64(spectrum_freqs)) = spectrum.column("freq_hz") else {
        panic!()
    };
    assert_eq!(spectrum_freqs.len(), 25_000 / 2 + 1);
    let Artifact::Figure(figure) = &outputs["spectrum_figure"] else {
        panic!()
    };
    assert!(figure.svg.contains("Power spectrum"));
}

#[test]
fn threshold_drops_weak_peaks() {
    let dt = 1e-3;
    let values: Vec<f64> = (0..1000)
        .map(|i| {
            let t = i as f64 * dt;
            (2.0 * PI * 100.0 * t).sin() + 0.001 * (2.0 * PI * 300.0 * t).sin()
        })
        .collect();
    // The weak tone is 60 dB down: kept at −80 dB, dropped at −40 dB.
    let count = |threshold| {
        let outputs = run(
            signal_table(dt, values.clone()),
            &params(0.0, "rect", 10, threshold),
        )
        .unwrap();
        outputs["peaks"].as_table().unwrap().n_rows()
    };
    assert_eq!(count(-80.0), 2);
    assert_eq!(count(-40.0), 1);
}

#[test]
fn bad_windows_are_refused_with_the_figures() {
    let table = signal_table(1e-3, noise(100));
    let err = run(table.clone(), &params(0.5, "hann", 3, -40.0)).unwrap_err();
    assert!(
        err.message.contains("longer than the record (0.1 s"),
        "{err}"
    );
    let err = run(table.clone(), &params(0.002, "hann", 3, -40.0)).unwrap_err();
    assert!(err.message.contains("at least 4"), "{err}");
    let err = run(table, &params(0.0, "hann", 3, 3.0)).unwrap_err();
    assert!(err.message.contains("threshold_db = 3"), "{err}");
}

#[test]
fn linear_detrend_removes_a_ramp() {
    let values: Vec<f64> = (0..64).map(|i| 2.0 + 0.5 * i as f64).collect();
    let residual = Detrend::Linear.apply(&values);
    assert!(residual.iter().all(|r| r.abs() < 1e-12), "{residual:?}");
}
