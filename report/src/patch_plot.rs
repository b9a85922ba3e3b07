//! The patch study's figure: one log-log panel per case, error against
//! wall ms per simulated second, one colour per method.
//!
//! ```text
//! dots          every point (errors below FLOOR drawn at FLOOR: exact to
//!               rounding has no logarithm)
//! filled + line each method's Pareto frontier
//! black ring    the frontier over all methods
//! dashed line   the summary's target error
//! labels        substeps×iterations (XPBD) or substeps×N Newton budget
//!               (implicit) on each method's frontier
//! ```

use crate::patch_study::{PatchMethod, PatchPoint, PatchResult, PatchSection};
use crate::plot::{frame, log_bounds, sci, sci_any};
use hyperpbd_render::chart::{Area, FONT, drawing_error as err, png};
use plotters::prelude::*;

/// Errors below this are drawn at it.
pub const FLOOR: f64 = 1e-16;

/// A method's colour.
pub fn color(method: PatchMethod) -> RGBColor {
    match method {
        PatchMethod::Xpbd => RGBColor(31, 119, 180),
        PatchMethod::PrimalResidual => RGBColor(230, 110, 0),
        PatchMethod::Implicit => RGBColor(44, 160, 44),
    }
}

fn drawn(p: &PatchPoint) -> Option<(f64, f64)> {
    let e = p.error.filter(|e| e.is_finite())?;
    p.ms_per_sim_second
        .is_finite()
        .then_some((p.ms_per_sim_second, e.max(FLOOR)))
}

fn frontier_label(p: &PatchPoint) -> String {
    match p.method {
        PatchMethod::Xpbd | PatchMethod::PrimalResidual => format!("{}×{}", p.substeps, p.budget),
        PatchMethod::Implicit => format!("{}×N{}", p.substeps, p.budget),
    }
}

fn panel(area: &Area<'_>, r: &PatchResult, target: f64) -> Result<(), String> {
    let (x0, x1) = log_bounds(r.points.iter().filter_map(drawn).map(|(x, _)| x));
    let (y0, y1) = log_bounds(
        r.points
            .iter()
            .filter_map(drawn)
            .map(|(_, y)| y)
            .chain(std::iter::once(target)),
    );
    let mut chart = ChartBuilder::on(area)
        .caption(format!("patch {}", r.name), (FONT, 20))
        .margin(8)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("wall ms per simulated second (cpu-f64, one thread)")
        .y_desc("max |x − F X| over the interior (m)")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 15))
        .x_label_formatter(&|v| sci(*v))
        .y_label_formatter(&|v| sci(*v))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(err)?;
    chart
        .draw_series(DashedLineSeries::new(
            vec![(x0, target), (x1, target)],
            6,
            4,
            RGBColor(120, 120, 120).stroke_width(1),
        ))
        .map_err(err)?
        .label(format!("target {}", sci_any(target)))
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(120, 120, 120)));
    for method in PatchMethod::ALL {
        let c = color(method);
        let pts: Vec<(f64, f64)> = r
            .points
            .iter()
            .filter(|p| p.method == method)
            .filter_map(drawn)
            .collect();
        if pts.is_empty() {
            continue;
        }
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.stroke_width(1))))
            .map_err(err)?
            .label(method.name())
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, c.filled()));
        let mut front: Vec<&PatchPoint> = r
            .points
            .iter()
            .filter(|p| p.method == method && p.frontier)
            .collect();
        front.sort_by(|a, b| a.ms_per_sim_second.total_cmp(&b.ms_per_sim_second));
        let line: Vec<(f64, f64)> = front.iter().filter_map(|p| drawn(p)).collect();
        chart
            .draw_series(LineSeries::new(line.clone(), c.stroke_width(2)))
            .map_err(err)?;
        chart
            .draw_series(line.iter().map(|&p| Circle::new(p, 4, c.filled())))
            .map_err(err)?;
        for p in front {
            if let Some(at) = drawn(p) {
                chart
                    .draw_series(std::iter::once(
                        EmptyElement::at(at)
                            + Text::new(
                                frontier_label(p),
                                (7, 2),
                                (FONT, 12).into_font().color(&c),
                            ),
                    ))
                    .map_err(err)?;
            }
        }
    }
    let overall: Vec<(f64, f64)> = r
        .points
        .iter()
        .filter(|p| p.overall_frontier)
        .filter_map(drawn)
        .collect();
    chart
        .draw_series(
            overall
                .iter()
                .map(|&p| Circle::new(p, 8, BLACK.stroke_width(2))),
        )
        .map_err(err)?
        .label("frontier over all methods")
        .legend(|(x, y)| Circle::new((x + 10, y), 6, BLACK.stroke_width(2)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 200, 200))
        .label_font((FONT, 13))
        .draw()
        .map_err(err)?;
    Ok(())
}

/// Every case of `section`, one panel each, side by side (two per row).
pub fn patch_figure(section: &PatchSection, footer: &[String]) -> Result<Vec<u8>, String> {
    let n = section.cases.len().max(1);
    let cols = n.min(2);
    let rows = n.div_ceil(cols);
    let (w, h) = (
        680 * cols as u32,
        560 * rows as u32 + 44 + 8 + 20 * footer.len() as u32,
    );
    png(w, h, |root| {
        let middle = frame(
            root,
            &format!(
                "Patch test: error after {} s against time (filled + line: each method's frontier; ring: over all)",
                section.seconds
            ),
            footer,
        )?;
        let panels = middle.split_evenly((rows, cols));
        for (r, area) in section.cases.iter().zip(panels.iter()) {
            panel(area, r, section.target)?;
        }
        Ok(())
    })
}
