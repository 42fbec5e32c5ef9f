//! A field over the pad faces, one value per contact pair: one panel per side (upper, lower),
//! each pair a round marker at its disc point's (angle, radius), coloured by its value (grey
//! where it has none): the equilibrium's contact pressure, the transient's share of steps
//! sticking.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::artifact::Figure;
use crate::artifact::mesh::Mesh;
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::StageError;

struct PadFaceMap<'a> {
    mesh: &'a Mesh,
    values: &'a [Option<f64>],
    /// The colour bar's top (its bottom is 0) and label.
    peak: f64,
    label: &'a str,
}

impl Drawing for PadFaceMap<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let polar: Vec<(f64, f64)> = self
            .mesh
            .contact_pairs
            .iter()
            .map(|pair| {
                let x = pair.disc_position(&self.mesh.nodes);
                (
                    x[1].atan2(x[0]).to_degrees(),
                    (x[0] * x[0] + x[1] * x[1]).sqrt(),
                )
            })
            .collect();
        let peak = self.peak;
        let span = |values: &mut dyn Iterator<Item = f64>| {
            let (low, high) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), v| {
                (low.min(v), high.max(v))
            });
            let margin = 0.08 * (high - low).max(1e-9);
            (low - margin)..(high + margin)
        };
        let angles = span(&mut polar.iter().map(|(angle, _)| *angle));
        let radii = span(&mut polar.iter().map(|(_, radius)| *radius));
        let (plots, colorbar) = root.split_horizontally(root.dim_in_pixel().0 as i32 - 120);
        let panels = plots.split_evenly((1, 2));
        for (panel, (label, upper)) in panels
            .iter()
            .zip([("upper pad face", true), ("lower pad face", false)])
        {
            let mut chart = ChartBuilder::on(panel)
                .caption(label, (plot::FONT, 20))
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(70)
                .build_cartesian_2d(angles.clone(), radii.clone())
                .map_err(drawing_error)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc("angle (degrees)")
                .y_desc("radius (m)")
                .label_style((plot::FONT, 14))
                .axis_desc_style((plot::FONT, 15))
                .draw()
                .map_err(drawing_error)?;
            let markers = self
                .mesh
                .contact_pairs
                .iter()
                .zip(&polar)
                .zip(self.values)
                .filter(|((pair, _), _)| (pair.normal[2] >= 0.0) == upper)
                .map(|((_, &(angle, radius)), &value)| {
                    let color = match value {
                        Some(value) => plot::viridis(if peak > 0.0 { value / peak } else { 0.0 }),
                        None => RGBColor(200, 200, 200),
                    };
                    Circle::new((angle, radius), 7, color.filled())
                });
            chart.draw_series(markers).map_err(drawing_error)?;
        }
        plot::colour_bar(&colorbar, 0.0..peak.max(f64::MIN_POSITIVE), self.label, 64)?;
        Ok(())
    }
}

/// The map of `values` (one per pair of `mesh`, `None` grey) on the pad faces, coloured from 0
/// to `peak`, the colour bar labelled `label`.
pub fn figure(
    mesh: &Mesh,
    values: &[Option<f64>],
    peak: f64,
    label: &str,
) -> Result<Figure, StageError> {
    let map = PadFaceMap {
        mesh,
        values,
        peak,
        label,
    };
    plot::render(&map, plot::DEFAULT_SIZE)
}
