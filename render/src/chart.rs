//! Charts (as opposed to scene pictures): plotters' bitmap backend into an
//! RGB buffer, encoded with the `png` crate. Text uses DejaVu Sans
//! embedded in the binary (the `dejavu` crate), so charts look the same on
//! every machine and need no system fonts. The accuracy report's figures
//! and `hyperpbd sweep --plot` draw through [`png()`].
//!
//! ```text
//! line_chart: one polyline with markers per series, y linear or log10,
//!             x the swept value; legend when there is more than one series
//! ```

use plotters::coord::Shift;
use plotters::prelude::*;
use std::sync::OnceLock;

/// The drawing area a chart draws into.
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// The font family name text is drawn with.
pub const FONT: &str = "sans-serif";

/// A drawing error as text.
pub fn drawing_error<E: std::fmt::Display>(e: E) -> String {
    format!("drawing: {e}")
}

/// Registers the embedded font once.
fn font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "the embedded DejaVu Sans font did not load".to_string())
        })
        .clone()
}

/// Renders `draw` into a `width × height` PNG and returns its bytes.
pub fn png(
    width: u32,
    height: u32,
    draw: impl FnOnce(&Area<'_>) -> Result<(), String>,
) -> Result<Vec<u8>, String> {
    font()?;
    let mut rgb = vec![255u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(drawing_error)?;
        draw(&root)?;
        root.present().map_err(drawing_error)?;
    }
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(drawing_error)?;
        writer.write_image_data(&rgb).map_err(drawing_error)?;
        writer.finish().map_err(drawing_error)?;
    }
    Ok(bytes)
}

/// One named polyline of a [`line_chart`].
pub struct Series {
    /// Legend text (unused with a single series).
    pub name: String,
    /// (x, y) points in x order.
    pub points: Vec<(f64, f64)>,
}

/// A 900 × 600 PNG of `series` against x, y on a log10 axis when `log_y`
/// (non-positive values are then left out).
pub fn line_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_y: bool,
) -> Result<Vec<u8>, String> {
    let usable = |y: f64| y.is_finite() && (!log_y || y > 0.0);
    let points = || {
        series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|p| p.0.is_finite() && usable(p.1))
    };
    let span = |values: Vec<f64>| {
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        match (lo.is_finite(), lo < hi) {
            (false, _) => (0.0, 1.0),
            (true, true) => (lo, hi),
            (true, false) => (lo - 0.5 * lo.abs().max(1.0), hi + 0.5 * hi.abs().max(1.0)),
        }
    };
    let (x0, x1) = span(points().map(|p| p.0).collect());
    let y_of = |y: f64| if log_y { y.log10() } else { y };
    let (y0, y1) = span(points().map(|p| y_of(p.1)).collect());
    png(900, 600, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(84)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(drawing_error)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(if log_y {
                format!("log10 {y_label}")
            } else {
                y_label.to_string()
            })
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .draw()
            .map_err(drawing_error)?;
        for (k, s) in series.iter().enumerate() {
            let color = Palette99::pick(k).to_rgba();
            let line: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|p| p.0.is_finite() && usable(p.1))
                .map(|&(x, y)| (x, y_of(y)))
                .collect();
            chart
                .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))
                .map_err(drawing_error)?
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
            chart
                .draw_series(line.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(drawing_error)?;
        }
        if series.len() > 1 {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 14))
                .draw()
                .map_err(drawing_error)?;
        }
        Ok(())
    })
}
