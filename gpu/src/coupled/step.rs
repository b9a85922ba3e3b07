//! The coupled step's own data (kernels, buffers, the element list and
//! its pairs and lags, the probes) and its loading: what
//! [`crate::GpuCoupledBackend`] runs, one minimisation per substep by
//! Newton's loop (newton.rs).

use hyperpbd_core::broadphase::{Aabbs, Pair, grid_pairs};
use hyperpbd_core::implicit::{CoupledPlan, PairLag};
use hyperpbd_core::{
    BackendError, Convergence, FamilyKind, GpuError, IncrementalPotentialPlan, Plan,
};

use super::device::{Device, ElementUpload, Reduction};
use super::entries::Entry;
use super::material::Materials;
use super::pcg::PcgProbe;
use super::trials::TrialProbe;
use crate::Precision;
use crate::barrier::barrier_resources;
use crate::codes;
use crate::kernel_set::{KernelSet, KernelSetSpec};
use crate::params::{push_reals, real_size};
use crate::resident_backend::{Load, Resident};
use crate::shader::MAX_GPU_DIM;

/// The coupled step's kernels, buffers and element lists.
pub struct CoupledStep {
    pub(super) ip: IncrementalPotentialPlan,
    pub(super) coupled: CoupledPlan,
    pub(super) device: Device,
    /// The uploaded element list, its pair set and pair friction lags.
    pub(super) elements: ElementUpload,
    pub(super) pairs: Vec<Pair>,
    pub(super) lags: Vec<PairLag>,
    /// The material elements (blocks of coupled_material.wgsl).
    pub(super) materials: Materials,
    /// m_i (0 for fixed particles).
    pub(super) mass: Vec<f64>,
    /// PCG's read-back buffer and chunk length (pcg.rs).
    pub(super) pcg: PcgProbe,
    /// Armijo's batch read-back and batch length (trials.rs).
    pub(super) trial_probe: TrialProbe,
}

/// Why the GPU does not run `plan`'s coupled step (yet), if it does not.
fn unsupported(plan: &Plan, ip: &IncrementalPotentialPlan, precision: Precision) -> Option<String> {
    ip.coupled.as_ref()?;
    let not_yet = |what: String| {
        Some(format!(
            "{what} in the coupled implicit step on the GPU (not built yet): use --backend cpu"
        ))
    };
    if plan.dim > MAX_GPU_DIM {
        return Some(format!(
            "dimension {} (the GPU kernels support 1..={MAX_GPU_DIM})",
            plan.dim
        ));
    }
    for f in &plan.families {
        if !f.kind.is_expression() {
            continue;
        }
        if precision == Precision::F32 {
            return not_yet(format!("the expression family {} in f32", f.label));
        }
        if f.arity > plan.dim + 1 {
            return not_yet(format!(
                "the expression family {} of arity {} (the GPU's dense blocks hold N + 1 = {} \
                 particles)",
                f.label,
                f.arity,
                plan.dim + 1
            ));
        }
    }
    if precision == Precision::F32
        && let Some(f) = plan
            .families
            .iter()
            .find(|f| matches!(f.kind, FamilyKind::Material { .. }))
    {
        return not_yet(format!("the material family {} in f32", f.label));
    }
    None
}

