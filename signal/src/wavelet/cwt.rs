//! The Morlet transform engine: `W(a, t_m)` for a set of scales, evaluated by FFT (the
//! definitions and the scale ↔ frequency convention are in the stage's module doc).
//!
//! # Discretisation
//!
//! With samples `s_n = s(t₀ + n Δt)`, the integral is the rectangle rule
//! `W(a, t_m) = Δt Σ_n s_n a^{−1/2} φ*((t_n − t_m)/a)`, a discrete correlation. It is
//! evaluated by FFT: the signal is zero-padded to `P` samples and transformed once
//! (`S_k`, real-to-complex FFT); for each scale the product `S_k Ĝ_k` is formed with the
//! *analytic* transform of the sampled daughter,
//! `Ĝ_k = Σ_j a^{1/2} √(2π) e^{−(a ω_j − k₀)²/2}` over every frequency `ω_j = 2π j/(P Δt)`
//! with `j ≡ k (mod P)` — the negative frequencies and the aliased images that the sampling
//! folds onto bin `k` (Poisson summation), so the FFT evaluation equals the rectangle rule, not
//! an approximation of it. Terms below `e^{−CUTOFF²/2}` (≈ 3e−18) of the peak are skipped.
//! An inverse FFT gives `W(a, t_m)` for every `m`.
//!
//! *Padding*: the daughter's envelope `e^{−τ²/(2a²)}` is below the same cut-off beyond
//! `|τ| = CUTOFF · a`, so `P ≥ N + CUTOFF · a_max / Δt` keeps the circular correlation free of
//! wrap-around. Scales wider than the whole record (every point of them inside the cone of
//! influence) are not padded for: the padding stops at the widest scale that has a point
//! outside the cone.
//!
//! *Decimation* (`dt_out_s`): the output keeps every `D`-th sample, `D = round(dt_out_s/Δt)`.
//! With `P = D L`, keeping `W` at `m = q D` is an inverse FFT of length `L` of the spectrum
//! folded modulo `L` (`Y_r = Σ_{k ≡ r (mod L)} S_k Ĝ_k`): exact, and `D` times cheaper.
//!
//! *Short scales* (every sample kept): a daughter of half-support `K = CUTOFF a / Δt` samples
//! needs no transform of the whole record. Overlap-save blocks of `B` samples (a power of two,
//! `8K ≤ B`, 1 024 ≤ B ≤ 16 384) overlapping by the group's widest `2K` give `B − 2K` exact
//! outputs each; the same identities hold with `P` replaced by `B`. FFTs of that size stay in
//! cache and cost less per point than one over a long record (`docs/PERFORMANCE.md`). Each
//! block's spectrum is computed once and shared by all the scales that use that block length;
//! only the bins the daughter's band covers are multiplied.
//!
//! Scales are independent: workers (one per rayon thread) take them in turn.
//!
//! # Power from the sampled envelope
//!
//! In a transform of `N` bins (`L` for the whole record, `B` for a block) a scale's band
//! covers `β` consecutive bins, so its coefficients are `W_n = c Σ_{k ∈ band} Y_k e^{2πi k n/N}`
//! and its power is a real trigonometric polynomial of the differences of those bins:
//!
//! ```text
//! |W_n|² = c² Σ_{|d| < β} C_d e^{2πi d n / N}
//! ```
//!
//! For any divisor `Λ ≥ 2β − 1` of `N`, the samples at `n = E m` (`E = N/Λ`, m = 0..Λ) hold
//! every `C_d` once, unaliased: their length-`Λ` DFT is `Λ C_d`. The samples themselves are one
//! inverse DFT of length `Λ` of the band folded modulo `Λ` (no two bins meet, as `β ≤ Λ`). So
//! the power at every `n` is: an inverse DFT of length `Λ`, `|·|²`, a real forward DFT of
//! length `Λ`, and one real inverse DFT of length `N` of those coefficients zero-padded — exact,
//! and half the cost of the complex inverse DFT of length `N` when `Λ ≤ N/4` (the wide scales,
//! whose bands are narrow). Broader bands take the complex transform and `|W|²` per point.
//!
//! The round-off of this route is absolute, about 1e-16 of the scale's peak power, where the
//! complex route's is relative to each coefficient: points 100 dB below their scale's peak
//! carry ~1e-6 relative error, and round-off below zero where the power vanishes is set to 0.

use std::f64::consts::PI;
use std::sync::{Arc, LazyLock, Mutex, OnceLock};

