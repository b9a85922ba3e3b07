//! What each effect costs: step time as effects are added one at a time.
//!
//! ```text
//! base      scenes::cloth(n): n × n cloth, 10 substeps × 1 iteration
//! ladder    gravity only → + distance (edges + shear, rigid)
//!           → + contact (ground plane, μ = 0) → + friction (μ = 0.4)
//!           → + damping (0.1 /s)  (= scenes::cloth(n))
//! controls  an effect authored but inert must compile to the same plan
//!           (no stage, no kernel) and so cost nothing:
//!           damping with rate 0  vs  "+ friction"
//!           gravity with every gravity_scale 0  vs  "no forces at all"
//!           a plane 100 m below that no particle reaches  vs  "+ contact"
//!           (same schedule: contact cost is per authored obstacle, not per
//!           active contact)
//! balls     collisions and the barrier solver on balls: granular_effects.rs
//! time      median ms per step over max(reps, 5) reps taken round-robin
//!           over every (row, backend), each rep k steps (k calibrated so a
//!           rep lasts about the time target; ball rows: one k per backend,
//!           the smallest calibrated, at least `effects_ball_steps`)
//! ```

use crate::config::Config;
use crate::granular_effects::{self, Relation, without_collisions};
use crate::progress::Progress;
use crate::timing::{calibrate, load, median, timed_steps};
use hyperpbd::{Backend, BackendKind, Obstacle, Plan, Scene, State};
use serde::Serialize;

/// One row of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectRow {
    /// The table the row belongs to ([`CLOTH`] or [`BALLS`]).
    pub group: String,
    /// What the scene contains.
    pub label: String,
    /// The row this one is a control of (its plan/schedule is compared).
    pub control_of: Option<String>,
    /// For a control: does it compile to the same kernel schedule as its
    /// twin (and the very same plan)?
    pub same_schedule: Option<bool>,
    /// Same plan, field for field (for a control of kind
    /// [`Relation::TwinWithoutCollisions`]: the twin's plan without its
    /// contacts, Broadphase and Collide kernels).
    pub same_plan: Option<bool>,
    /// For a control: what its plan was compared with ("vs *twin*", or
    /// "vs *twin* minus its contacts, Broadphase and Collide").
    pub compared: Option<String>,
    /// A row on a different solver: the row it is compared with (ratio of
    /// times only; no plan claim).
    pub versus: Option<String>,
    /// Stages per substep, joined with →.
    pub stages: String,
    /// Kernel calls per step.
    pub kernel_calls: u64,
    /// Constraint projections per step.
    pub projections: u64,
    /// Median ms per step per backend (None: skipped).
    pub ms: Vec<(BackendKind, Option<f64>)>,
}

/// Group of the cloth ladder.
pub const CLOTH: &str = "cloth";
/// Group of the balls (collisions, barrier solver).
pub const BALLS: &str = "balls";

