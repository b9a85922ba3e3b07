//! Dispatch side of prescribed motion (`shaders/motion.wgsl` ↔
//! `cpu/src/motion.rs`): where the host puts each step's values.
//!
//! ```text
//! rest    … families' rest data | substep 0 block | … | substep S−1 block
//!         block = Ā of each rotating moving plane (DIM² each)
//!               | per moving mesh: Ā (DIM²), Rᵀ (DIM²), e (DIM) when it
//!                 rotates, e (DIM) alone otherwise (moving_mesh.rs)
//!               | per pin: x(t1) − o (DIM), v (DIM)
//! calls   Motion        OP_MOTION, slot_map → particle → pin map in
//!                       contact_slot, slot_base → the substep's pin table
//!         moving plane  contact / friction: FLAG_MOVING (+ FLAG_ROTATES,
//!                       chunk → its Ā), normal = n(t1), factor = s − n·o,
//!                       gravity = c + Ā o;  residual: FLAG_MOVING, the last
//!                       substep's n and s
//!         moving mesh   contact / friction: FLAG_MESH | FLAG_MOVING
//!                       (+ FLAG_ROTATES), chunk → its block, gravity =
//!                       c + Ā o;  residual: the same flags, its block of
//!                       the last substep in its mesh header (mesh.rs)
//! per step (before its one submit): every substep's values from
//!   MotionPlan::substep (f64, the golden path's), written into `rest`, the
//!   call blocks and the dispatch blocks
//! ```
//! gpu-f64 runs on o = 0 and takes the golden path's values as they are;
//! gpu-f32 takes them rounded once, as the f32 reference does.

use hyperpbd_core::GuardRejection;
use hyperpbd_core::motion::{Motion, local_carry, local_plane, local_position, substep_time};
use hyperpbd_core::moving_mesh::reach_rejection;
use hyperpbd_core::{Kernel, Plan};

use super::NONE;
use super::call::{Call, FLAG_MOVING, FLAG_ROTATES, OP_MOTION, OP_RESIDUAL};
use crate::SceneOrigin;

/// The substep of step call `call` (0 for the run-alone copies).
pub(crate) fn substep_of(plan: &Plan, call: u32) -> usize {
    let per = plan.substep_kernels.len().max(1);
    (call as usize / per).min(plan.substeps.saturating_sub(1) as usize)
}

/// Where a plan's motion values live on the device.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MotionLayout {
    /// Offset of the particle → pin map in `contact_slot`.
    pin_map: u32,
    /// First real of substep 0's block in `rest`.
    base: usize,
    /// Reals per substep block.
    per_substep: usize,
    /// Per moving plane: its Ā's offset in a block (rotating ones).
    matrices: Vec<Option<usize>>,
    /// Per moving mesh: its values' offset in a block, and whether it
    /// rotates.
    meshes: Vec<(usize, bool)>,
    /// Offset of the pin table in a block.
    pins: usize,
}

fn rotates(motion: &[Motion]) -> bool {
    motion.iter().any(|m| match m {
        Motion::Rotate { .. } => true,
        Motion::Translate { .. } | Motion::Keyframes { .. } => false,
    })
}

impl MotionLayout {
    /// The layout of `plan`'s motion (None without one): the pin map
    /// appended to `slot_maps`, the blocks (zeros) to `rest`.
    pub fn new(plan: &Plan, slot_maps: &mut Vec<u32>, rest: &mut Vec<f64>) -> Option<Self> {
        let motion = plan.motion.as_ref()?;
        let n = plan.dim;
        let mut map = vec![NONE; plan.particle_count()];
        for (k, pin) in motion.pins.iter().enumerate() {
            map[pin.particle] = k as u32;
        }
        let pin_map = slot_maps.len() as u32;
        slot_maps.extend(map);
        let mut per_substep = 0;
        let matrices = motion
            .planes
            .iter()
            .map(|plane| {
                rotates(&plane.motion).then(|| {
                    per_substep += n * n;
                    per_substep - n * n
                })
            })
            .collect();
        let meshes = motion
            .meshes
            .iter()
            .map(|mesh| {
                let turns = rotates(&mesh.motion);
                let at = per_substep;
                per_substep += if turns { 2 * n * n + n } else { n };
                (at, turns)
            })
            .collect();
        let pins = per_substep;
        per_substep += motion.pins.len() * 2 * n;
        let base = rest.len();
        rest.resize(base + per_substep * plan.substeps as usize, 0.0);
        Some(MotionLayout {
            pin_map,
            base,
            per_substep,
            matrices,
            meshes,
            pins,
        })
    }

    /// Where moving mesh family `family`'s values of the last substep
    /// start in `rest` (`None`: the family's mesh does not move).
    pub fn last_mesh_block(&self, plan: &Plan, family: usize) -> Option<u32> {
        let k = plan.motion.as_ref()?.mesh_of(family)?;
        let last = (plan.substeps as usize).saturating_sub(1);
        Some((self.block(last) + self.meshes[k].0) as u32)
    }

    fn block(&self, substep: usize) -> usize {
        self.base + substep * self.per_substep
    }

