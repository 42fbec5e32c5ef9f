//! Shared plotting: one drawing, rendered twice (SVG for papers, PNG for a quick look).
//!
//! Text in the bitmap needs glyphs, and a CI machine may have no system fonts, so the crate
//! carries DejaVu Sans (`assets/DejaVuSans.ttf`, Bitstream Vera license in
//! `assets/DejaVu-LICENSE`) and registers it once as the `sans-serif` family.

use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use squeal_contract::artifact::Figure;
use squeal_contract::value::StageError;

const FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The family every figure uses: the font above, registered under this name.
pub const FONT: &str = "sans-serif";

/// Figure size in pixels (SVG user units and PNG pixels alike).
pub const DEFAULT_SIZE: (u32, u32) = (1000, 640);

/// A plotting error from either backend, flattened to its message.
pub type DrawResult = Result<(), String>;

/// Something that draws itself on any plotters backend.
pub trait Drawing {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult;
}

/// Turns a backend error into the one-line message of a [`DrawResult`].
pub fn drawing_error(err: impl std::fmt::Display) -> String {
    err.to_string()
}

fn register_font() -> Result<(), StageError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(StageError::new(
            "the bundled font DejaVuSans.ttf is not a valid font",
        ))
    }
}

/// Renders `drawing` as SVG and as PNG, on a white background.
pub fn render(drawing: &impl Drawing, (width, height): (u32, u32)) -> Result<Figure, StageError> {
    register_font()?;
    let figure_error = |message: String| StageError::new(format!("drawing the figure: {message}"));

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        root.fill(&WHITE)
            .map_err(drawing_error)
            .map_err(figure_error)?;
        drawing.draw(&root).map_err(figure_error)?;
        root.present()
            .map_err(drawing_error)
            .map_err(figure_error)?;
    }

    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE)
            .map_err(drawing_error)
            .map_err(figure_error)?;
        drawing.draw(&root).map_err(figure_error)?;
        root.present()
            .map_err(drawing_error)
            .map_err(figure_error)?;
    }
    let png = encode_png(&rgb, width, height)
        .map_err(|err| StageError::new(format!("encoding the PNG: {err}")))?;
    Ok(Figure { svg, png })
}

fn encode_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, png::EncodingError> {
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(bytes)
}

/// Viridis colour of `level` in [0, 1] (clamped): perceptually uniform, readable in grey.
/// Linear between nine samples of the matplotlib map, which the eye cannot tell from it.
pub fn viridis(level: f64) -> RGBColor {
    const ANCHORS: [(f64, f64, f64); 9] = [
        (68.0, 1.0, 84.0),
        (71.0, 44.0, 122.0),
        (59.0, 81.0, 139.0),
        (44.0, 113.0, 142.0),
        (33.0, 144.0, 141.0),
        (39.0, 173.0, 129.0),
        (92.0, 200.0, 99.0),
        (170.0, 220.0, 50.0),
        (253.0, 231.0, 37.0),
    ];
    let position = level.clamp(0.0, 1.0) * (ANCHORS.len() - 1) as f64;
    let low = (position.floor() as usize).min(ANCHORS.len() - 2);
    let weight = position - low as f64;
    let (a, b) = (ANCHORS[low], ANCHORS[low + 1]);
    let mix = |x: f64, y: f64| (x + (y - x) * weight).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// A colour for the `idx`-th series of a figure (shapes, tones): distinguishable and printable.
pub fn series_color(idx: usize) -> RGBColor {
    const PALETTE: [RGBColor; 6] = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
        RGBColor(23, 190, 207),
    ];
    PALETTE[idx % PALETTE.len()]
}

/// A vertical colour bar over `range`, in `levels` viridis steps from its bottom to its top,
/// with its axis labelled `label` (ticks as [`tick_label`]).
pub fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    range: std::ops::Range<f64>,
    label: &str,
    levels: usize,
) -> DrawResult {
    let (low, high) = (range.start, range.end);
    let mut bar = ChartBuilder::on(area)
        .margin_top(45)
        .margin_bottom(56)
        .margin_right(10)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..1.0, range)
        .map_err(drawing_error)?;
    bar.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_desc(label)
        .y_label_formatter(&|value| tick_label(*value))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()
        .map_err(drawing_error)?;
    let levels = levels.max(2);
    let at = |step: usize| low + (high - low) * step as f64 / levels as f64;
    bar.draw_series((0..levels).map(|step| {
        let color = viridis(step as f64 / (levels - 1) as f64);
        Rectangle::new([(0.0, at(step)), (1.0, at(step + 1))], color.filled())
    }))
    .map_err(drawing_error)?;
    Ok(())
}

/// Short engineering label for an axis tick: `1.5k`, `250`, `0.01`.
pub fn tick_label(value: f64) -> String {
    let magnitude = value.abs();
    if magnitude >= 1e6 {
        format!("{}M", trim_float(value / 1e6))
    } else if magnitude >= 1e3 {
        format!("{}k", trim_float(value / 1e3))
    } else {
        trim_float(value)
    }
}

fn trim_float(value: f64) -> String {
    let text = format!("{value:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text.is_empty() || text == "-" {
        "0".into()
    } else {
        text.into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Diagonal;

    impl Drawing for Diagonal {
        fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
            let mut chart = ChartBuilder::on(root)
                .caption("diagonal", (FONT, 20))
                .x_label_area_size(30)
                .y_label_area_size(40)
                .build_cartesian_2d(0.0..1.0, 0.0..1.0)
                .map_err(drawing_error)?;
            chart.configure_mesh().draw().map_err(drawing_error)?;
            chart
                .draw_series(LineSeries::new([(0.0, 0.0), (1.0, 1.0)], &BLACK))
                .map_err(drawing_error)?;
            Ok(())
        }
    }

    #[test]
    fn renders_svg_and_png_with_text() {
        let figure = render(&Diagonal, (200, 150)).unwrap();
        assert!(figure.svg.starts_with("<svg"), "{}", &figure.svg[..40]);
        assert!(figure.svg.contains("diagonal"));
        assert_eq!(&figure.png[1..4], b"PNG");
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(1500.0), "1.5k");
        assert_eq!(tick_label(250.0), "250");
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(2e6), "2M");
    }
}