impl CoupledStep {
    /// Loads `plan` (an incremental-potential plan with a coupled step)
    /// with `state` on `device`.
    pub(super) fn load(load: Load<'_>) -> Result<(Resident, Self), BackendError> {
        let (device, plan, state, precision) = load.into_parts();
        let (Some(ip), Some(coupled)) = (
            plan.incremental_potential().cloned(),
            plan.incremental_potential()
                .and_then(|ip| ip.coupled.clone()),
        ) else {
            return Err(BackendError::InvalidCall(
                "GpuCoupledBackend runs incremental_potential scenes with a coupled step only"
                    .into(),
            ));
        };
        if let Some(what) = unsupported(&plan, &ip, precision) {
            return Err(GpuError::Unsupported { what }.into());
        }
        let (n, dim) = (plan.particle_count(), plan.dim);
        let ctx = device.context(precision)?;
        let materials = Materials::of(&plan);
        let generated = super::expression::generated(&plan, precision);
        let kernels = KernelSet::new(
            &ctx,
            &KernelSetSpec {
                label: "hyperpbd coupled step",
                modules: &[crate::shader::ShaderFile::Coupled],
                dim,
                precision,
                entries: &Entry::needed(materials.len() > 0),
                constants: &[],
                generated: generated.as_deref(),
            },
        )?;
        let reals = |values: &[f64]| {
            let mut b = Vec::new();
            push_reals(&mut b, values, precision);
            b
        };
        let (resident, mut fixed) = barrier_resources(&ctx, &plan, &ip, state, precision)?;
        if precision == Precision::F32 {
            // Radii rounded outward: an f32 gap ℓ − r̂_i − r̂_j certified > 0
            // is then > 0 with the authored f64 radii too (f32/mod.rs).
            fixed[0] = ctx.storage("radius", &super::f32::outward_radii(&plan.radius))?;
        }
        let mass: Vec<f64> = plan
            .inverse_mass
            .iter()
            .map(|&w| if w > 0.0 { 1.0 / w } else { 0.0 })
            .collect();
        let planes = ip.obstacles.plane_count();
        let obstacle_mu: Vec<f64> = (coupled.plane_friction.iter())
            .chain(&coupled.simplex_friction)
            .copied()
            .collect();
        let zeros = vec![0u8; (n * planes).max(1) * real_size(precision)];
        for (label, bytes) in [
            ("mass", reals(&mass)),
            ("gravity_scale", reals(&plan.gravity_scale)),
            ("gravity", reals(&plan.gravity)),
            ("obstacle_mu", reals(&obstacle_mu)),
            ("lag_force", zeros),
        ] {
            fixed.push(ctx.storage(label, &bytes)?);
        }
        fixed.extend(materials.buffers(&ctx, &plan, precision)?);
        let mut device = Device::new(&ctx, kernels, precision, (n, dim), fixed)?;
        device.params.criterion = match ip.convergence {
            Convergence::PackedGradient { .. } => 0,
            Convergence::MaxAccelerationResidual { .. } => 1,
        };
        device.params.h = plan.h;
        device.params.slip = coupled.slip_velocity * plan.h;
        device.params.mesh_friction =
            u32::from(coupled.simplex_friction.iter().any(|&mu| mu > 0.0));
        let pcg = PcgProbe::new(&ctx, precision)?;
        let trial_probe = TrialProbe::new(&ctx)?;
        let mut step = CoupledStep {
            ip,
            coupled: *coupled,
            device,
            elements: ElementUpload::default(),
            pairs: Vec::new(),
            lags: Vec::new(),
            materials,
            mass,
            pcg,
            trial_probe,
        };
        let on = Resident {
            plan,
            precision,
            ctx,
            state: resident,
        };
        step.upload_elements(&on, Vec::new(), true)?;
        on.ctx.check()?;
        Ok((on, step))
    }

