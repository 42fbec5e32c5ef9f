//! Fitting an observed rate: the least-squares slope of `ln y` against `ln x`.

/// The slope of the least-squares line through `(ln x, ln y)` of `points`.
pub fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points.iter().map(|(x, y)| (x.ln(), y.ln())).collect();
    let n = logs.len() as f64;
    let mean_x = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = logs.iter().map(|p| p.1).sum::<f64>() / n;
    logs.iter()
        .map(|(x, y)| (x - mean_x) * (y - mean_y))
        .sum::<f64>()
        / logs.iter().map(|(x, _)| (x - mean_x).powi(2)).sum::<f64>()
}
