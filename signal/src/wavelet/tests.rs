use std::collections::BTreeMap;
use std::sync::Arc;

use super::*;
use crate::stage::{Input, Value};
use crate::table::ColumnData;

const K0: f64 = 6.0;

fn tone_table(dt: f64, n: usize, tone: impl Fn(f64) -> f64) -> Table {
    let time: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    let values = time.iter().map(|&t| tone(t)).collect::<Vec<f64>>();
    Table::new().with("t", time).with("x", values)
}

fn params(f_min: f64, f_max: f64, n_freqs: i64, dt_out: f64) -> Params {
    Params(BTreeMap::from([
        ("column".into(), Value::Str("x".into())),
        ("k0".into(), Value::Float(K0)),
        ("f_min_hz".into(), Value::Float(f_min)),
        ("f_max_hz".into(), Value::Float(f_max)),
        ("n_freqs".into(), Value::Int(n_freqs)),
        ("dt_out_s".into(), Value::Float(dt_out)),
        ("map_range_db".into(), Value::Float(60.0)),
    ]))
}

fn run(table: Table, params: &Params) -> Result<Outputs, StageError> {
    let inputs = Inputs(BTreeMap::from([(
        "signal".to_string(),
        Input::One(Arc::new(Artifact::Table(table))),
    )]));
    Wavelet.run(params, &inputs)
}

/// Per output time outside the cone of influence: the frequency of the largest power.
struct Ridge {
    times: Vec<f64>,
    freqs: Vec<f64>,
}

fn ridge(outputs: &Outputs) -> Ridge {
    let table = outputs["power"].as_table().unwrap();
    let column = |name| match table.column(name) {
        Some(ColumnData::F64(values)) => values.clone(),
        _ => panic!("no f64 column {name}"),
    };
    let (t, freq, power) = (column("t"), column("freq_hz"), column("power"));
    let Some(ColumnData::Bool(in_coi)) = table.column("in_coi") else {
        panic!("no in_coi column");
    };
    // Rows are grouped by frequency, times ascending within each.
    let mut best: BTreeMap<u64, (f64, f64, bool)> = BTreeMap::new();
    for row in 0..t.len() {
        let entry = best.entry(t[row].to_bits()).or_insert((0.0, 0.0, false));
        if power[row] > entry.0 {
            *entry = (power[row], freq[row], in_coi[row]);
        }
    }
    let (times, freqs) = best
        .iter()
        .filter(|(_, (_, _, coi))| !coi)
        .map(|(bits, (_, freq, _))| (f64::from_bits(*bits), *freq))
        .unzip();
    Ridge { times, freqs }
}

#[test]
fn sinusoid_ridge_sits_at_its_frequency_outside_the_cone() {
    // Tolerance: one grid step (ratio 1.02) around the power ridge 0.9865 f₀ predicted in
    // the module doc.
    let (dt, f0) = (1e-4, 440.0);
    let table = tone_table(dt, 4000, |t| (2.0 * PI * f0 * t).sin());
    let outputs = run(table, &params(200.0, 1000.0, 80, 0.0)).unwrap();
    let grid_ratio = (1000.0f64 / 200.0).powf(1.0 / 79.0);
    let predicted = f0 * 2.0 * K0 / (K0 + (K0 * K0 + 2.0).sqrt());
    let ridge = ridge(&outputs);
    assert!(
        ridge.times.len() > 3000,
        "{} points outside the cone",
        ridge.times.len()
    );
    for (t, freq) in ridge.times.iter().zip(&ridge.freqs) {
        let off = (freq / predicted).ln().abs();
        assert!(
            off <= grid_ratio.ln(),
            "t = {t}: ridge at {freq} Hz, predicted {predicted}"
        );
    }
}