use rayon::prelude::*;
use realfft::{RealFftPlanner, RealToComplex};
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftDirection as Direction, FftPlanner};

/// Where the Gaussian factors are cut: `e^{−CUTOFF²/2}` ≈ 2.6e−18 of their peak, below the
/// round-off of f64 sums.
const CUTOFF: f64 = 9.0;

/// Blocks no shorter than this: below it, per-block overheads outweigh the FFT savings.
const MIN_BLOCK_LEN: usize = 1024;
/// Blocks no longer than this: past it the FFT no longer fits in cache and one transform of
/// the whole record is as cheap per output sample (`docs/PERFORMANCE.md`).
const MAX_BLOCK_LEN: usize = 16_384;
/// The power goes through the sampled envelope when its `Λ` samples are at most this fraction
/// of the transform length: a real inverse transform of length `N` costs half a complex one,
/// and the two transforms of length `Λ` must not eat the saving.
const MAX_ENVELOPE_FRACTION: usize = 4;

/// Where a scale's transforms are taken (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Domain {
    /// The whole record's spectrum, folded to `L` bins.
    WholeRecord,
    /// Overlap-save blocks, index into [`MorletCwt::block_groups`].
    Blocks(usize),
}

/// How one scale is evaluated: its domain, and for the power the envelope plan (index into
/// [`MorletCwt::envelopes`]) when its band is narrow enough for one.
#[derive(Debug, Clone, Copy)]
struct Route {
    domain: Domain,
    envelope: Option<usize>,
}

/// The signal's spectrum zero-padded to `P = D L` samples.
struct RecordSpectrum {
    n_padded: usize,
    n_folded: usize,
    /// `S_k`, k = 0..P, Hermitian-completed so the band loop needs no conjugation branch.
    spectrum: Vec<Complex64>,
    /// Complex inverse of length `L`, planned on first use: the envelope route needs none.
    inverse: OnceLock<Arc<dyn Fft<f64>>>,
}

/// The signal cut into overlapping blocks of one length, each block's spectrum computed once
/// and shared by every scale evaluated with this length.
struct BlockGroup {
    block_len: usize,
    /// Samples at each end of a block whose outputs would wrap around: the widest
    /// half-support of the group's scales, at most `block_len / 8`.
    margin: usize,
    /// Valid outputs per block, `block_len − 2 margin`; block `b` yields samples from `b hop`.
    hop: usize,
    /// Spectra of the blocks, one after the other.
    spectra: Vec<Complex64>,
    /// Complex inverse of length `block_len`, planned on first use.
    inverse: OnceLock<Arc<dyn Fft<f64>>>,
}

/// Plans of the power's envelope route (module doc) for a transform of `N` bins sampled at
/// `Λ` points.
struct EnvelopePlan {
    /// Inverse, length `Λ`: the coefficients at every `N/Λ`-th point.
    samples: Arc<dyn Fft<f64>>,
    /// Forward, length `Λ`: the spectrum of their power.
    spectrum: Arc<dyn RealToComplex<f64>>,
    /// Inverse, length `N/2`: the power at every point, as a real inverse DFT of length `N`
    /// folded into a complex one of half the length.
    expand: Arc<dyn Fft<f64>>,
    /// `e^{2πi d/N}` for the kept frequencies `d < Λ/2`.
    twiddles: Vec<Complex64>,
}

/// A scale's band in a transform of `len` bins, from bin `first` (mod `len`) on.
struct Band<'a> {
    len: usize,
    first: usize,
    values: BandValues<'a>,
}

/// The values of a [`Band`], `i` counting bins from its first.
enum BandValues<'a> {
    /// `values[i]`.
    Computed(&'a [Complex64]),
    /// `spectrum[(first + i) mod len] · gains[i]`: a block's spectrum times the daughter's
    /// gains, multiplied where they are folded.
    Product {
        spectrum: &'a [Complex64],
        gains: &'a [f64],
    },
}

/// One inverse transform of a scale and where its valid outputs go: outputs
/// `skip..skip + n_valid` are the samples from `first_output` on.
struct Segment<'a> {
    band: Band<'a>,
    first_output: usize,
    skip: usize,
    n_valid: usize,
}