    /// The Motion call of substep `substep`.
    pub fn motion_call(&self, plan: &Plan, call: u32, substep: usize) -> Call {
        Call {
            op: OP_MOTION,
            count: plan.particle_count() as u32,
            slot_map: self.pin_map,
            slot_base: (self.block(substep) + self.pins) as u32,
            call,
            kernel: Some(Kernel::Motion),
            ..Call::default()
        }
    }

    /// Marks `c`, a contact or friction call of family `family` in
    /// substep `substep` (or its residual call, `residual`), when the
    /// family's plane moves.
    pub fn mark(&self, plan: &Plan, family: usize, substep: usize, residual: bool, c: &mut Call) {
        let Some(motion) = plan.motion.as_ref() else {
            return;
        };
        if let Some(k) = motion.mesh_of(family) {
            let (offset, turns) = self.meshes[k];
            c.flags |= FLAG_MOVING;
            if turns {
                c.flags |= FLAG_ROTATES;
            }
            if !residual {
                c.chunk = (self.block(substep) + offset) as u32;
            }
            return;
        }
        let Some(k) = motion.plane_of(family) else {
            return;
        };
        c.flags |= FLAG_MOVING;
        if residual {
            return;
        }
        if let Some(offset) = self.matrices[k] {
            c.flags |= FLAG_ROTATES;
            c.chunk = (self.block(substep) + offset) as u32;
        }
    }

    /// Step `step`'s values: the blocks (to write at `base` in `rest`),
    /// and the calls patched (`k` calls per substep in the first
    /// `substeps · k`; residual calls; the run-alone copies from
    /// `run_base` take substep 0). A moving mesh that would move too far
    /// in a substep is that substep's guard rejection, before anything is
    /// written (`hyperpbd_core::moving_mesh`).
    pub fn step(
        &self,
        plan: &Plan,
        origin: &SceneOrigin,
        step: u64,
        calls: &mut [Call],
        run_base: usize,
    ) -> Result<(usize, Vec<f64>), GuardRejection> {
        let Some(motion) = &plan.motion else {
            return Ok((self.base, Vec::new()));
        };
        let n = plan.dim;
        let o = origin.as_slice();
        let substeps = plan.substeps as usize;
        let mut blocks = vec![0.0; self.per_substep * substeps];
        // Per substep: per moving plane (n, s − n·o, c + Ā o), per moving
        // mesh c + Ā o.
        let mut planes = Vec::with_capacity(substeps);
        for s in 0..substeps {
            let t0 = substep_time(step, plan.dt, s as u32, plan.h);
            let t1 = substep_time(step, plan.dt, s as u32 + 1, plan.h);
            let now = motion.substep(n, t0, t1, plan.h);
            if let Some(rejection) = reach_rejection(motion, &now, s as u32) {
                return Err(rejection);
            }
            let block = &mut blocks[s * self.per_substep..(s + 1) * self.per_substep];
            let mut values = Vec::with_capacity(now.planes.len());
            for (plane, offset) in now.planes.iter().zip(&self.matrices) {
                if let (Some(offset), Some(m)) = (offset, &plane.carry.matrix) {
                    block[*offset..offset + n * n].copy_from_slice(m);
                }
                let (shift, carry) = local_plane(plane, o);
                values.push((plane.normal.clone(), shift, carry));
            }
            let mut carries = Vec::with_capacity(now.meshes.len());
            for (mesh, &(offset, turns)) in now.meshes.iter().zip(&self.meshes) {
                let frame = mesh.frame(o);
                let mut at = offset;
                if let (true, Some(m), Some(t)) = (turns, &mesh.carry.matrix, &frame.inverse) {
                    block[at..at + n * n].copy_from_slice(m);
                    block[at + n * n..at + 2 * n * n].copy_from_slice(t);
                    at += 2 * n * n;
                }
                block[at..at + n].copy_from_slice(&frame.offset);
                carries.push(local_carry(&mesh.carry, o));
            }
            for k in 0..motion.pins.len() {
                let at = self.pins + 2 * n * k;
                for a in 0..n {
                    block[at + a] = local_position(now.pin_positions[k * n + a], o.get(a));
                    block[at + n + a] = now.pin_velocities[k * n + a];
                }
            }
            planes.push((values, carries));
        }
        let per = plan.substep_kernels.len().max(1);
        for (index, c) in calls.iter_mut().enumerate() {
            let substep = if index < substeps * per {
                index / per
            } else if index >= run_base || c.op != OP_RESIDUAL {
                0
            } else {
                substeps - 1
            };
            let family = match c.kernel {
                Some(Kernel::Project { family, .. } | Kernel::Friction { family }) => family,
                Some(_) => continue,
                None if c.op == OP_RESIDUAL => c.family as usize,
                None => continue,
            };
            if let Some(k) = motion.mesh_of(family) {
                if c.op != OP_RESIDUAL {
                    c.gravity.clone_from(&planes[substep].1[k]);
                }
                continue;
            }
            let Some(k) = motion.plane_of(family) else {
                continue;
            };
            let (normal, shift, carry) = &planes[substep].0[k];
            c.normal.clone_from(normal);
            c.factor = *shift;
            if c.op != OP_RESIDUAL {
                c.gravity.clone_from(carry);
            }
        }
        Ok((self.base, blocks))
    }
}