#[test]
fn scale_frequency_convention_puts_the_normalised_peak_at_the_tone() {
    // |W|²/a of a tone peaks at a = k₀/(2π f₀) exactly; on a fine grid (ratio 1.001) the
    // argmax is within one step of f₀, and the |W|² argmax within one step of 0.9865 f₀.
    let (dt, f0, n) = (1e-4, 300.0, 3000);
    let signal: Vec<f64> = (0..n)
        .map(|i| (2.0 * PI * f0 * i as f64 * dt).cos())
        .collect();
    let freqs = log_spaced(290.0, 305.0, 53);
    let step = (305.0f64 / 290.0).ln() / 52.0;
    let scales: Vec<f64> = freqs.iter().map(|&f| scale_of_frequency(K0, f)).collect();
    let cwt = MorletCwt::new(&signal, dt, K0, &scales, 1);
    let power: Vec<Vec<f64>> = cwt
        .power()
        .chunks(cwt.n_out())
        .map(<[f64]>::to_vec)
        .collect();
    let middle = n / 2;
    let argmax = |values: Vec<f64>| {
        let idx = (0..values.len())
            .max_by(|&i, &j| values[i].total_cmp(&values[j]))
            .unwrap();
        freqs[idx]
    };
    let normalised = argmax(
        power
            .iter()
            .zip(&scales)
            .map(|(row, a)| row[middle] / a)
            .collect(),
    );
    let raw = argmax(power.iter().map(|row| row[middle]).collect());
    assert!(
        (normalised / f0).ln().abs() <= step,
        "|W|²/a peaks at {normalised} Hz"
    );
    let predicted = f0 * 2.0 * K0 / (K0 + (K0 * K0 + 2.0).sqrt());
    assert!(
        (raw / predicted).ln().abs() <= step,
        "|W|² peaks at {raw} Hz, predicted {predicted}"
    );
    // The analytic amplitude of a unit cosine: |W| = √(2π a)/2 · e^{−(aω₀ − k₀)²/2}; 1e-6.
    let a0 = scale_of_frequency(K0, f0);
    let on_tone = MorletCwt::new(&signal, dt, K0, &[a0], 1).coefficients(0);
    let expected = (2.0 * PI * a0).sqrt() / 2.0;
    let relative = (on_tone[middle].norm() - expected).abs() / expected;
    assert!(
        relative < 1e-6,
        "|W| = {} vs {expected}",
        on_tone[middle].norm()
    );
}

#[test]
fn two_tones_give_two_ridges() {
    // Tolerance: each local maximum over frequency within one grid step (ratio 1.02) of the
    // predicted power ridge of its tone, at every time outside the cone of both.
    let (dt, f1, f2) = (1e-4, 300.0, 1200.0);
    let table = tone_table(dt, 5000, |t| {
        (2.0 * PI * f1 * t).sin() + 0.5 * (2.0 * PI * f2 * t).sin()
    });
    let (f_min, f_max, n_freqs) = (100.0, 3000.0, 170);
    let outputs = run(table, &params(f_min, f_max, n_freqs, 1e-3)).unwrap();
    let table = outputs["power"].as_table().unwrap();
    let Some(ColumnData::F64(power)) = table.column("power") else {
        panic!()
    };
    let Some(ColumnData::Bool(in_coi)) = table.column("in_coi") else {
        panic!()
    };
    let freqs = log_spaced(f_min, f_max, n_freqs as usize);
    let n_times = power.len() / freqs.len();
    let step = (f_max / f_min).ln() / (n_freqs - 1) as f64;
    let bias = 2.0 * K0 / (K0 + (K0 * K0 + 2.0).sqrt());
    let mut checked = 0;
    for time_idx in 0..n_times {
        let column: Vec<f64> = (0..freqs.len())
            .map(|f| power[f * n_times + time_idx])
            .collect();
        // The cone narrows as frequency rises: the rows outside it are the upper ones.
        let first_outside = (0..freqs.len()).find(|&f| !in_coi[f * n_times + time_idx]);
        let Some(first_outside) = first_outside.filter(|&f| freqs[f] < 250.0) else {
            continue;
        };
        let maxima: Vec<f64> = (first_outside + 1..freqs.len() - 1)
            .filter(|&f| column[f] > column[f - 1] && column[f] >= column[f + 1])
            .filter(|&f| column[f] > 1e-3 * column.iter().copied().fold(0.0, f64::max))
            .map(|f| freqs[f])
            .collect();
        assert_eq!(maxima.len(), 2, "time {time_idx}: maxima at {maxima:?}");
        for (found, tone) in maxima.iter().zip([f1, f2]) {
            assert!(
                (found / (tone * bias)).ln().abs() <= step,
                "{found} Hz for {tone} Hz"
            );
        }
        checked += 1;
    }
    assert!(checked > 100, "only {checked} times outside the cone");
}

