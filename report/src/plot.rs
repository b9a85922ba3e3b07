//! PNG figures: error against time with Pareto frontiers, and scaling.
//!
//! Drawn through `hyperpbd_render::chart` (plotters' bitmap backend, PNG,
//! DejaVu Sans embedded in the binary, so figures look the same on every
//! machine). Every figure carries a footer naming the machine and the
//! adapter that produced it.

use crate::pareto::frontier;
use crate::scaling::{Fit, ScalingPoint};
use crate::sweep::CaseResult;
use hyperpbd::{BackendKind, Precision};
use hyperpbd_render::chart::{Area, FONT, drawing_error as err, png};
use plotters::prelude::*;

/// A backend's colour.
pub fn color(backend: BackendKind) -> RGBColor {
    match backend {
        BackendKind::Cpu | BackendKind::Auto => RGBColor(31, 119, 180),
        BackendKind::Gpu(Precision::F32) => RGBColor(230, 110, 0),
        BackendKind::Gpu(Precision::F64) => RGBColor(44, 160, 44),
    }
}

/// Title on top, footer lines at the bottom; returns the middle.
pub(crate) fn frame<'a>(
    root: &Area<'a>,
    title: &str,
    footer: &[String],
) -> Result<Area<'a>, String> {
    let (_, h) = root.dim_in_pixel();
    let footer_h = 8 + 20 * footer.len() as u32;
    let (top, rest) = root.split_vertically(44);
    let (middle, bottom) = rest.split_vertically(h - 44 - footer_h);
    top.draw(&Text::new(
        title.to_string(),
        (16, 12),
        (FONT, 24).into_font().color(&BLACK),
    ))
    .map_err(err)?;
    for (k, line) in footer.iter().enumerate() {
        bottom
            .draw(&Text::new(
                line.clone(),
                (16, 4 + 20 * k as i32),
                (FONT, 15).into_font().color(&RGBColor(70, 70, 70)),
            ))
            .map_err(err)?;
    }
    Ok(middle)
}

pub(crate) fn log_bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (1e-3, 1.0);
    }
    let lo = 10f64.powf(lo.log10().floor() - 0.05);
    let hi = 10f64.powf(hi.log10().ceil() + 0.05);
    (lo, if hi > lo { hi } else { lo * 10.0 })
}

pub(crate) fn sci(v: f64) -> String {
    let e = v.log10().round();
    if (v.log10() - e).abs() < 1e-6 {
        if (-2.0..=3.0).contains(&e) {
            format!("{}", 10f64.powf(e))
        } else {
            format!("1e{}", e as i32)
        }
    } else {
        String::new()
    }
}

/// One error-vs-time panel: every point of every backend, each backend's
/// frontier as a line; `target` as a dashed line; `labels` annotates
/// frontier points with (substeps, iterations).
fn pareto_panel(
    area: &Area<'_>,
    case: &CaseResult,
    target: Option<f64>,
    labels: bool,
    big: bool,
) -> Result<(), String> {
    let (x0, x1) = log_bounds(case.points.iter().map(|p| p.ms_per_sim_second));
    let (y0, y1) = log_bounds(
        case.points
            .iter()
            .filter_map(|p| p.error)
            .chain(target)
            .chain(case.reference.as_ref().map(|r| r.uncertainty)),
    );
    let (title, label, desc) = if big { (22, 16, 17) } else { (16, 12, 13) };
    let mut chart = ChartBuilder::on(area)
        .caption(case.title.clone(), (FONT, title))
        .margin(8)
        .x_label_area_size(if big { 48 } else { 38 })
        .y_label_area_size(if big { 70 } else { 56 })
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("wall ms per simulated second")
        .y_desc(case.metric.clone())
        .label_style((FONT, label))
        .axis_desc_style((FONT, desc))
        .x_label_formatter(&|v| sci(*v))
        .y_label_formatter(&|v| sci(*v))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(err)?;
    if let Some(t) = target {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x0, t), (x1, t)],
                6,
                4,
                RGBColor(120, 120, 120).stroke_width(1),
            ))
            .map_err(err)?
            .label(format!("target {}", sci_any(t)))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(120, 120, 120)));
    }
    if let Some(r) = &case.reference
        && r.uncertainty > 0.0
    {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x0, r.uncertainty), (x1, r.uncertainty)],
                2,
                4,
                RGBColor(170, 0, 170).stroke_width(1),
            ))
            .map_err(err)?
            .label("reference's own error (est.)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(170, 0, 170)));
    }
    let radius = if big { 5 } else { 3 };
    for backend in BackendKind::ALL {
        let c = color(backend);
        let pts: Vec<(f64, f64)> = case
            .points
            .iter()
            .filter(|p| p.backend == backend)
            .filter_map(|p| p.error.map(|e| (p.ms_per_sim_second, e.max(y0))))
            .filter(|(x, _)| x.is_finite())
            .collect();
        if pts.is_empty() {
            continue;
        }
        chart
            .draw_series(
                pts.iter()
                    .map(|&p| Circle::new(p, radius, c.stroke_width(1))),
            )
            .map_err(err)?
            .label(backend.name())
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, c.filled()));
        let front: Vec<(f64, f64)> = frontier(&case.points, backend)
            .into_iter()
            .map(|i| {
                let p = &case.points[i];
                (p.ms_per_sim_second, p.error.unwrap_or(y0).max(y0))
            })
            .collect();
        chart
            .draw_series(LineSeries::new(front.clone(), c.stroke_width(2)))
            .map_err(err)?;
        chart
            .draw_series(front.iter().map(|&p| Circle::new(p, radius, c.filled())))
            .map_err(err)?;
        if labels {
            for i in frontier(&case.points, backend) {
                let p = &case.points[i];
                let text = if case.case.uses_iterations() {
                    format!("{}×{}", p.substeps, p.iterations)
                } else {
                    format!("{}", p.substeps)
                };
                let at = (p.ms_per_sim_second, p.error.unwrap_or(y0).max(y0));
                chart
                    .draw_series(std::iter::once(
                        EmptyElement::at(at)
                            + Text::new(text, (7, 2), (FONT, 13).into_font().color(&c)),
                    ))
                    .map_err(err)?;
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 200, 200))
        .label_font((FONT, label))
        .draw()
        .map_err(err)?;
    Ok(())
}