/// A signal prepared for Morlet transforms at a set of scales: spectra and plans, shared
/// read-only by the parallel workers.
pub struct MorletCwt {
    k0: f64,
    dt: f64,
    scales: Vec<f64>,
    routes: Vec<Route>,
    n_samples: usize,
    n_out: usize,
    record: Option<RecordSpectrum>,
    block_groups: Vec<BlockGroup>,
    envelopes: Vec<EnvelopePlan>,
}

/// Per-worker buffers for one scale at a time.
struct Workspace {
    /// A whole-record scale's band values, and a block scale's Gaussian gains over its band.
    band: Vec<Complex64>,
    gains: Vec<f64>,
    buffers: Buffers,
}

/// Per-worker buffers of the inverse transforms.
struct Buffers {
    /// A complex transform of `N` bins, or the folded real one of the envelope route.
    complex: Vec<Complex64>,
    samples: Vec<Complex64>,
    sample_power: Vec<f64>,
    sample_spectrum: Vec<Complex64>,
    scratch: Vec<Complex64>,
}

impl MorletCwt {
    /// Prepares `signal` (sampled every `dt` seconds) for the Morlet transform at `scales`
    /// (seconds), keeping every `decimation`-th output sample.
    pub fn new(signal: &[f64], dt: f64, k0: f64, scales: &[f64], decimation: usize) -> Self {
        let n_samples = signal.len();
        let decimation = decimation.max(1);
        // (block length, the widest half-support among its scales): one group each.
        let mut block_shapes: Vec<(usize, usize)> = Vec::new();
        let mut widest_record_scale: Option<f64> = None;
        let domains: Vec<Domain> = scales
            .iter()
            .map(|&scale| {
                let half_support = (CUTOFF * scale / dt).ceil() as usize + 1;
                let block_len = (8 * half_support).next_power_of_two().max(MIN_BLOCK_LEN);
                // Blocks pay off when outputs are not decimated and the record spans several.
                if decimation == 1 && block_len <= MAX_BLOCK_LEN && 4 * block_len <= n_samples {
                    let group = match block_shapes.iter().position(|&(len, _)| len == block_len) {
                        Some(group) => group,
                        None => {
                            block_shapes.push((block_len, 0));
                            block_shapes.len() - 1
                        }
                    };
                    block_shapes[group].1 = block_shapes[group].1.max(half_support);
                    Domain::Blocks(group)
                } else {
                    widest_record_scale = Some(widest_record_scale.unwrap_or(0.0).max(scale));
                    Domain::WholeRecord
                }
            })
            .collect();
        // The record's transform is serial: the blocks' run beside it.
        let (record, block_groups) = rayon::join(
            || widest_record_scale.map(|scale| RecordSpectrum::new(signal, dt, scale, decimation)),
            || {
                block_shapes
                    .iter()
                    .map(|&(len, margin)| BlockGroup::new(signal, len, margin))
                    .collect::<Vec<_>>()
            },
        );
        // One envelope plan per (N, Λ) pair the scales need.
        let mut envelope_shapes: Vec<(usize, usize)> = Vec::new();
        let routes = domains
            .into_iter()
            .zip(scales)
            .map(|(domain, &scale)| {
                let (len, omega_step) = match domain {
                    Domain::WholeRecord => {
                        let record = record.as_ref().expect("built for whole-record scales");
                        (record.n_folded, 2.0 * PI / (record.n_padded as f64 * dt))
                    }
                    Domain::Blocks(group) => {
                        let len = block_groups[group].block_len;
                        (len, 2.0 * PI / (len as f64 * dt))
                    }
                };
                let (band, _) = gaussian_band(k0, scale, omega_step);
                let width = band.count().min(len);
                let envelope = envelope_len(len, width).map(|samples| {
                    match envelope_shapes.iter().position(|&s| s == (len, samples)) {
                        Some(index) => index,
                        None => {
                            envelope_shapes.push((len, samples));
                            envelope_shapes.len() - 1
                        }
                    }
                });
                Route { domain, envelope }
            })
            .collect();
        let envelopes = envelope_shapes
            .iter()
            .map(|&(len, samples)| EnvelopePlan {
                samples: complex_plan(samples, Direction::Inverse),
                spectrum: real_forward_plan(samples),
                expand: complex_plan(len / 2, Direction::Inverse),
                twiddles: (0..samples.div_ceil(2))
                    .map(|d| Complex64::from_polar(1.0, 2.0 * PI * d as f64 / len as f64))
                    .collect(),
            })
            .collect();
        MorletCwt {
            k0,
            dt,
            scales: scales.to_vec(),
            routes,
            n_samples,
            n_out: (n_samples - 1) / decimation + 1,
            record,
            block_groups,
            envelopes,
        }
    }

