//! The arrays a backend's buffers hold: world 0's for one world, every
//! world's, world-major, for a batch (crate::batch).
//!
//! ```text
//! per world   particle records x v p force (n each), gravity scales,
//!             `rest`, the reals of every call block: world after world
//! constants   WORLDS, WORLD_PARTICLES, WORLD_REST, WORLD_SLOTS,
//!             WORLD_CALLS, WORLD_CHUNKS, WORLD_REPORT (step.wgsl's
//!             strides; none for one world, which compiles to the
//!             single-world kernels)
//! ```

use std::borrow::Cow;

use hyperpbd_core::{BackendError, GpuError, Plan, State};

use crate::xpbd::Families;
use crate::xpbd::call::Call;
use crate::xpbd::schedule::Schedule;

/// Every world's plan, initial state, rest values and call blocks
/// (world 0's plan is the backend's own; the batch lays out the last
/// two).
#[derive(Clone, Copy)]
pub(crate) struct Worlds<'a> {
    pub plans: &'a [Plan],
    pub states: &'a [State],
    pub rest: &'a [f64],
    pub calls: &'a [Call],
}

/// What a backend's buffers hold: world 0's arrays (borrowed) for one
/// world, every world's, world-major, for a batch.
pub(crate) struct WorldArrays<'a> {
    /// W.
    pub count: u32,
    /// Every world's plan (as it runs: the union's stages).
    pub plans: &'a [Plan],
    pub state: Cow<'a, State>,
    pub inverse_mass: Cow<'a, [f64]>,
    pub force: Cow<'a, [f64]>,
    pub gravity_scale: Cow<'a, [f64]>,
    pub rest: &'a [f64],
    pub calls: &'a [Call],
    /// step.wgsl's world strides (none for one world).
    pub constants: Vec<(&'static str, f64)>,
}

impl<'a> WorldArrays<'a> {
    /// World 0 alone.
    pub fn one(
        plan: &'a Plan,
        state: &'a State,
        families: &'a Families,
        schedule: &'a Schedule,
    ) -> Self {
        WorldArrays {
            count: 1,
            plans: std::slice::from_ref(plan),
            state: Cow::Borrowed(state),
            inverse_mass: Cow::Borrowed(&plan.inverse_mass),
            force: Cow::Borrowed(&plan.force),
            gravity_scale: Cow::Borrowed(&plan.gravity_scale),
            rest: &families.rest,
            calls: &schedule.calls,
            constants: Vec::new(),
        }
    }

    /// Every world of `worlds`, world-major, for world 0's `families` and
    /// `schedule`.
    pub fn batch(
        worlds: Worlds<'a>,
        families: &Families,
        schedule: &Schedule,
    ) -> Result<Self, BackendError> {
        let w = worlds.plans.len();
        let first = &worlds.plans[0];
        let n = first.particle_count();
        let largest = schedule
            .calls
            .iter()
            .map(|c| c.count as usize)
            .max()
            .unwrap_or(0);
        if worlds.rest.len() != w * families.rest.len()
            || worlds.calls.len() != w * schedule.calls.len()
        {
            return Err(GpuError::Other {
                message: "a batch's worlds were laid out for another schedule".into(),
            }
            .into());
        }
        if worlds.plans.iter().any(|p| p.motion.is_some()) {
            return Err(GpuError::Unsupported {
                what: "prescribed \"motion\" in a batch of worlds (one world at a time runs it)"
                    .into(),
            }
            .into());
        }
        if worlds.plans.iter().any(|p| p.meshes != first.meshes) {
            // One copy of the meshes serves every world (xpbd/mesh.rs).
            return Err(GpuError::Unsupported {
                what: "worlds with different simplex meshes in one batch (one world at a time runs them)"
                    .into(),
            }
            .into());
        }
        if w.saturating_mul(largest.max(n)) > (u32::MAX / 2) as usize {
            return Err(GpuError::Unsupported {
                what: format!("{w} worlds of {n} particles: over 2^31 invocations per dispatch"),
            }
            .into());
        }
        let concat = |part: fn(&Plan) -> &[f64]| -> Vec<f64> {
            worlds
                .plans
                .iter()
                .flat_map(|p| part(p).iter().copied())
                .collect()
        };
        let state = State {
            dim: first.dim,
            positions: worlds
                .states
                .iter()
                .flat_map(|s| s.positions.iter().copied())
                .collect(),
            velocities: worlds
                .states
                .iter()
                .flat_map(|s| s.velocities.iter().copied())
                .collect(),
        };
        let constants = vec![
            ("WORLDS", w as f64),
            ("WORLD_PARTICLES", n as f64),
            ("WORLD_REST", families.rest.len() as f64),
            ("WORLD_SLOTS", families.slots as f64),
            ("WORLD_CALLS", schedule.calls.len() as f64),
            ("WORLD_CHUNKS", schedule.chunks.len() as f64),
            ("WORLD_REPORT", (2 * first.families.len()) as f64),
        ];
        Ok(WorldArrays {
            count: w as u32,
            plans: worlds.plans,
            state: Cow::Owned(state),
            inverse_mass: Cow::Owned(concat(|p| &p.inverse_mass)),
            force: Cow::Owned(concat(|p| &p.force)),
            gravity_scale: Cow::Owned(concat(|p| &p.gravity_scale)),
            rest: worlds.rest,
            calls: worlds.calls,
            constants,
        })
    }
}
