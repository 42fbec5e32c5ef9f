//! The `map` figure of `wavelet`: the time–frequency power in dB, with the cone of influence.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{e_folding_time, scale_of_frequency};
use crate::plot::{self, DrawResult, Drawing, drawing_error};

/// The 1–2–5 values (…, 100, 200, 500, 1000, …) between `low` and `high`: ticks of a log axis.
fn one_two_five_ticks(low: f64, high: f64) -> Vec<f64> {
    let mut ticks = Vec::new();
    let mut decade = 10f64.powf(low.log10().floor());
    while decade <= high {
        for multiple in [1.0, 2.0, 5.0] {
            let tick = multiple * decade;
            if tick >= low && tick <= high {
                ticks.push(tick);
            }
        }
        decade *= 10.0;
    }
    ticks
}

/// The time–frequency heat map: power in dB below its maximum, viridis, log frequency axis,
/// the cone of influence as white lines.
pub(super) struct PowerMap<'a> {
    pub(super) column: &'a str,
    pub(super) times: &'a [f64],
    pub(super) freqs_hz: &'a [f64],
    /// Frequency-major, `times.len()` values per frequency.
    pub(super) power: &'a [f64],
    pub(super) k0: f64,
    pub(super) t_first: f64,
    pub(super) t_last: f64,
    pub(super) range_db: f64,
}

/// Heat-map cells drawn at most, per axis: enough for the eye, small enough for an SVG.
const MAP_MAX_COLUMNS: usize = 400;
const MAP_MAX_ROWS: usize = 200;
/// Colour levels of the map; runs of equal level along time are merged into one rectangle.
const MAP_LEVELS: f64 = 64.0;

impl PowerMap<'_> {
    /// Max-pools the power onto at most MAP_MAX_ROWS × MAP_MAX_COLUMNS cells (peaks survive).
    fn pooled(&self) -> PooledPower {
        let n_times = self.times.len();
        let row_groups = groups(self.freqs_hz.len(), MAP_MAX_ROWS);
        let column_groups = groups(self.times.len(), MAP_MAX_COLUMNS);
        let cells = row_groups
            .iter()
            .map(|&(row_first, row_end)| {
                column_groups
                    .iter()
                    .map(|&(column_first, column_end)| {
                        self.power[row_first * n_times..row_end * n_times]
                            .chunks_exact(n_times)
                            .flat_map(|row| &row[column_first..column_end])
                            .copied()
                            .fold(0.0, f64::max)
                    })
                    .collect()
            })
            .collect();
        PooledPower {
            row_groups,
            column_groups,
            cells,
        }
    }
}

/// The map's cells: `cells[row][column]` is the largest power over the frequencies
/// `row_groups[row]` and the times `column_groups[column]` (`(first, end)` index ranges).
struct PooledPower {
    row_groups: Vec<(usize, usize)>,
    column_groups: Vec<(usize, usize)>,
    cells: Vec<Vec<f64>>,
}

/// Splits `n` items into at most `max_groups` contiguous `(first, end)` ranges.
fn groups(n: usize, max_groups: usize) -> Vec<(usize, usize)> {
    let n_groups = n.min(max_groups);
    (0..n_groups)
        .map(|group| (group * n / n_groups, (group + 1) * n / n_groups))
        .collect()
}

impl Drawing for PowerMap<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let PooledPower {
            row_groups,
            column_groups,
            cells,
        } = self.pooled();
        let peak = cells.iter().flatten().copied().fold(0.0, f64::max);
        let level_of = |power: f64| -> f64 {
            if peak <= 0.0 || power <= 0.0 {
                return 0.0;
            }
            let db = 10.0 * (power / peak).log10();
            ((1.0 + db / self.range_db).clamp(0.0, 1.0) * (MAP_LEVELS - 1.0)).round()
        };

        // Cell edges: geometric midpoints in frequency, arithmetic midpoints in time.
        let n_freqs = self.freqs_hz.len();
        let ratio = if n_freqs > 1 {
            (self.freqs_hz[n_freqs - 1] / self.freqs_hz[0]).powf(0.5 / (n_freqs - 1) as f64)
        } else {
            1.1
        };
        let freq_low = |idx: usize| self.freqs_hz[idx] / ratio;
        let freq_high = |idx: usize| self.freqs_hz[idx] * ratio;
        let step = if self.times.len() > 1 {
            self.times[1] - self.times[0]
        } else {
            1.0
        };
        let time_low = |idx: usize| self.times[idx] - 0.5 * step;
        let time_high = |idx: usize| self.times[idx] + 0.5 * step;
        let x_range = time_low(0)..time_high(self.times.len() - 1);
        let y_range = freq_low(0)..freq_high(n_freqs - 1);

        let (main, colorbar) = root.split_horizontally(root.dim_in_pixel().0 as i32 - 110);
        let mut chart = ChartBuilder::on(&main)
            .caption(
                format!("Morlet wavelet power of {} (k₀ = {})", self.column, self.k0),
                (plot::FONT, 22),
            )
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(
                x_range.clone(),
                y_range
                    .clone()
                    .log_scale()
                    .with_key_points(one_two_five_ticks(y_range.start, y_range.end)),
            )
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("time (s)")
            .y_desc("frequency (Hz)")
            .x_label_formatter(&|t| plot::tick_label(*t))
            .y_label_formatter(&|f| plot::tick_label(*f))
            .label_style((plot::FONT, 15))
            .axis_desc_style((plot::FONT, 16))
            .draw()
            .map_err(drawing_error)?;

        let mut rectangles = Vec::new();
        for (row_idx, &(row_first, row_end)) in row_groups.iter().enumerate() {
            let (f0, f1) = (freq_low(row_first), freq_high(row_end - 1));
            let mut run_start = 0;
            for column_idx in 1..=column_groups.len() {
                let run_level = level_of(cells[row_idx][run_start]);
                let run_ends = column_idx == column_groups.len()
                    || level_of(cells[row_idx][column_idx]) != run_level;
                if run_ends {
                    let t0 = time_low(column_groups[run_start].0);
                    let t1 = time_high(column_groups[column_idx - 1].1 - 1);
                    let color = plot::viridis(run_level / (MAP_LEVELS - 1.0));
                    rectangles.push(Rectangle::new([(t0, f0), (t1, f1)], color.filled()));
                    run_start = column_idx;
                }
            }
        }
        chart.draw_series(rectangles).map_err(drawing_error)?;

        // The cone of influence: t = t_first + √2 a(f) and t = t_last − √2 a(f).
        for side in [1.0, -1.0] {
            let edge = if side > 0.0 {
                self.t_first
            } else {
                self.t_last
            };
            let boundary: Vec<(f64, f64)> = self
                .freqs_hz
                .iter()
                .map(|&freq| {
                    let t = edge + side * e_folding_time(scale_of_frequency(self.k0, freq));
                    (t.clamp(x_range.start, x_range.end), freq)
                })
                .collect();
            chart
                .draw_series(LineSeries::new(boundary, WHITE.stroke_width(2)))
                .map_err(drawing_error)?;
        }

        // Colour bar, in dB below the maximum.
        plot::colour_bar(&colorbar, -self.range_db..0.0, "dB", MAP_LEVELS as usize)?;
        Ok(())
    }
}