pub(crate) fn sci_any(v: f64) -> String {
    let s = sci(v);
    if s.is_empty() { format!("{v:.1e}") } else { s }
}

/// All cases, one panel each, on a grid.
pub fn pareto_grid(cases: &[CaseResult], footer: &[String]) -> Result<Vec<u8>, String> {
    let cols = 4usize.min(cases.len().max(1));
    let rows = cases.len().div_ceil(cols).max(1);
    let (w, h) = (
        470 * cols as u32,
        430 * rows as u32 + 44 + 8 + 20 * footer.len() as u32,
    );
    png(w, h, |root| {
        let middle = frame(
            root,
            "Error against wall time per simulated second (filled + line: each backend's Pareto frontier)",
            footer,
        )?;
        let panels = middle.split_evenly((rows, cols));
        for (case, panel) in cases.iter().zip(panels.iter()) {
            pareto_panel(panel, case, None, false, false)?;
        }
        Ok(())
    })
}

/// One case, large, with the target line and frontier labels.
pub fn pareto_single(case: &CaseResult, target: f64, footer: &[String]) -> Result<Vec<u8>, String> {
    let (w, h) = (1100, 720 + 8 + 20 * footer.len() as u32);
    png(w, h, |root| {
        let middle = frame(
            root,
            "What accuracy costs: error against time (labels: substeps×iterations on each frontier)",
            footer,
        )?;
        pareto_panel(&middle, case, Some(target), true, true)
    })
}

/// Time per step against particle count, with fitted power laws.
pub fn scaling(
    points: &[ScalingPoint],
    fits: &[Fit],
    footer: &[String],
) -> Result<Vec<u8>, String> {
    let (w, h) = (1100, 700 + 8 + 20 * footer.len() as u32);
    png(w, h, |root| {
        let middle = frame(
            root,
            "Time per step against particle count (hanging cloth, 10 substeps × 1 iteration)",
            footer,
        )?;
        let (x0, x1) = log_bounds(
            points
                .iter()
                .filter(|p| p.ms_per_step.is_some())
                .map(|p| p.particles as f64),
        );
        let (y0, y1) = log_bounds(points.iter().filter_map(|p| p.ms_per_step));
        let mut chart = ChartBuilder::on(&middle)
            .margin(12)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("particles")
            .y_desc("wall ms per step (median)")
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 17))
            .x_label_formatter(&|v| sci_count(*v))
            .y_label_formatter(&|v| sci(*v))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(err)?;
        for backend in BackendKind::ALL {
            let c = color(backend);
            let pts: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.backend == backend)
                .filter_map(|p| p.ms_per_step.map(|t| (p.particles as f64, t)))
                .collect();
            if pts.is_empty() {
                continue;
            }
            let fit = fits.iter().find(|f| f.backend == backend);
            let label = match fit {
                Some(f) => format!("{}: t ∝ P^{:.2}", backend.name(), f.exponent),
                None => backend.name().to_string(),
            };
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(1)))
                .map_err(err)?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 5, c.filled())))
                .map_err(err)?
                .label(label)
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, c.filled()));
            if let Some(f) = fit {
                let (lo, hi) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), (x, _)| {
                    (a.min(*x), b.max(*x))
                });
                let line: Vec<(f64, f64)> = (0..=20)
                    .map(|k| {
                        let x = lo * (hi / lo).powf(f64::from(k) / 20.0);
                        (x, f.prefactor_ms * x.powf(f.exponent))
                    })
                    .collect();
                chart
                    .draw_series(DashedLineSeries::new(line, 8, 5, c.stroke_width(2)))
                    .map_err(err)?;
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(200, 200, 200))
            .label_font((FONT, 16))
            .draw()
            .map_err(err)?;
        Ok(())
    })
}

fn sci_count(v: f64) -> String {
    let e = v.log10().round();
    if (v.log10() - e).abs() < 1e-6 {
        match e as i32 {
            3 => "1k".into(),
            4 => "10k".into(),
            5 => "100k".into(),
            6 => "1M".into(),
            7 => "10M".into(),
            k => format!("1e{k}"),
        }
    } else {
        String::new()
    }
}