    /// The element list of the plan's springs and materials, the ball pairs `pairs` and
    /// the pair friction lags `self.lags` (cpu/src/coupled/elements.rs
    /// `rebuild`), uploaded when the pairs changed (or `force`: new lags).
    pub(super) fn upload_elements(
        &mut self,
        on: &Resident,
        pairs: Vec<Pair>,
        force: bool,
    ) -> Result<(), GpuError> {
        if !force && pairs == self.pairs {
            return Ok(());
        }
        let plan = &on.plan;
        let width = plan.dim + 1;
        let arity_max = plan.families.iter().map(|f| f.arity).fold(2, usize::max);
        let up = &mut self.elements;
        up.lists.clear(arity_max);
        up.codes.clear();
        up.reals.clear();
        let mut push = |members: &[u32], code: u32, reals: &[f64]| {
            up.lists.push(members);
            up.codes.push(code);
            up.reals.extend(reals);
            up.reals
                .extend(std::iter::repeat_n(0.0, width - reals.len()));
        };
        for family in &plan.families {
            // Hyperplanes are obstacle barriers here, never elements.
            let Some(code) = codes::element_code(&family.kind) else {
                continue;
            };
            for e in 0..family.len() {
                let members = &family.elements[e * family.arity..(e + 1) * family.arity];
                match family.kind.material() {
                    Some(material) => {
                        push(members, code, &[material.lame.mu, material.lame.lambda]);
                    }
                    None => push(members, code, &[family.compliance, family.rest[e]]),
                }
            }
        }
        let first_ball = (plan.families.iter())
            .filter(|f| codes::element_code(&f.kind).is_some())
            .map(|f| f.len())
            .sum();
        for pair in &pairs {
            push(pair, codes::ELEMENT_BALL, &[]);
        }
        for lag in &self.lags {
            let mut reals = vec![lag.force_limit];
            reals.extend(&lag.normal);
            push(&lag.pair, codes::ELEMENT_LAG, &reals);
        }
        up.first_ball = first_ball;
        up.lists.build_gather(plan.particle_count());
        self.device.upload(&on.ctx, &on.state, up, pairs.len())?;
        self.pairs = pairs;
        Ok(())
    }

    /// The ball pairs over the boxes swept from `from` to `to` (radius +
    /// d^/2), pairs of two fixed particles left out (cpu/src/collide.rs).
    pub(super) fn sweep(&self, on: &Resident, from: &[f64], to: &[f64]) -> Vec<Pair> {
        if !self.coupled.collisions {
            return Vec::new();
        }
        let margin = 0.5 * self.ip.law.activation_distance;
        let boxes = Aabbs::swept_particles(on.plan.dim, from, to, &on.plan.radius, margin);
        let w = &on.plan.inverse_mass;
        let mut pairs = grid_pairs(&boxes);
        pairs.retain(|&[i, j]| w[i as usize] + w[j as usize] > 0.0);
        pairs
    }

    /// Writes the params and a clear status block, then records `entries`
    /// (each over its items) and `reductions` in one compute pass (on
    /// lavapipe a pass of its own per dispatch costs more than the
    /// dispatch), and reads them back.
    pub(super) fn run(
        &self,
        on: &Resident,
        entries: &[(Entry, usize)],
        reductions: &[Reduction],
    ) -> Result<(Vec<f64>, [u32; 5]), GpuError> {
        self.device.write_params(&on.ctx);
        self.device.reset_status(&on.ctx);
        let mut encoder = on.encoder();
        let results: Vec<_> = {
            let mut pass = self.device.begin(&mut encoder);
            for &(entry, items) in entries {
                self.device.dispatch(&mut pass, entry, items);
            }
            reductions
                .iter()
                .map(|&r| self.device.reduce_in(&mut pass, r))
                .collect()
        };
        self.device.read(&on.ctx, encoder, &results)
    }

    /// Writes the params, records `entries` (kernels that write no status
    /// word: cp_set_x, cp_finish) in one compute pass and submits it without
    /// waiting: the next submission runs after it (queue order), and the
    /// host needs nothing from it.
    pub(super) fn submit(&self, on: &Resident, entries: &[(Entry, usize)]) -> Result<(), GpuError> {
        self.device.write_params(&on.ctx);
        let mut encoder = on.encoder();
        {
            let mut pass = self.device.begin(&mut encoder);
            for &(entry, items) in entries {
                self.device.dispatch(&mut pass, entry, items);
            }
        }
        on.ctx.submit(encoder).map(|_| ())
    }

    /// Element and particle item counts.
    pub(super) fn counts(&self, on: &Resident) -> (usize, usize) {
        (on.plan.particle_count(), self.elements.lists.len())
    }
}