    /// Number of output times (every `decimation`-th sample, the first included).
    pub fn n_out(&self) -> usize {
        self.n_out
    }

    fn workspace(&self) -> Workspace {
        let mut complex_len = 0;
        let mut scratch_len = 0;
        let mut band_len = 0;
        if let Some(record) = &self.record {
            complex_len = record.n_folded;
            band_len = record.n_folded;
        }
        for group in &self.block_groups {
            complex_len = complex_len.max(group.block_len);
            band_len = band_len.max(group.block_len);
        }
        let mut samples_len = 0;
        for plan in &self.envelopes {
            samples_len = samples_len.max(plan.samples.len());
            scratch_len = scratch_len
                .max(plan.samples.get_inplace_scratch_len())
                .max(plan.spectrum.get_scratch_len())
                .max(plan.expand.get_inplace_scratch_len());
        }
        let zero = Complex64::new(0.0, 0.0);
        Workspace {
            band: Vec::with_capacity(band_len),
            gains: Vec::with_capacity(band_len),
            buffers: Buffers {
                complex: vec![zero; complex_len],
                samples: vec![zero; samples_len],
                sample_power: vec![0.0; samples_len],
                sample_spectrum: vec![zero; samples_len / 2 + 1],
                scratch: vec![zero; scratch_len],
            },
        }
    }

    /// The complex inverse plan and the factor `a^{1/2} √(2π) / N_DFT` of a scale's domain:
    /// Ĝ's constant and the inverse DFT's normalisation. The rectangle rule's Δt is already
    /// in Ĝ: Poisson summation of the Δt-weighted samples gives the analytic transform.
    fn inverse_and_factor(&self, scale_idx: usize) -> (&Arc<dyn Fft<f64>>, f64) {
        let root = (2.0 * PI * self.scales[scale_idx]).sqrt();
        let (inverse, len, n_dft) = match self.routes[scale_idx].domain {
            Domain::WholeRecord => {
                let record = self.record.as_ref().expect("built for whole-record scales");
                (&record.inverse, record.n_folded, record.n_padded)
            }
            Domain::Blocks(group) => {
                let group = &self.block_groups[group];
                (&group.inverse, group.block_len, group.block_len)
            }
        };
        let inverse = inverse.get_or_init(|| complex_plan(len, Direction::Inverse));
        (inverse, root / n_dft as f64)
    }

    /// Calls `each` on every segment of a scale: one for the whole record, one per block.
    fn segments(
        &self,
        scale_idx: usize,
        work: &mut Workspace,
        mut each: impl FnMut(&Segment, &mut Buffers),
    ) {
        let scale = self.scales[scale_idx];
        match self.routes[scale_idx].domain {
            Domain::WholeRecord => {
                let record = self.record.as_ref().expect("built for whole-record scales");
                let band = record.band(self.k0, self.dt, scale, &mut work.band);
                let segment = Segment {
                    band,
                    first_output: 0,
                    skip: 0,
                    n_valid: self.n_out,
                };
                each(&segment, &mut work.buffers);
            }
            Domain::Blocks(group) => {
                let group = &self.block_groups[group];
                let first = group.gains(self.k0, self.dt, scale, &mut work.gains);
                for (block, spectrum) in group.spectra.chunks_exact(group.block_len).enumerate() {
                    let first_output = block * group.hop;
                    let segment = Segment {
                        band: Band {
                            len: group.block_len,
                            first,
                            values: BandValues::Product {
                                spectrum,
                                gains: &work.gains,
                            },
                        },
                        first_output,
                        skip: group.margin,
                        n_valid: group.hop.min(self.n_samples - first_output),
                    };
                    each(&segment, &mut work.buffers);
                }
            }
        }
    }

    /// `W(scales[scale_idx], t_{qD})` for q = 0..n_out.
    pub fn coefficients(&self, scale_idx: usize) -> Vec<Complex64> {
        let mut work = self.workspace();
        let mut coefficients = vec![Complex64::new(0.0, 0.0); self.n_out];
        let (inverse, factor) = self.inverse_and_factor(scale_idx);
        self.segments(scale_idx, &mut work, |segment, buffers| {
            let values = segment.band.inverse(inverse.as_ref(), buffers);
            let out = &mut coefficients[segment.first_output..][..segment.n_valid];
            for (out, value) in out.iter_mut().zip(&values[segment.skip..]) {
                *out = value * factor;
            }
        });
        coefficients
    }

