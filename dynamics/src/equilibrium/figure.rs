//! The contact pressure over the pad faces: one panel per side (upper, lower), each pair a
//! round marker at (angle, radius) coloured by its pressure r_n / area.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::artifact::Figure;
use crate::artifact::mesh::Mesh;
use crate::plot::{self, DrawResult, Drawing, drawing_error};
use crate::stage::StageError;

struct PressureMap<'a> {
    mesh: &'a Mesh,
    pressure: &'a [f64],
}

impl Drawing for PressureMap<'_> {
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
        let peak = self.pressure.iter().copied().fold(0.0, f64::max);
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
                .zip(self.pressure)
                .filter(|((pair, _), _)| (pair.normal[2] >= 0.0) == upper)
                .map(|((_, &(angle, radius)), &pressure)| {
                    let level = if peak > 0.0 { pressure / peak } else { 0.0 };
                    let color = if pressure > 0.0 {
                        plot::viridis(level)
                    } else {
                        RGBColor(200, 200, 200)
                    };
                    Circle::new((angle, radius), 7, color.filled())
                });
            chart.draw_series(markers).map_err(drawing_error)?;
        }
        // Colour bar: 0 to the peak pressure (grey: open pairs).
        plot::colour_bar(
            &colorbar,
            0.0..peak.max(f64::MIN_POSITIVE),
            "pressure (Pa)",
            64,
        )?;
        Ok(())
    }
}

/// The pressure figure of a set of contact pairs.
pub fn pressure_figure(mesh: &Mesh, pressure: &[f64]) -> Result<Figure, StageError> {
    plot::render(&PressureMap { mesh, pressure }, plot::DEFAULT_SIZE)
}
