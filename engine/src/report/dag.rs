//! The run's DAG as an inline SVG: instances in columns by depth (longest path from a root),
//! boxes coloured by status, edges as curves from left to right.

use std::fmt::Write;

use super::{InstanceView, escape};

const BOX_WIDTH: f64 = 190.0;
const BOX_HEIGHT: f64 = 40.0;
const COLUMN_GAP: f64 = 60.0;
const ROW_GAP: f64 = 14.0;
const MARGIN: f64 = 10.0;

/// The fill of a status's box (ran, cached, failed, skipped, not in the last run).
pub fn status_colour(status: &str) -> &'static str {
    match status {
        "ran" => "#b7e1b0",
        "cached" => "#c9d9f2",
        "failed" => "#f4a6a6",
        "skipped" => "#e4e4e4",
        _ => "#ffffff",
    }
}

/// `edges[i]`: the instances `i` reads from, in `views` order.
pub fn svg(views: &[InstanceView], edges: &[Vec<usize>]) -> String {
    // Depth by longest path; views come in topological order, so one pass suffices.
    let mut depth = vec![0usize; views.len()];
    for idx in 0..views.len() {
        depth[idx] = edges[idx]
            .iter()
            .map(|up| depth[*up] + 1)
            .max()
            .unwrap_or(0);
    }
    let n_columns = depth.iter().max().map_or(0, |max| max + 1);
    let mut row = vec![0usize; views.len()];
    let mut rows_in = vec![0usize; n_columns];
    for idx in 0..views.len() {
        row[idx] = rows_in[depth[idx]];
        rows_in[depth[idx]] += 1;
    }
    let n_rows = rows_in.iter().copied().max().unwrap_or(0);
    let x = |idx: usize| MARGIN + depth[idx] as f64 * (BOX_WIDTH + COLUMN_GAP);
    let y = |idx: usize| MARGIN + row[idx] as f64 * (BOX_HEIGHT + ROW_GAP);
    let width = 2.0 * MARGIN + n_columns as f64 * (BOX_WIDTH + COLUMN_GAP) - COLUMN_GAP;
    let height = 2.0 * MARGIN + n_rows as f64 * (BOX_HEIGHT + ROW_GAP) - ROW_GAP;

    let mut svg = String::new();
    let _ = write!(
        svg,
        r#"<svg class="dag" xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="11">"#
    );
    for (idx, ups) in edges.iter().enumerate() {
        for &up in ups {
            let (x0, y0) = (x(up) + BOX_WIDTH, y(up) + BOX_HEIGHT / 2.0);
            let (x1, y1) = (x(idx), y(idx) + BOX_HEIGHT / 2.0);
            let bend = (x1 - x0) / 2.0;
            let _ = write!(
                svg,
                r##"<path d="M{x0:.1},{y0:.1} C{:.1},{y0:.1} {:.1},{y1:.1} {x1:.1},{y1:.1}" fill="none" stroke="#777"/>"##,
                x0 + bend,
                x1 - bend
            );
        }
    }
    for (idx, view) in views.iter().enumerate() {
        let (bx, by) = (x(idx), y(idx));
        let time = view
            .wall_s
            .map_or(String::new(), |wall| format!(", {}", seconds(wall)));
        let _ = write!(
            svg,
            r##"<g><title>{} ({}): {}</title><rect x="{bx:.1}" y="{by:.1}" width="{BOX_WIDTH}" height="{BOX_HEIGHT}" rx="4" fill="{}" stroke="#555"/><text x="{:.1}" y="{:.1}" font-weight="bold">{}</text><text x="{:.1}" y="{:.1}">{}{}</text></g>"##,
            escape(&view.name),
            escape(&view.status),
            escape(&view.reason),
            status_colour(&view.status),
            bx + 6.0,
            by + 16.0,
            escape(&shorten(&view.name, 30)),
            bx + 6.0,
            by + 32.0,
            escape(&view.status),
            escape(&time)
        );
    }
    svg.push_str("</svg>");
    svg
}

/// Seconds as a person reads them: `0.012 s`, `3.4 s`, `2 min 05 s`.
pub fn seconds(value: f64) -> String {
    if value < 1.0 {
        format!("{value:.3} s")
    } else if value < 60.0 {
        format!("{value:.1} s")
    } else {
        let whole = value.round() as u64;
        format!("{} min {:02} s", whole / 60, whole % 60)
    }
}

fn shorten(text: &str, max: usize) -> String {
    if text.chars().count() <= max {
        text.to_string()
    } else {
        let kept: String = text.chars().take(max - 1).collect();
        format!("{kept}…")
    }
}