    /// `|W|²` of one scale into `row` (q = 0..n_out).
    fn power_row(&self, scale_idx: usize, work: &mut Workspace, row: &mut [f64]) {
        let (inverse, factor) = self.inverse_and_factor(scale_idx);
        let factor_squared = factor * factor;
        let envelope = self.routes[scale_idx].envelope.map(|e| &self.envelopes[e]);
        self.segments(scale_idx, work, |segment, buffers| {
            let out = &mut row[segment.first_output..][..segment.n_valid];
            match envelope {
                Some(plan) => {
                    let folded = segment.band.envelope_power(plan, buffers);
                    let power = &interleaved(folded)[segment.skip..];
                    let factor_squared = factor_squared / plan.samples.len() as f64;
                    for (out, value) in out.iter_mut().zip(power) {
                        // Round-off may dip below zero where the power is nil.
                        *out = (value * factor_squared).max(0.0);
                    }
                }
                None => {
                    let values = segment.band.inverse(inverse.as_ref(), buffers);
                    for (out, value) in out.iter_mut().zip(&values[segment.skip..]) {
                        *out = value.norm_sqr() * factor_squared;
                    }
                }
            }
        });
    }

    /// `|W|²`, scale-major: `power[s n_out + q]` at scale `s` and output time `q`.
    ///
    /// As many workers as rayon threads, each with its own buffers, take the next scale still
    /// to do until none is left: the scales' costs differ, and buffers made per rayon job
    /// (megabytes each for long records) would spend more time faulting in fresh pages than
    /// transforming. Workers are spawned tasks, so busy threads are not waited for.
    pub fn power(&self) -> Vec<f64> {
        let mut power = vec![0.0; self.scales.len() * self.n_out];
        advise_huge_pages(&mut power);
        let rows = std::sync::Mutex::new(power.chunks_mut(self.n_out).enumerate());
        let next_row = || rows.lock().expect("no worker panics holding it").next();
        let n_workers = rayon::current_num_threads().clamp(1, self.scales.len().max(1));
        rayon::scope(|scope| {
            for _ in 0..n_workers {
                scope.spawn(|_| {
                    let mut work = self.workspace();
                    while let Some((scale_idx, row)) = next_row() {
                        self.power_row(scale_idx, &mut work, row);
                    }
                });
            }
        });
        power
    }

    /// Whether scale `scale_idx` is evaluated in overlap-save blocks (else on the whole
    /// record): the verification covers every route.
    pub fn uses_blocks(&self, scale_idx: usize) -> bool {
        matches!(self.routes[scale_idx].domain, Domain::Blocks(_))
    }

    /// Whether the power of scale `scale_idx` comes from its sampled envelope (else from the
    /// complex coefficients).
    pub fn uses_envelope(&self, scale_idx: usize) -> bool {
        self.routes[scale_idx].envelope.is_some()
    }
}

