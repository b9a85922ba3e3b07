//! The XPBD kernel set: `shaders/step.wgsl` and the kernels' own files,
//! built with the kernel-set builder, and the device data of a plan.
//!
//! ```text
//! kernel ↔ CPU golden ↔ WGSL ↔ dispatch side (call blocks)
//!   predict, velocity, damping   cpu/src/integrate.rs  shaders/integrate.wgsl  integrate.rs
//!   projection                   cpu/src/project.rs    shaders/project.wgsl    project.rs
//!   material energy constraint   core/src/material     shaders/material.wgsl   material.rs
//!   friction                     cpu/src/friction.rs   shaders/friction.wgsl   friction.rs
//!   residual                     cpu/src/residual.rs   shaders/residual.wgsl   residual.rs
//!   guards                       core/src/guards.rs    shaders/guard.wgsl      guard.rs
//! schedule.rs   the calls of a step and the dispatches that run them
//! call.rs       the call block, op codes, flags, record io
//! ```
//! Group 0: x v p force (particle records, prelude.wgsl) gravity_scale
//! elements rest lambda status report calls contact_slot partials chunks
//! pairs (= elements, read as vec2); `rest` holds every slot's rest value,
//! then the material rest data, the expression families' per-element
//! constants and the prescribed motion's values;
//! group 1: the `Dispatch` block of each dispatch (dynamic offset).

pub(crate) mod call;
pub(crate) mod expression;
mod friction;
mod guard;
mod integrate;
pub(crate) mod material;
mod mesh;
pub(crate) mod motion;
mod project;
mod residual;
pub(crate) mod schedule;

use hyperpbd_core::{FamilyKind, GpuError, Plan};

use crate::SceneOrigin;
use crate::kernel_set::{EntryPoint, KernelSet};
use crate::shader::ShaderFile;
use call::Call;
pub(crate) use residual::step_report;
use schedule::Dispatch;

/// The WGSL a plan adds to the step module: its expression families, and
/// the primal-residual update where the plan uses it (failing stand-ins
/// otherwise: `shader::primal_source`).
pub(crate) fn generated(plan: &Plan, families: &Families, precision: crate::Precision) -> String {
    let mut source = expression::generated(plan, families, precision);
    let materials = (plan.families.iter()).any(|f| matches!(f.kind, FamilyKind::Material { .. }));
    source.push_str(&crate::shader::primal_source(
        plan.primal_residual,
        materials,
    ));
    source.push_str(&crate::shader::mesh_source(families.meshes.is_some()));
    source
}

/// No slot (a fixed particle in a contact family's slot map).
pub(crate) const NONE: u32 = u32::MAX;

/// The families in the shared element / slot arrays of the device.
pub(crate) struct Families {
    /// Particle indices of every family, in family order.
    pub elements: Vec<u32>,
    /// Rest values (hyperplane offsets in device coordinates), one per
    /// slot, then the material families' rest data (material.wgsl).
    pub rest: Vec<f64>,
    /// Slots of every family (the multipliers; `rest` holds more).
    pub slots: usize,
    /// Offset of each material family's rest data in `rest` (0 for the
    /// others).
    pub material_base: Vec<u32>,
    /// Offset of each family's per-element expression constants in `rest`
    /// (after the material data; `element_constants` per slot, none for
    /// the other kinds).
    pub constants_base: Vec<u32>,
    /// Offset of each family's particle indices in `elements`.
    pub elem_base: Vec<u32>,
    /// Offset of each family's slots in `rest` and `lambda`.
    pub slot_base: Vec<u32>,
    /// Offset of each contact (hyperplane or mesh) family's particle → slot map in
    /// `slot_maps` (0 for the others).
    pub slot_map: Vec<u32>,
    /// Per contact family, per particle: its slot, or NONE (then the
    /// pins' particle → pin map, with prescribed motion; then, with the
    /// primal residual, the warm start's rows at `warm_start`).
    pub slot_maps: Vec<u32>,
    /// Where the prescribed motion's values live (motion.rs).
    pub motion: Option<motion::MotionLayout>,
    /// The meshes of the mesh contact families (mesh.rs; `None`: none).
    pub meshes: Option<mesh::MeshLayout>,
    /// Primal residual: offset of each family's displacements in
    /// `carried` (arity · DIM reals per slot), of each material family's
    /// Newton factors after them ((arity · DIM)² reals per slot; 0 for the
    /// others), and the total.
    pub carried_base: Vec<u32>,
    pub factor_base: Vec<u32>,
    pub carried_len: usize,
    /// Primal residual: offset in `slot_maps` of the warm start's rows:
    /// n + 1 row starts (absolute indices into `slot_maps`), then per
    /// dynamic particle the offsets in `carried` of its displacements in
    /// family, slot order — the order `cpu::consistent::apply` adds them.
    pub warm_start: u32,
}

