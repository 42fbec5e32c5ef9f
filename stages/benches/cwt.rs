//! Wall time of the Morlet CWT: `cargo bench -p squeal-stages --bench cwt`.
//!
//! Prints the minimum over several runs (the least disturbed one) for the power on every
//! sample, the way PyWavelets computes it (`pywavelets_cwt.py` beside this file times
//! `pywt.cwt(..., method='fft')` on the same signal and grid), then the whole `wavelet` stage
//! (power table and figure included) and a decimated run.

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use squeal_stages::signal::log_spaced;
use squeal_stages::signal::wavelet::{MorletCwt, Wavelet, scale_of_frequency};
use squeal_stages::stage::Input;
use squeal_stages::{Artifact, Inputs, Params, Stage, Table, Value};

const DT: f64 = 1e-5; // 100 kHz sampling
const K0: f64 = 6.0;
const F_MIN: f64 = 100.0;
const F_MAX: f64 = 25_000.0;

/// Two tones and a linear chirp; `pywavelets_cwt.py` builds the same samples.
fn signal(n: usize) -> Vec<f64> {
    let duration = n as f64 * DT;
    (0..n)
        .map(|i| {
            let t = i as f64 * DT;
            (2.0 * PI * 3537.0 * t).sin()
                + 0.3 * (2.0 * PI * 11_100.0 * t).sin()
                + 0.5 * (2.0 * PI * (500.0 * t + 0.5 * (8000.0 / duration) * t * t)).sin()
        })
        .collect()
}

fn min_time(runs: usize, mut work: impl FnMut()) -> f64 {
    (0..runs)
        .map(|_| {
            let start = Instant::now();
            work();
            start.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn kernel(n_samples: usize, n_freqs: usize, runs: usize) {
    let values = signal(n_samples);
    let scales: Vec<f64> = log_spaced(F_MIN, F_MAX, n_freqs)
        .iter()
        .map(|&f| scale_of_frequency(K0, f))
        .collect();
    let seconds = min_time(runs, || {
        let cwt = MorletCwt::new(&values, DT, K0, &scales, 1);
        black_box(cwt.power());
    });
    println!(
        "cwt power, every sample: {n_samples:>9} samples x {n_freqs} freqs: {seconds:8.3} s (min of {runs})"
    );
}

fn stage(n_samples: usize, n_freqs: usize, dt_out_s: f64, runs: usize) {
    let values = signal(n_samples);
    let time: Vec<f64> = (0..n_samples).map(|i| i as f64 * DT).collect();
    let table = Table::new().with("t", time).with("x", values);
    let inputs = Inputs(BTreeMap::from([(
        "signal".to_string(),
        Input::One(Arc::new(Artifact::Table(table))),
    )]));
    let params = Params(BTreeMap::from([
        ("column".into(), Value::Str("x".into())),
        ("k0".into(), Value::Float(K0)),
        ("f_min_hz".into(), Value::Float(F_MIN)),
        ("f_max_hz".into(), Value::Float(F_MAX)),
        ("n_freqs".into(), Value::Int(n_freqs as i64)),
        ("dt_out_s".into(), Value::Float(dt_out_s)),
        ("map_range_db".into(), Value::Float(60.0)),
    ]));
    let seconds = min_time(runs, || {
        black_box(Wavelet.run(&params, &inputs).expect("the stage runs"));
    });
    println!(
        "wavelet stage (table + figure), dt_out = {dt_out_s:e} s: {n_samples:>9} samples x {n_freqs} freqs: {seconds:8.3} s (min of {runs})"
    );
}

fn main() {
    println!(
        "Morlet k0 = {K0}, dt = {DT} s, {F_MIN}..{F_MAX} Hz log-spaced, {} rayon threads",
        rayon::current_num_threads()
    );
    // `cargo bench --bench cwt -- kernel` runs the cases whose name holds "kernel".
    let filters: Vec<String> = std::env::args()
        .skip(1)
        .filter(|arg| !arg.starts_with('-'))
        .collect();
    let wanted =
        |name: &str| filters.is_empty() || filters.iter().any(|f| name.contains(f.as_str()));
    if wanted("kernel-100k") {
        kernel(100_000, 300, 7);
    }
    if wanted("kernel-1M") {
        kernel(1_000_000, 256, 3);
    }
    if wanted("stage-100k") {
        stage(100_000, 300, 0.0, 3);
    }
    if wanted("stage-1M") {
        stage(1_000_000, 256, 1e-4, 3);
    }
}