/// Asks Linux to back the 2 MiB-aligned part of a fresh, untouched buffer with transparent
/// huge pages. Filling hundreds of megabytes of output otherwise costs one page fault per
/// 4 KiB; with huge pages, one per 2 MiB.
/// Advice only: where the kernel declines, or elsewhere than Linux, nothing changes.
fn advise_huge_pages(buffer: &mut [f64]) {
    #[cfg(target_os = "linux")]
    {
        const HUGE_PAGE: usize = 2 << 20;
        let start = buffer.as_mut_ptr() as usize;
        let end = start + std::mem::size_of_val(buffer);
        let aligned_start = start.next_multiple_of(HUGE_PAGE);
        let aligned_end = end / HUGE_PAGE * HUGE_PAGE;
        if aligned_start < aligned_end {
            // SAFETY: the range lies inside `buffer`, which we own mutably; madvise with
            // MADV_HUGEPAGE changes neither its contents nor its mapping, only how the kernel
            // backs pages on first touch. Its result is advice and is ignored on purpose.
            unsafe {
                libc::madvise(
                    aligned_start as *mut libc::c_void,
                    aligned_end - aligned_start,
                    libc::MADV_HUGEPAGE,
                );
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = buffer;
}

/// FFT plans shared by every transform of the process: planning computes the twiddle factors,
/// milliseconds per length that repeated transforms (a sweep's runs) need not pay again.
/// They are kept for the life of the process, as numpy's and scipy's FFTs keep theirs.
static PLANNER: LazyLock<Mutex<FftPlanner<f64>>> = LazyLock::new(|| Mutex::new(FftPlanner::new()));
static REAL_PLANNER: LazyLock<Mutex<RealFftPlanner<f64>>> =
    LazyLock::new(|| Mutex::new(RealFftPlanner::new()));

fn complex_plan(len: usize, direction: Direction) -> Arc<dyn Fft<f64>> {
    let mut planner = PLANNER
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    planner.plan_fft(len, direction)
}

fn real_forward_plan(len: usize) -> Arc<dyn RealToComplex<f64>> {
    let mut planner = REAL_PLANNER
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    planner.plan_fft_forward(len)
}

/// The unwrapped frequency indices `j` where the daughter's Gaussian `e^{−(a ω_j − k₀)²/2}`,
/// `ω_j = j ω_step`, is above the cut-off, and the step of `x_j = a ω_j − k₀` per index.
fn gaussian_band(k0: f64, scale: f64, omega_step: f64) -> (std::ops::RangeInclusive<i64>, f64) {
    let x_step = scale * omega_step;
    let j_center = k0 / x_step;
    let j_half_width = CUTOFF / x_step;
    let j_first = (j_center - j_half_width).ceil() as i64;
    let j_last = (j_center + j_half_width).floor() as i64;
    (j_first..=j_last, x_step)
}

/// The number of samples `Λ` of the envelope route for a band `width` bins wide in a
/// transform of `len` bins, if that route pays: the least divisor of `len` with
/// `Λ ≥ 2 width − 1` (module doc), at most `len / MAX_ENVELOPE_FRACTION`.
fn envelope_len(len: usize, width: usize) -> Option<usize> {
    if !len.is_multiple_of(2) {
        return None; // the real inverse DFT is folded into a complex one of half the length
    }
    let least = (2 * width).max(3) - 1;
    (least..=len / MAX_ENVELOPE_FRACTION).find(|samples| len.is_multiple_of(*samples))
}

/// The real sequence `p_{2m} = z_m.re, p_{2m+1} = z_m.im`, without a copy.
fn interleaved(folded: &[Complex64]) -> &[f64] {
    // SAFETY: `Complex<f64>` is `#[repr(C)]` with fields `re, im` (documented by num-complex),
    // so a slice of them is a slice of twice as many f64 with the same alignment and lifetime.
    unsafe { std::slice::from_raw_parts(folded.as_ptr().cast::<f64>(), 2 * folded.len()) }
}

impl Band<'_> {
    /// The unnormalised inverse DFT `Σ_i values[i] e^{2πi (first + i) n / len}`, n = 0..len.
    fn inverse<'b>(&self, plan: &dyn Fft<f64>, buffers: &'b mut Buffers) -> &'b [Complex64] {
        let scratch_len = plan.get_inplace_scratch_len();
        if buffers.scratch.len() < scratch_len {
            // Complex plans are made on first use, after the workspace.
            buffers
                .scratch
                .resize(scratch_len, Complex64::new(0.0, 0.0));
        }
        let buffer = &mut buffers.complex[..self.len];
        self.fold_into(buffer);
        plan.process_with_scratch(buffer, &mut buffers.scratch);
        buffer
    }

    /// `|inverse|²` at every n through its envelope (module doc): the coefficients at every
    /// `len/Λ`-th point, their power's spectrum, and one real inverse DFT of length `len`.
    /// The result is `Λ` times the power, `z_m = p_{2m} + i p_{2m+1}` (see [`interleaved`]).
    ///
    /// The real inverse DFT `p_n = Σ_k X_k e^{2πi kn/N}` of a Hermitian `X` is one complex
    /// inverse DFT of length `N/2`: `z_m = p_{2m} + i p_{2m+1} = Σ_k Z_k e^{2πi km/(N/2)}`
    /// with `Z_k = (X_k + X_{k+N/2}) + i e^{2πi k/N} (X_k − X_{k+N/2})`. Here `X_d = C_d` and
    /// `X_{N−d} = C_d*` for `d < Λ/2 ≤ N/8`, zero elsewhere, so `Z_d = C_d (1 + i w_d)` and
    /// `Z_{N/2−d} = (C_d (1 − i w_d))*` with `w_d = e^{2πi d/N}`, and the rest vanishes.
    fn envelope_power<'b>(&self, plan: &EnvelopePlan, buffers: &'b mut Buffers) -> &'b [Complex64] {
        let n_samples = plan.samples.len();
        let samples = &mut buffers.samples[..n_samples];
        self.fold_into(samples);
        plan.samples
            .process_with_scratch(samples, &mut buffers.scratch);
        let sample_power = &mut buffers.sample_power[..n_samples];
        for (power, value) in sample_power.iter_mut().zip(samples.iter()) {
            *power = value.norm_sqr();
        }
        let coefficients = &mut buffers.sample_spectrum[..n_samples / 2 + 1];
        plan.spectrum
            .process_with_scratch(sample_power, coefficients, &mut buffers.scratch)
            .expect("buffers sized by the plan");
        // The spectrum of |W|² has no frequency of Λ/2 or above (in magnitude): the first
        // half of the samples' spectrum, less its Nyquist bin, is the whole of it.
        coefficients[0].im = 0.0;
        let half_len = self.len / 2;
        let folded = &mut buffers.complex[..half_len];
        folded.fill(Complex64::new(0.0, 0.0));
        for (d, (c, w)) in coefficients.iter().zip(&plan.twiddles).enumerate() {
            let i_w = Complex64::new(-w.im, w.re);
            folded[d] = c * (1.0 + i_w);
            if d > 0 {
                folded[half_len - d] = (c * (1.0 - i_w)).conj();
            }
        }
        plan.expand
            .process_with_scratch(folded, &mut buffers.scratch);
        folded
    }

    /// `buffer[(first + i) mod buffer.len()] = value_i`, zero elsewhere, where `buffer.len()`
    /// divides `len` and is no less than the band's width (bands are folded to at most `len`
    /// bins, and the envelope's `Λ` exceeds twice the width), so no two values meet. Written
    /// in runs of bins contiguous both in the band and in the buffer.
    fn fold_into(&self, buffer: &mut [Complex64]) {
        let modulus = buffer.len();
        let width = match self.values {
            BandValues::Computed(values) => values.len(),
            BandValues::Product { gains, .. } => gains.len(),
        };
        debug_assert!(width <= modulus && self.len.is_multiple_of(modulus));
        let first = self.first % modulus;
        if first + width <= modulus {
            buffer[..first].fill(Complex64::new(0.0, 0.0));
            buffer[first + width..].fill(Complex64::new(0.0, 0.0));
        } else {
            buffer[first + width - modulus..first].fill(Complex64::new(0.0, 0.0));
        }
        let (mut i, mut bin, mut r) = (0, self.first % self.len, first);
        while i < width {
            let run = (width - i).min(modulus - r).min(self.len - bin);
            let out = &mut buffer[r..r + run];
            match self.values {
                BandValues::Computed(values) => out.copy_from_slice(&values[i..i + run]),
                BandValues::Product { spectrum, gains } => {
                    let products = spectrum[bin..bin + run].iter().zip(&gains[i..i + run]);
                    for (out, (value, gain)) in out.iter_mut().zip(products) {
                        *out = value * gain;
                    }
                }
            }
            i += run;
            bin = (bin + run) % self.len;
            r = (r + run) % modulus;
        }
    }
}