/// Every row to measure: (group, label, scene, relation with indices into
/// this list).
pub fn all_rows(config: &Config) -> Result<Vec<(&'static str, String, Scene, Relation)>, String> {
    let mut all: Vec<(&'static str, String, Scene, Relation)> = ladder(config.effects_n)
        .into_iter()
        .map(|(label, scene, twin)| {
            let relation = twin.map_or(Relation::Ladder, Relation::Control);
            (CLOTH, label, scene, relation)
        })
        .collect();
    let offset = all.len();
    let (side, height) = config.effects_balls;
    for (label, scene, relation) in granular_effects::rows(side, height)? {
        let relation = match relation {
            Relation::Ladder => Relation::Ladder,
            Relation::Control(t) => Relation::Control(t + offset),
            Relation::TwinWithoutCollisions(t) => Relation::TwinWithoutCollisions(t + offset),
            Relation::DifferentSolver(t) => Relation::DifferentSolver(t + offset),
        };
        all.push((BALLS, label, scene, relation));
    }
    Ok(all)
}

fn without_damping(mut s: Scene) -> Scene {
    s.damping = None;
    s
}

fn with_friction(mut s: Scene, mu: f64) -> Scene {
    for o in &mut s.obstacles {
        if let Obstacle::Hyperplane { friction, .. } = o {
            *friction = mu;
        }
    }
    s
}

/// The rows: (label, scene, index of the twin for controls).
pub fn ladder(n: usize) -> Vec<(String, Scene, Option<usize>)> {
    let full = hyperpbd::scenes::cloth(n);
    let mut nothing = without_damping(full.clone());
    nothing.constraints.clear();
    nothing.obstacles.clear();
    nothing.gravity = None;
    let mut gravity = nothing.clone();
    gravity.gravity = full.gravity.clone();
    let mut distance = gravity.clone();
    distance.constraints = full.constraints.clone();
    let mut contact = with_friction(without_damping(full.clone()), 0.0);
    contact.constraints = full.constraints.clone();
    let friction = without_damping(full.clone());
    let damping = full.clone();

    let mut damping_zero = friction.clone();
    damping_zero.damping = Some(hyperpbd::Damping { rate: 0.0 });
    let mut gravity_unscaled = gravity.clone();
    for p in &mut gravity_unscaled.particles {
        p.gravity_scale = 0.0;
    }
    let mut far_plane = contact.clone();
    for o in &mut far_plane.obstacles {
        if let Obstacle::Hyperplane { offset, .. } = o {
            *offset = -100.0;
        }
    }
    vec![
        ("no forces, no constraints".into(), nothing, None),
        ("gravity only".into(), gravity, None),
        ("+ distance (edges + shear, rigid)".into(), distance, None),
        ("+ contact (ground plane, μ = 0)".into(), contact, None),
        ("+ friction (μ = 0.4)".into(), friction, None),
        ("+ damping (0.1 /s) = scenes::cloth".into(), damping, None),
        (
            "control: + friction, damping rate 0 authored".into(),
            damping_zero,
            Some(4),
        ),
        (
            "control: gravity authored, every gravity_scale 0".into(),
            gravity_unscaled,
            Some(0),
        ),
        (
            "control: + contact, plane 100 m below (never touched)".into(),
            far_plane,
            Some(3),
        ),
    ]
}

/// Repetitions of the effect table: at least 5, because its point is
/// differences between rows.
pub fn reps(config: &Config) -> usize {
    config.reps.max(5)
}

/// Measures the ladder on every configured backend. Every (row, backend)
/// is loaded and calibrated first; then the reps go round-robin over all
/// of them, so slow drifts in machine load spread over every row instead
/// of biasing the rows measured last.
pub fn run(config: &Config, progress: &mut Progress) -> Result<Vec<EffectRow>, String> {
    let rungs = all_rows(config)?;
    let plans: Vec<Plan> = rungs
        .iter()
        .map(|(_, label, s, _)| Plan::compile(s).map_err(|e| format!("{label}: {e}")))
        .collect::<Result<_, _>>()?;
    let initials: Vec<State> = rungs
        .iter()
        .map(|(_, _, s, _)| State::from_scene(s))
        .collect();
    type Slot = (usize, BackendKind, Box<dyn Backend>, u64);
    let mut slots: Vec<Slot> = Vec::new();
    for (k, (_, label, _, _)) in rungs.iter().enumerate() {
        for &backend in &config.backends {
            if !progress.available(backend) {
                continue;
            }
            let loaded = load(backend, plans[k].clone(), &initials[k]).and_then(|mut b| {
                calibrate(b.as_mut(), config.time_target).map(|steps| (b, steps))
            });
            match loaded {
                Ok((b, steps)) => slots.push((k, backend, b, steps)),
                Err(e) => {
                    progress.note(&format!("effects {} {label}: SKIPPED: {e}", backend.name()))
                }
            }
        }
    }
    // Ball rows change cost as the column collapses (contacts, Newton
    // iterations), so on one backend they all run the same steps from the
    // same start: the fewest any of them calibrated to, at least
    // `effects_ball_steps`.
    for &backend in &config.backends {
        let in_group = |(k, b, _, _): &Slot| rungs[*k].0 == BALLS && *b == backend;
        let fewest = slots.iter().filter(|s| in_group(s)).map(|s| s.3).min();
        if let Some(fewest) = fewest {
            for slot in slots.iter_mut().filter(|s| in_group(s)) {
                slot.3 = fewest.max(config.effects_ball_steps);
            }
        }
    }
    let mut samples: Vec<Vec<f64>> = vec![Vec::new(); slots.len()];
    for _ in 0..reps(config) {
        for (slot, (k, _, b, steps)) in slots.iter_mut().enumerate() {
            samples[slot].push(timed_steps(b.as_mut(), &initials[*k], *steps)?);
        }
    }
    let mut rows = Vec::new();
    for (k, (group, label, _, relation)) in rungs.iter().enumerate() {
        let plan = &plans[k];
        let mut ms = Vec::new();
        for &backend in &config.backends {
            if !progress.available(backend) {
                continue;
            }
            let m = slots
                .iter()
                .position(|(r, b, _, _)| *r == k && *b == backend)
                .map(|slot| 1000.0 * median(&samples[slot]));
            if let Some(m) = m {
                progress.line(&format!(
                    "effects {:>8} {label}: {m:.3} ms/step",
                    backend.name()
                ));
            }
            ms.push((backend, m));
        }
        let names: Vec<&str> = plan.stages.iter().map(|s| s.as_str()).collect();
        let (control_of, same_schedule, same_plan, compared, versus) = match *relation {
            Relation::Ladder => (None, None, None, None, None),
            Relation::Control(t) => (
                Some(rungs[t].1.clone()),
                Some(plans[t].substep_kernels == plan.substep_kernels),
                Some(plans[t] == *plan),
                Some(format!("vs *{}*", rungs[t].1)),
                None,
            ),
            Relation::TwinWithoutCollisions(t) => {
                let expected = without_collisions(&plans[t]);
                (
                    Some(rungs[t].1.clone()),
                    Some(expected.substep_kernels == plan.substep_kernels),
                    Some(expected == *plan),
                    Some(format!(
                        "vs *{}* minus its contacts, Broadphase and Collide",
                        rungs[t].1
                    )),
                    None,
                )
            }
            Relation::DifferentSolver(t) => (None, None, None, None, Some(rungs[t].1.clone())),
        };
        rows.push(EffectRow {
            group: (*group).to_string(),
            label: label.clone(),
            control_of,
            same_schedule,
            same_plan,
            compared,
            versus,
            stages: if names.is_empty() {
                "(none)".into()
            } else {
                names.join(" → ")
            },
            kernel_calls: plan.kernel_counts().iter().map(|(_, c)| c).sum(),
            projections: plan.projections_per_step(),
            ms,
        });
    }
    Ok(rows)
}