impl Families {
    /// Lays out `plan`'s families, hyperplane offsets relative to `origin`.
    pub fn new(plan: &Plan, origin: &SceneOrigin) -> Result<Self, GpuError> {
        let n = plan.particle_count();
        let mut out = Families {
            elements: Vec::new(),
            rest: Vec::new(),
            elem_base: Vec::new(),
            slot_base: Vec::new(),
            slot_map: Vec::new(),
            slot_maps: Vec::new(),
            slots: 0,
            material_base: Vec::new(),
            constants_base: Vec::new(),
            carried_base: Vec::new(),
            factor_base: Vec::new(),
            carried_len: 0,
            warm_start: 0,
            motion: None,
            meshes: None,
        };
        for (family, f) in plan.families.iter().enumerate() {
            if f.arity == 2 && out.elements.len() % 2 == 1 {
                // Pairs are read as vec2<u32>: an even offset.
                out.elements.push(0);
            }
            out.elem_base.push(out.elements.len() as u32);
            out.slot_base.push(out.rest.len() as u32);
            out.elements.extend_from_slice(&f.elements);
            match &f.kind {
                FamilyKind::MeshContact { .. } => {
                    // C = dist(x, mesh) − r: rest = r, translation-invariant.
                    out.rest.extend_from_slice(&f.rest);
                    out.push_slot_map(f, n)?;
                }
                FamilyKind::HyperplaneContact { normal, .. } => {
                    // A moving plane's origin term is in its per-substep
                    // shift (motion.rs).
                    let moving = plan
                        .motion
                        .as_ref()
                        .is_some_and(|m| m.plane_of(family).is_some());
                    out.rest.extend(f.rest.iter().map(|&r| match moving {
                        true => r,
                        false => origin.local_offset(normal, r),
                    }));
                    out.push_slot_map(f, n)?;
                }
                FamilyKind::Distance
                | FamilyKind::Tether
                | FamilyKind::SimplexMeasure { .. }
                | FamilyKind::OrientedMeasure
                | FamilyKind::Material { .. }
                | FamilyKind::Expression(_) => {
                    out.rest.extend_from_slice(&f.rest);
                    out.slot_map.push(0);
                }
            }
        }
        out.slots = out.rest.len();
        for f in &plan.families {
            out.material_base.push(out.rest.len() as u32);
            material::push_rest_data(f, &mut out.rest);
        }
        for f in &plan.families {
            out.constants_base.push(out.rest.len() as u32);
            if let FamilyKind::Expression(kind) = &f.kind {
                out.rest.extend_from_slice(&kind.constants);
            }
        }
        out.motion = motion::MotionLayout::new(plan, &mut out.slot_maps, &mut out.rest);
        out.meshes = mesh::MeshLayout::new(plan, origin, out.motion.as_ref());
        if plan.primal_residual {
            out.lay_out_carried(plan);
        }
        Ok(out)
    }

    /// The particle → slot map of contact family `f` (hyperplane or mesh:
    /// one colour, each particle once; a fixed particle has no slot) over
    /// `n` particles.
    fn push_slot_map(&mut self, f: &hyperpbd_core::Family, n: usize) -> Result<(), GpuError> {
        let mut map = vec![NONE; n];
        for (e, &i) in f.elements.iter().enumerate() {
            match map.get_mut(i as usize) {
                Some(slot) if *slot == NONE && f.color_count() == 1 => *slot = e as u32,
                _ => {
                    return Err(GpuError::Unsupported {
                        what: format!(
                            "{}: a contact family must hold each particle once, in one colour",
                            f.label
                        ),
                    });
                }
            }
        }
        self.slot_map.push(self.slot_maps.len() as u32);
        self.slot_maps.extend(map);
        Ok(())
    }