impl RecordSpectrum {
    fn new(signal: &[f64], dt: f64, widest_scale: f64, decimation: usize) -> Self {
        let n_samples = signal.len();
        // Padding beyond the widest scale with a point outside the cone of influence buys
        // nothing: those scales are wholly inside it.
        let widest_useful_scale = (n_samples - 1) as f64 * dt / (2.0 * std::f64::consts::SQRT_2);
        let pad_scale = widest_scale.min(widest_useful_scale);
        let pad = (CUTOFF * pad_scale / dt).ceil() as usize + 1;
        let n_folded = next_fast_len((n_samples + pad).div_ceil(decimation));
        let n_padded = n_folded * decimation;

        let mut padded = vec![0.0; n_padded];
        padded[..n_samples].copy_from_slice(signal);
        let forward = real_forward_plan(n_padded);
        let mut half = forward.make_output_vec();
        forward
            .process(&mut padded, &mut half)
            .expect("buffers sized by the plan");
        let mut spectrum = vec![Complex64::new(0.0, 0.0); n_padded];
        spectrum[..half.len()].copy_from_slice(&half);
        for k in half.len()..n_padded {
            spectrum[k] = spectrum[n_padded - k].conj();
        }
        RecordSpectrum {
            n_padded,
            n_folded,
            spectrum,
            inverse: OnceLock::new(),
        }
    }

