//! `CoupledStep` ([`crate::GpuCoupledBackend`]): the coupled implicit step (docs/implicit.md §7) on
//! the GPU, the golden path's schedule (`cpu/src/coupled/`) kernel for
//! kernel: every per-element and per-particle pass, PCG whole (its vectors
//! and its scalar recurrence, pcg.rs), the line search's vectors, and every
//! sum on the block tree run in `shaders/coupled.wgsl` and
//! `coupled_solve.wgsl`, the material elements' passes (StVK, Neo-Hookean:
//! W, ∇W, the frame Hessian H_F projected by cyclic Jacobi, its products)
//! in `coupled_material.wgsl`; the host runs the Newton loop's other
//! decisions on the few reduced scalars it reads back, through the same
//! core functions as the CPU (`pcg_start`, `armijo`, `MinimisationReport`,
//! `change_resolution`).
//!
//! ```text
//! per substep:  cp_start (x^t, x~, load, lags, d ≤ 0) → pairs at x^t (collisions) → warm start
//!               loop { x_k → point; cp_elements + cp_material_elements; cp_gradient;
//!                      Σ|max → residual (one read; without materials PCG's start
//!                      rides in it)
//!                      PCG on the device (pcg.rs: cp_material_frames (H_F⁺ at x_k, only
//!                      with materials), the diagonal and start, one read; then
//!                      chunks of iterations, one read each; cp_material_slots after
//!                      every cp_slots)
//!                      pairs over [x_k, x_k + Δ]; filter and, at x_k, elements and
//!                      slope (one read); trials in batches of 1, 2, 4, … (one read
//!                      per batch, trials.rs); accept (no read) }
//!               cp_finish: x = x_k, v = (x − x^t)/h (no read)
//! host waits    per Newton iteration: the residual, PCG's chunks, filter + slope, the
//!               trial batches (plus the swept pairs with collisions); per substep the start
//!               (with the warm start's filter when there are no collisions)
//! pairs         the broadphase over the swept boxes runs on the host over x_k and Δ read
//!               back (only with `collisions`); the element list (springs, balls, pair
//!               friction lags frozen at x^t) is re-uploaded when the pair set changes
//! materials     refusals (a law refusal at x_k, a non-finite H_F) and the rounding δW
//!               of the floor are core's functions on the host, on x_k read back
//!               (only when needed), as the golden path names and sums them
//! loops         a material element whose Jacobi sweeps llvmpipe cuts short is a typed
//!               refusal naming it (R^5 simplices on lavapipe; material.rs)
//! f32           the same passes at ε₃₂ (f32.rs): the certified filter counts ε₃₂ on the
//!               stored device coordinates (relative to the scene origin), radii stored
//!               rounded outward, the rounding floor at ε₃₂ with its second-order terms;
//!               the authored criterion, ending mostly at RoundingFloor
//! refused       material families in f32 (their δW and frame Hessians are outside the
//!               f32 bound)
//! ```
//! In f64 on lavapipe every state is bit-identical to the CPU golden path
//! (`tests/gpu/coupled/`). In f32 nothing the device reports is taken as
//! evidence: the host recomputes ∇F in f64 at the returned iterate
//! (`hyperpbd_cpu::coupled_gradient`) and bounds its distance to the CPU's
//! iterate with a per-particle modulus (`hyperpbd_verify::compare_coupled`,
//! `tests/gpu/coupled_f32.rs`).

mod cg_state;
mod device;
mod entries;
pub(crate) mod expression;
mod f32;
mod material;
mod newton;
mod pcg;
mod trials;

use hyperpbd_core::broadphase::{Aabbs, Pair, grid_pairs};
use hyperpbd_core::implicit::{CoupledPlan, PairLag};
use hyperpbd_core::{
    BackendError, Convergence, FamilyKind, GpuError, IncrementalPotentialPlan, MinimisationReport,
    Plan, State, check_state,
};

use crate::Precision;
use crate::barrier::barrier_resources;
use crate::codes;
use crate::context::DeviceSource;
use crate::kernel_set::{KernelSet, KernelSetSpec};
use crate::minimising::{Minimiser, Minimising};
use crate::params::{push_reals, real_size};
use crate::resident_backend::{Resident, ResidentBackend};
use crate::shader::MAX_GPU_DIM;
use device::{Device, ElementUpload, Reduction};
use entries::Entry;
use material::Materials;
use newton::Newton;
use pcg::PcgProbe;
use trials::TrialProbe;

/// The GPU backend of the coupled implicit step.
pub type GpuCoupledBackend = ResidentBackend<Minimising<CoupledStep>>;

/// The coupled step's kernels, buffers and element lists.
pub struct CoupledStep {
    ip: IncrementalPotentialPlan,
    coupled: CoupledPlan,
    device: Device,
    /// The uploaded element list, its pair set and pair friction lags.
    elements: ElementUpload,
    pairs: Vec<Pair>,
    lags: Vec<PairLag>,
    /// The material elements (blocks of coupled_material.wgsl).
    materials: Materials,
    /// m_i (0 for fixed particles).
    mass: Vec<f64>,
    /// PCG's read-back buffer and chunk length (pcg.rs).
    pcg: PcgProbe,
    /// Armijo's batch read-back and batch length (trials.rs).
    trial_probe: TrialProbe,
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

impl Minimiser for CoupledStep {
    /// Loads `plan` (an incremental-potential plan with a coupled step)
    /// with `state` on `device`.
    fn load(
        device: DeviceSource<'_>,
        plan: Plan,
        state: &State,
        precision: Precision,
    ) -> Result<(Resident, Self), BackendError> {
        check_state(&plan, state)?;
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
        let generated = expression::generated(&plan, precision);
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
            fixed[0] = ctx.storage("radius", &f32::outward_radii(&plan.radius))?;
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

    fn minimise(&mut self, on: &mut Resident) -> Result<MinimisationReport, BackendError> {
        Newton { on, step: self }.minimise()
    }
}

impl CoupledStep {
    /// The element list of the plan's springs and materials, the ball pairs `pairs` and
    /// the pair friction lags `self.lags` (cpu/src/coupled/elements.rs
    /// `rebuild`), uploaded when the pairs changed (or `force`: new lags).
    fn upload_elements(
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
                match &family.kind {
                    FamilyKind::Material { material, .. } => {
                        push(members, code, &[material.lame.mu, material.lame.lambda]);
                    }
                    FamilyKind::Distance
                    | FamilyKind::Tether
                    | FamilyKind::SimplexMeasure { .. }
                    | FamilyKind::OrientedMeasure
                    | FamilyKind::HyperplaneContact { .. }
                    | FamilyKind::MeshContact { .. }
                    | FamilyKind::Expression(_) => {
                        push(members, code, &[family.compliance, family.rest[e]])
                    }
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
    fn sweep(&self, on: &Resident, from: &[f64], to: &[f64]) -> Vec<Pair> {
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
    fn run(
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
    fn submit(&self, on: &Resident, entries: &[(Entry, usize)]) -> Result<(), GpuError> {
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
    fn counts(&self, on: &Resident) -> (usize, usize) {
        (on.plan.particle_count(), self.elements.lists.len())
    }
}