#[test]
fn outputs_do_not_depend_on_the_thread_count() {
    // Scales are handed to workers as they come free: each row must not depend on the
    // rows its worker did before.
    let table = tone_table(1e-4, 3000, |t| {
        (2.0 * PI * 300.0 * t).sin() + 0.5 * (2.0 * PI * 1200.0 * t).sin()
    });
    let inputs = Inputs(BTreeMap::from([(
        "signal".to_string(),
        Input::One(Arc::new(Artifact::Table(table))),
    )]));
    crate::stage::assert_outputs_independent_of_threads(
        &Wavelet,
        &params(100.0, 3000.0, 60, 1e-3),
        &inputs,
        "wavelet",
    );
}

#[test]
fn chirp_ridge_follows_the_instantaneous_frequency() {
    // s = sin(2π (f_a t + c t²/2)), f_inst = f_a + c t. Tolerance: the ridge within 4 % of the
    // predicted power ridge f_inst · 0.9865 (grid step 1.8 % plus the lag of a sweep across
    // the wavelet's duration).
    let (dt, n) = (1e-4, 20000);
    let duration = n as f64 * dt;
    let (f_a, f_b) = (200.0, 800.0);
    let rate = (f_b - f_a) / duration;
    let table = tone_table(dt, n, |t| (2.0 * PI * (f_a * t + 0.5 * rate * t * t)).sin());
    let outputs = run(table, &params(100.0, 1500.0, 150, 5e-3)).unwrap();
    let bias = 2.0 * K0 / (K0 + (K0 * K0 + 2.0).sqrt());
    let ridge = ridge(&outputs);
    assert!(ridge.times.len() > 300, "{} points", ridge.times.len());
    for (t, freq) in ridge.times.iter().zip(&ridge.freqs) {
        let expected = (f_a + rate * t) * bias;
        assert!(
            (freq / expected - 1.0).abs() < 0.04,
            "t = {t}: {freq} Hz vs {expected}"
        );
    }
}

#[test]
fn cone_of_influence_is_the_e_folding_time_from_either_edge() {
    let (dt, n) = (1e-3, 1001); // a one-second record
    let table = tone_table(dt, n, |t| (2.0 * PI * 50.0 * t).sin());
    let outputs = run(table, &params(10.0, 10.0, 1, 0.0)).unwrap();
    let table = outputs["power"].as_table().unwrap();
    let Some(ColumnData::Bool(in_coi)) = table.column("in_coi") else {
        panic!()
    };
    let e_folding = e_folding_time(scale_of_frequency(K0, 10.0)); // 0.135 s
    let first_outside = in_coi.iter().position(|coi| !coi).unwrap();
    assert_eq!(first_outside, (e_folding / dt).ceil() as usize);
    let last_outside = in_coi.iter().rposition(|coi| !coi).unwrap();
    assert_eq!(last_outside, n - 1 - (e_folding / dt).ceil() as usize);
}

#[test]
fn bad_grids_are_refused_with_the_figures() {
    let table = tone_table(1e-3, 100, |t| t);
    let err = run(table.clone(), &params(10.0, 800.0, 10, 0.0)).unwrap_err();
    assert!(err.message.contains("Nyquist frequency 500"), "{err}");
    let err = run(table.clone(), &params(100.0, 10.0, 10, 0.0)).unwrap_err();
    assert!(err.message.contains("below f_min_hz"), "{err}");
    let err = run(table.clone(), &params(0.0, 10.0, 10, 0.0)).unwrap_err();
    assert!(err.message.contains("positive"), "{err}");
    let err = run(table, &params(10.0, 100.0, 2_000_000, 0.0)).unwrap_err();
    assert!(
        err.message.contains("(2000000 frequencies × 100 times)"),
        "{err}"
    );
}

#[test]
fn map_renders_for_a_small_transform() {
    let table = tone_table(1e-4, 2000, |t| (2.0 * PI * 500.0 * t).sin());
    let outputs = run(table, &params(100.0, 2000.0, 40, 0.0)).unwrap();
    let Artifact::Figure(figure) = &outputs["map"] else {
        panic!("map is not a figure")
    };
    assert!(figure.svg.contains("Morlet wavelet power"));
    assert!(figure.png.len() > 1000);
}
