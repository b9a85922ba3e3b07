//! Time per step against particle count.
//!
//! ```text
//! scene     scenes::hanging_cloth(n): n² particles, 2n(n−1) edges +
//!           2(n−1)² shear diagonals (rigid), 10 substeps × 1 iteration
//! sizes     n = 32, 64, …, 1024 (1,024 to 1,048,576 particles)
//! time      median over reps of (time of k steps) / k, after one warm-up
//!           step; k chosen so a rep lasts about the configured target
//! fit       t ≈ a · P^b by least squares on (ln P, ln t), P = particles:
//!           b = Σ (u − ū)(w − w̄) / Σ (u − ū)²,  u = ln P, w = ln t
//!           b = 1 is linear scaling; b < 1 means fixed per-step costs
//!           (submission, dispatch, read-back) still dominate
//! ```

use crate::config::Config;
use crate::progress::Progress;
use crate::timing::{load, median, time_per_step};
use hyperpbd::{BackendKind, Plan, State};
use serde::Serialize;

/// One size on one backend.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScalingPoint {
    /// The backend.
    pub backend: BackendKind,
    /// Cloth side n.
    pub n: usize,
    /// n².
    pub particles: usize,
    /// Constraint projections per step.
    pub projections: u64,
    /// Median ms per step (None when skipped).
    pub ms_per_step: Option<f64>,
    /// Rep samples, ms per step.
    pub samples: Vec<f64>,
    /// Why it was skipped.
    pub note: Option<String>,
}

/// A fitted power law.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Fit {
    /// The backend.
    pub backend: BackendKind,
    /// b in t ≈ a P^b.
    pub exponent: f64,
    /// a, in ms.
    pub prefactor_ms: f64,
    /// Points fitted.
    pub points: usize,
}

/// Least squares on (ln x, ln y): (exponent, prefactor). None with fewer
/// than two distinct x.
pub fn fit_power_law(xy: &[(f64, f64)]) -> Option<(f64, f64)> {
    let pts: Vec<(f64, f64)> = xy
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mu, mw) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (u, w)| (a + u / n, b + w / n));
    let sxx: f64 = pts.iter().map(|(u, _)| (u - mu) * (u - mu)).sum();
    if sxx == 0.0 {
        return None;
    }
    let sxy: f64 = pts.iter().map(|(u, w)| (u - mu) * (w - mw)).sum();
    let b = sxy / sxx;
    Some((b, (mw - b * mu).exp()))
}

/// Measures every size on every backend.
pub fn run(config: &Config, progress: &mut Progress) -> (Vec<ScalingPoint>, Vec<Fit>) {
    let mut points = Vec::new();
    for &n in &config.scaling_sizes {
        let scene = hyperpbd::scenes::hanging_cloth(n);
        let plan = match Plan::compile(&scene) {
            Ok(p) => p,
            Err(e) => {
                progress.note(&format!("scaling n = {n}: {e}"));
                continue;
            }
        };
        let initial = State::from_scene(&scene);
        for &backend in &config.backends {
            if !progress.available(backend) {
                continue;
            }
            let mut point = ScalingPoint {
                backend,
                n,
                particles: n * n,
                projections: plan.projections_per_step(),
                ms_per_step: None,
                samples: Vec::new(),
                note: None,
            };
            if backend == BackendKind::Cpu && n > config.cpu_scaling_max {
                point.note = Some(format!(
                    "CPU stops at n = {} in this mode",
                    config.cpu_scaling_max
                ));
                points.push(point);
                continue;
            }
            match load(backend, plan.clone(), &initial).and_then(|mut b| {
                time_per_step(b.as_mut(), &initial, config.reps, config.time_target)
            }) {
                Ok(samples) => {
                    point.samples = samples.iter().map(|s| s * 1000.0).collect();
                    point.ms_per_step = Some(median(&point.samples));
                }
                Err(e) => point.note = Some(e),
            }
            progress.line(&format!(
                "scaling {:>8} {:>9} particles: {}",
                backend.name(),
                n * n,
                match (&point.ms_per_step, &point.note) {
                    (Some(ms), _) => format!("{ms:.3} ms/step"),
                    (None, Some(why)) => format!("SKIPPED: {why}"),
                    (None, None) => "SKIPPED".into(),
                }
            ));
            points.push(point);
        }
    }
    let fits = config
        .backends
        .iter()
        .filter_map(|&backend| {
            let xy: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.backend == backend)
                .filter_map(|p| p.ms_per_step.map(|t| (p.particles as f64, t)))
                .collect();
            fit_power_law(&xy).map(|(exponent, prefactor_ms)| Fit {
                backend,
                exponent,
                prefactor_ms,
                points: xy.len(),
            })
        })
        .collect();
    (points, fits)
}
