//! What `hyperpbd sweep --plot METRIC` draws against the swept values.
//!
//! ```text
//! max_violation    largest constraint violation of the last step's report
//! kinetic_energy   ½ Σ m_i |v_i|² over the dynamic particles (m_i authored,
//!                  or lumped from a material family's density)
//! height           mean over dynamic particles of u·x_i, u = −g/|g|
//!                  (the up direction; axis 1 — axis 0 in 1D — without gravity)
//! max_speed        max |v_i| over all particles
//! active_contacts  contacts with a positive multiplier in the last substep
//! ```

use crate::{Scene, State, StepReport};
use std::fmt;
use std::str::FromStr;

/// A scalar of a finished world (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Metric {
    MaxViolation,
    KineticEnergy,
    Height,
    MaxSpeed,
    ActiveContacts,
}

impl Metric {
    /// Every metric, in the order the docs list them.
    pub const ALL: [Metric; 5] = [
        Metric::MaxViolation,
        Metric::KineticEnergy,
        Metric::Height,
        Metric::MaxSpeed,
        Metric::ActiveContacts,
    ];

    /// The name `--plot` takes.
    pub fn name(self) -> &'static str {
        match self {
            Metric::MaxViolation => "max_violation",
            Metric::KineticEnergy => "kinetic_energy",
            Metric::Height => "height",
            Metric::MaxSpeed => "max_speed",
            Metric::ActiveContacts => "active_contacts",
        }
    }

    /// Whether a chart of it reads best on a log axis.
    pub fn logarithmic(self) -> bool {
        self == Metric::MaxViolation
    }

    /// Its value for `state` of `scene` after the step that reported `report`.
    pub fn value(self, scene: &Scene, state: &State, report: Option<&StepReport>) -> f64 {
        // Authored or lumped (density) masses; the scene ran, so it is valid.
        let masses = crate::particle_masses(scene).unwrap_or_default();
        let dynamic = || {
            scene
                .particles
                .iter()
                .enumerate()
                .filter(|(_, p)| !p.fixed)
                .map(|(i, _)| (i, masses.get(i).copied().unwrap_or(0.0)))
        };
        let speed2 = |i: usize| state.velocity(i).iter().map(|v| v * v).sum::<f64>();
        match self {
            Metric::MaxViolation => report.map_or(0.0, StepReport::max_violation),
            Metric::ActiveContacts => report.map_or(0.0, |r| r.active_contacts as f64),
            Metric::KineticEnergy => dynamic().map(|(i, m)| 0.5 * m * speed2(i)).sum(),
            Metric::MaxSpeed => (0..state.len())
                .map(|i| speed2(i).sqrt())
                .fold(0.0, f64::max),
            Metric::Height => {
                let up = up(scene);
                let (sum, count) = dynamic().fold((0.0, 0usize), |(s, c), (i, _)| {
                    let h: f64 = state.position(i).iter().zip(&up).map(|(x, u)| x * u).sum();
                    (s + h, c + 1)
                });
                if count == 0 { 0.0 } else { sum / count as f64 }
            }
        }
    }
}

/// The unit vector against gravity (axis 1, or 0 in 1D, without gravity).
fn up(scene: &Scene) -> Vec<f64> {
    let g = scene
        .gravity
        .clone()
        .unwrap_or_else(|| vec![0.0; scene.dim]);
    let norm = g.iter().map(|c| c * c).sum::<f64>().sqrt();
    if norm > 0.0 {
        return g.iter().map(|c| -c / norm).collect();
    }
    let mut up = vec![0.0; scene.dim];
    if let Some(axis) = up.get_mut(1.min(scene.dim.saturating_sub(1))) {
        *axis = 1.0;
    }
    up
}

impl fmt::Display for Metric {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Metric {
    type Err = String;

    fn from_str(text: &str) -> Result<Metric, String> {
        Metric::ALL
            .into_iter()
            .find(|m| m.name() == text)
            .ok_or_else(|| {
                let names: Vec<&str> = Metric::ALL.iter().map(|m| m.name()).collect();
                format!("unknown metric `{text}` (one of {})", names.join(", "))
            })
    }
}