    /// `Y_r = Σ_{k ≡ r mod L} S_k Ĝ_k / (a^{1/2} √(2π))` over the scale's band (module doc),
    /// held in `values`.
    fn band<'v>(&self, k0: f64, dt: f64, scale: f64, values: &'v mut Vec<Complex64>) -> Band<'v> {
        let omega_step = 2.0 * PI / (self.n_padded as f64 * dt);
        let (band, x_step) = gaussian_band(k0, scale, omega_step);
        let width = band.clone().count().min(self.n_folded);
        values.clear();
        values.resize(width, Complex64::new(0.0, 0.0));
        let first = band.start().rem_euclid(self.n_folded as i64) as usize;
        let mut k = band.start().rem_euclid(self.n_padded as i64) as usize;
        let mut i = 0;
        for j in band {
            let x = x_step * j as f64 - k0;
            values[i] += self.spectrum[k] * (-0.5 * x * x).exp();
            k += 1;
            if k == self.n_padded {
                k = 0;
            }
            i += 1;
            if i == width {
                i = 0;
            }
        }
        Band {
            len: self.n_folded,
            first,
            values: BandValues::Computed(values),
        }
    }
}

impl BlockGroup {
    fn new(signal: &[f64], block_len: usize, margin: usize) -> Self {
        let hop = block_len - 2 * margin;
        let n_blocks = signal.len().div_ceil(hop);
        let forward = complex_plan(block_len, Direction::Forward);
        let mut spectra = vec![Complex64::new(0.0, 0.0); n_blocks * block_len];
        spectra.par_chunks_mut(block_len).enumerate().for_each_init(
            || vec![Complex64::new(0.0, 0.0); forward.get_inplace_scratch_len()],
            |scratch, (block, spectrum)| {
                // Block b holds samples b hop − margin … b hop − margin + block_len − 1.
                let first = (block * hop) as i64 - margin as i64;
                for (i, value) in spectrum.iter_mut().enumerate() {
                    let sample = first + i as i64;
                    if sample >= 0 && (sample as usize) < signal.len() {
                        *value = Complex64::new(signal[sample as usize], 0.0);
                    }
                }
                forward.process_with_scratch(spectrum, scratch);
            },
        );
        BlockGroup {
            block_len,
            margin,
            hop,
            spectra,
            inverse: OnceLock::new(),
        }
    }

    /// The block-length DFT of the sampled daughter (less `a^{1/2} √(2π)`), which is real:
    /// the Gaussian summed over the frequencies that alias onto each bin. `gains[i]` belongs
    /// to bin `first + i` (mod the block length); `first` is returned. Only the band's bins
    /// are kept, so narrow bands read a fraction of each block's spectrum.
    fn gains(&self, k0: f64, dt: f64, scale: f64, gains: &mut Vec<f64>) -> usize {
        let omega_step = 2.0 * PI / (self.block_len as f64 * dt);
        let (band, x_step) = gaussian_band(k0, scale, omega_step);
        let width = band.clone().count().min(self.block_len);
        gains.clear();
        gains.resize(width, 0.0);
        let first = band.start().rem_euclid(self.block_len as i64) as usize;
        for (i, j) in band.enumerate() {
            let x = x_step * j as f64 - k0;
            gains[i % width] += (-0.5 * x * x).exp();
        }
        first
    }
}

/// Smallest `n ≥ min_len` of the form `2^p 3^q`: the FFT sizes rustfft is fastest on.
pub fn next_fast_len(min_len: usize) -> usize {
    let min_len = min_len.max(1);
    let mut best = min_len.next_power_of_two();
    let mut power_of_three = 1;
    while power_of_three < best {
        let mut candidate = power_of_three;
        while candidate < min_len {
            candidate *= 2;
        }
        best = best.min(candidate);
        power_of_three *= 3;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_fast_len_has_small_factors() {
        assert_eq!(next_fast_len(1), 1);
        assert_eq!(next_fast_len(1025), 1152); // 2^7 3^2
        assert_eq!(next_fast_len(108_595), 110_592); // 2^12 3^3
        for n in [17, 97, 1000, 65_537] {
            let mut m = next_fast_len(n);
            assert!(m >= n);
            for p in [2, 3] {
                while m.is_multiple_of(p) {
                    m /= p;
                }
            }
            assert_eq!(m, 1);
        }
    }
}