    /// The displacements' offsets and the warm start's rows (primal
    /// residual).
    fn lay_out_carried(&mut self, plan: &Plan) {
        let (n, dim) = (plan.particle_count(), plan.dim);
        let mut rows: Vec<Vec<u32>> = vec![Vec::new(); n];
        for f in &plan.families {
            let base = self.carried_len;
            self.carried_base.push(base as u32);
            for (k, &i) in f.elements.iter().enumerate() {
                if plan.inverse_mass[i as usize] != 0.0 {
                    rows[i as usize].push((base + k * dim) as u32);
                }
            }
            self.carried_len += f.elements.len() * dim;
        }
        for f in &plan.families {
            self.factor_base.push(self.carried_len as u32);
            if matches!(f.kind, FamilyKind::Material { .. }) {
                self.carried_len += f.len() * (f.arity * dim).pow(2);
            }
        }
        self.warm_start = self.slot_maps.len() as u32;
        let mut at = self.warm_start + n as u32 + 1;
        for row in &rows {
            self.slot_maps.push(at);
            at += row.len() as u32;
        }
        self.slot_maps.push(at);
        self.slot_maps.extend(rows.into_iter().flatten());
    }

    /// A call over every element of family `family` of `plan` (`call`: its
    /// index in the step): the family's element and slot offsets and
    /// arity, the other fields zero.
    pub fn family_call(&self, plan: &Plan, family: usize, call: u32) -> Call {
        let f = &plan.families[family];
        Call {
            count: f.len() as u32,
            family: family as u32,
            elem_base: self.elem_base[family],
            slot_base: self.slot_base[family],
            arity: f.arity as u32,
            call,
            ..Call::default()
        }
    }
}

/// Entry points of the step module, keyed by the values of their
/// pipeline-overridable constants: `particles` once per run shape (ops,
/// flags, io), `project` once per (op, FLAG_*) of its calls, `guard`
/// once per (op, FLAG_*). The flags of a call are then constants of its
/// pipeline and the code they switch off is removed when the pipeline is
/// created — lavapipe runs every branch of a kernel under a mask, memory
/// accesses included (docs/performance.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum XpbdEntry {
    Particles(schedule::Segment),
    Distance(u32),
    Simplex(u32),
    Oriented(u32),
    Residual,
    Reduce,
    Small,
    Guard(u32, u32),
    Material(u32),
    ResidualLanes,
    Expression(u32),
}

impl XpbdEntry {
    /// Order of the entry kinds (pipelines are built in this order).
    pub fn rank(self) -> usize {
        match self {
            XpbdEntry::Particles(_) => 0,
            XpbdEntry::Distance(_) => 1,
            XpbdEntry::Simplex(_) => 2,
            XpbdEntry::Oriented(_) => 3,
            XpbdEntry::Residual => 4,
            XpbdEntry::Reduce => 5,
            XpbdEntry::Small => 6,
            XpbdEntry::Guard(..) => 7,
            XpbdEntry::Material(_) => 8,
            XpbdEntry::ResidualLanes => 9,
            XpbdEntry::Expression(_) => 10,
        }
    }
}

impl EntryPoint for XpbdEntry {
    fn source(self) -> (ShaderFile, &'static str) {
        let name = match self {
            XpbdEntry::Particles(_) => "particles",
            XpbdEntry::Distance(_)
            | XpbdEntry::Simplex(_)
            | XpbdEntry::Oriented(_)
            | XpbdEntry::Material(_)
            | XpbdEntry::Expression(_) => "project",
            XpbdEntry::Residual => "residual",
            XpbdEntry::Reduce => "reduce",
            XpbdEntry::Small => "step_small",
            XpbdEntry::Guard(..) => "guard",
            XpbdEntry::ResidualLanes => "residual_lanes",
        };
        (ShaderFile::Step, name)
    }

    /// OP0..OP7, FL0..FL7 and IO of a `particles` run; OP0 (its
    /// OP_PROJECT_*) and FLAGS of a `project` colour; OP0 and FLAGS of a
    /// guard (step.wgsl).
    fn constants(self) -> Vec<(&'static str, f64)> {
        const OPS: [&str; call::SEGMENT] = ["OP0", "OP1", "OP2", "OP3", "OP4", "OP5", "OP6", "OP7"];
        const FLAGS: [&str; call::SEGMENT] =
            ["FL0", "FL1", "FL2", "FL3", "FL4", "FL5", "FL6", "FL7"];
        let op_and_flags =
            |op: u32, flags: u32| vec![("OP0", f64::from(op)), ("FLAGS", f64::from(flags))];
        match self {
            XpbdEntry::Particles(segment) => {
                let ops = OPS
                    .iter()
                    .zip(segment.ops)
                    .map(|(&k, op)| (k, f64::from(op)));
                let flags = (FLAGS.iter().zip(segment.flags)).map(|(&k, f)| (k, f64::from(f)));
                let io = std::iter::once(("IO", f64::from(segment.io)));
                ops.chain(flags).chain(io).collect()
            }
            XpbdEntry::Distance(f) => op_and_flags(call::OP_PROJECT_DISTANCE, f),
            XpbdEntry::Simplex(f) => op_and_flags(call::OP_PROJECT_SIMPLEX, f),
            XpbdEntry::Oriented(f) => op_and_flags(call::OP_PROJECT_ORIENTED, f),
            XpbdEntry::Material(f) => op_and_flags(call::OP_PROJECT_MATERIAL, f),
            XpbdEntry::Expression(f) => op_and_flags(call::OP_PROJECT_EXPRESSION, f),
            XpbdEntry::Guard(op, f) => op_and_flags(op, f),
            XpbdEntry::Residual
            | XpbdEntry::Reduce
            | XpbdEntry::ResidualLanes
            | XpbdEntry::Small => Vec::new(),
        }
    }
}

/// A dispatch with its block's dynamic offset.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Placed {
    pub dispatch: Dispatch,
    pub offset: u32,
}

/// Records `d` into `pass` for `worlds` worlds (group 0 set by the
/// caller): each world's invocations or workgroups after the last's. Host
/// kernels record nothing.
pub(crate) fn encode(
    kernels: &KernelSet<XpbdEntry>,
    blocks: &wgpu::BindGroup,
    pass: &mut wgpu::ComputePass<'_>,
    d: &Placed,
    worlds: u32,
) {
    let Some(entry) = d.dispatch.run.entry() else {
        return;
    };
    if d.dispatch.count == 0 && entry != XpbdEntry::Small {
        return;
    }
    pass.set_bind_group(1, blocks, &[d.offset]);
    match entry {
        XpbdEntry::Residual | XpbdEntry::Reduce => {
            kernels.dispatch_workgroups(pass, entry, d.dispatch.count * worlds)
        }
        XpbdEntry::Small => kernels.dispatch_workgroups(pass, entry, d.dispatch.count),
        _ => kernels.dispatch(pass, entry, d.dispatch.count * worlds),
    }
}

#[cfg(test)]
mod tests {
    use super::call::{FLAG_FIRST, FLAG_UNREAD, OP_PREDICT, OP_PROJECT_CONTACT};
    use super::*;

    #[test]
    fn flags_are_constants_of_their_pipelines() {
        let mut segment = schedule::Segment {
            ops: [call::OP_NONE as u8; call::SEGMENT],
            flags: [0; call::SEGMENT],
            io: 7,
        };
        segment.ops[..2].copy_from_slice(&[OP_PROJECT_CONTACT as u8, OP_PREDICT as u8]);
        segment.flags[0] = FLAG_FIRST as u16;
        let constants = XpbdEntry::Particles(segment).constants();
        assert!(constants.contains(&("OP0", f64::from(OP_PROJECT_CONTACT))));
        assert!(constants.contains(&("FL0", f64::from(FLAG_FIRST))));
        assert!(constants.contains(&("FL1", 0.0)));
        assert!(constants.contains(&("IO", 7.0)));
        let step = FLAG_FIRST | FLAG_UNREAD;
        assert_eq!(
            XpbdEntry::Distance(step).constants(),
            vec![
                ("OP0", f64::from(call::OP_PROJECT_DISTANCE)),
                ("FLAGS", f64::from(step))
            ]
        );
        assert_eq!(
            XpbdEntry::Expression(0).constants(),
            vec![
                ("OP0", f64::from(call::OP_PROJECT_EXPRESSION)),
                ("FLAGS", 0.0)
            ]
        );
        // The step's colour and the run-alone one are two pipelines.
        assert_ne!(XpbdEntry::Distance(step), XpbdEntry::Distance(0));
        assert!(XpbdEntry::Small.constants().is_empty());
    }
}
