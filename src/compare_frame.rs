//! The per-frame divergence bound of the XPBD path.
//!
//! A comparison restarts the golden path every frame from the other run's
//! state of the previous frame, so the bound counts the roundings of one
//! frame, not the history since the start (which would let an error of
//! many frames' worth hide in an accumulated bound):
//!
//! ```text
//! u    ε/2, the unit roundoff of the compared precision
//! X    largest |device coordinate| in the frame (x − o, o the GPU's scene
//!      origin in f32; start and both ends): a rounding of a coordinate is ≤ u X
//! V    largest |velocity| in the frame;  A = max |s g| + |w f| of a dynamic particle
//! c    roundings that land on one coordinate in one substep (largest over
//!      dynamic particles), counted from the WGSL:
//!        1                      predict      x + h v
//!        iterations · e         projections  x += w ∇C Δλ  (e: equality elements)
//!        iterations · 2 k       contacts     x += w n Δλ, static friction x −= Δt  (k: contacts)
//!        iterations · (8N + 40) particle contact (pair terms and the averaged gather)
//! c_v  roundings at velocity magnitude per substep: 1 (predict) + 3 (velocity:
//!      x − p, h, division) + 4 per friction family + 2 (damping)
//! J_k  static friction decides on |Δt| ≤ μ w λ: a contact whose margin
//!      | |Δt| − μ w λ | is within what the other run's errors can move
//!      (2 (1 + μ) e + (2N + 8) u X, e the position error of the substep so
//!      far: Δt moves with x and p, w λ with the normal correction) may
//!      stick in one run and slide in the other, a jump of max(|Δt|, μ w λ).
//!      J_k is the largest such jump of substep k, from the golden path run
//!      kernel by kernel (Δt before each contact projection, λ after it).
//! M_k  material families: the largest per-particle sum, over the substep's
//!      projections of material elements, of the bound on the error of the
//!      increment w ∇C Δλ (`compare_material.rs`: the law's rounding δW, δ∇W
//!      at the element's state, through C = √(2W), ∇C = ∇W / C and the
//!      update, λ's error carried across the substep's iterations). This is
//!      the element's conditioning: near rest W is known to δW only, so C
//!      and ∇C are, relatively, far worse than one rounding.
//! per substep k = 1 … S, from e_x = e_v = 0 (both runs start from the same state):
//!      r_k  = u X c + u h V + J_k + M_k            fresh position error
//!      q    = u V c_v + 4 u h A                    fresh velocity error (and h, g, s, w, f in f32)
//!      e_x ← e_x + h (e_v + q) + r_k               x = p + h v + corrections
//!      e_v ← e_v + q + r_k / h                     v = (x − p) / h
//! bounds: position e_x, velocity e_v after the frame's S substeps
//! ```
//! A velocity error moves every later position of the frame, hence the
//! double sum (S (S + 1)/2 fresh errors in the position bound). The model
//! assumes a substep maps errors non-expansively: each projection moves a
//! particle's error to a convex combination of its own and its partners'
//! (distance, contact), sticking friction keeps the substep start's. That
//! holds for the stable scenes compared; measures add their conditioning
//! (tests/gpu_kernels.rs checks them alone), material elements add theirs
//! through M_k (their rounding, not the propagation of incoming errors). It is a worst case: roundings
//! of the same sign every time, every coordinate at X. Particle contact also
//! switches on and off at C = 0, which no rounding model bounds: granular
//! scenes are compared on invariants (tests/gpu_granular.rs).

use hyperpbd_core::{
    Backend, BackendError, FamilyKind, Kernel, Plan, Precision, State, StepReport,
};
use hyperpbd_cpu::CpuBackend;

use crate::compare::DivergenceModel;
use crate::compare_material::{Rounding, color_error};

/// The per-frame rounding model of one XPBD plan at one precision.
pub struct FrameErrorModel {
    /// Unit roundoff u = ε/2.
    pub unit_roundoff: f64,
    /// Roundings landing on a coordinate per substep (c).
    pub position_roundings: f64,
    /// Roundings at velocity magnitude per substep (c_v).
    pub velocity_roundings: f64,
    /// Largest |s g| + |w f| of a dynamic particle (A).
    pub acceleration: f64,
    /// Device origin o (zero in f64): X is measured from it.
    origin: Vec<f64>,
    /// The compared precision's rounding (material elements).
    rounding: Rounding,
    /// The golden path run kernel by kernel, for the multipliers of every
    /// substep (J_k).
    probe: CpuBackend,
}

/// Largest per-particle count of (equality elements, contact elements).
fn largest_degree(plan: &Plan) -> (f64, f64) {
    let n = plan.particle_count();
    let mut equality = vec![0u32; n];
    let mut contact = vec![0u32; n];
    for f in &plan.families {
        let count = if f.kind.is_inequality() {
            &mut contact
        } else {
            &mut equality
        };
        for &i in &f.elements {
            count[i as usize] += 1;
        }
    }
    (0..n)
        .filter(|&i| plan.inverse_mass[i] > 0.0)
        .map(|i| (f64::from(equality[i]), f64::from(contact[i])))
        .fold((0.0, 0.0), |m, d| {
            if d.0 + 2.0 * d.1 > m.0 + 2.0 * m.1 {
                d
            } else {
                m
            }
        })
}

/// A = max over dynamic particles and coordinates of |s g| + |w f| (the
/// terms prediction adds to a velocity, per unit time).
pub fn largest_acceleration(plan: &Plan) -> f64 {
    let dim = plan.dim;
    (0..plan.particle_count())
        .filter(|&i| plan.inverse_mass[i] > 0.0)
        .map(|i| {
            (0..dim)
                .map(|a| {
                    let g = if plan.predict.gravity {
                        (plan.gravity_scale[i] * plan.gravity[a]).abs()
                    } else {
                        0.0
                    };
                    let f = if plan.predict.force {
                        (plan.inverse_mass[i] * plan.force[i * dim + a]).abs()
                    } else {
                        0.0
                    };
                    g + f
                })
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

impl FrameErrorModel {
    /// The model of `plan` (an XPBD plan) run at `precision` with device
    /// coordinates relative to `origin` (`hyperpbd::gpu::SceneOrigin`).
    pub fn new(plan: &Plan, precision: Precision, origin: &[f64]) -> Result<Self, BackendError> {
        let iterations = f64::from(plan.iterations);
        let (equality, contact) = largest_degree(plan);
        let particle_contact = if plan.contacts.is_some() {
            iterations * (8.0 * plan.dim as f64 + 40.0)
        } else {
            0.0
        };
        let friction_families = plan
            .substep_kernels
            .iter()
            .filter(|k| matches!(k, Kernel::Friction { .. }))
            .count() as f64;
        let dim = plan.dim;
        let acceleration = largest_acceleration(plan);
        let empty = State {
            dim,
            positions: vec![0.0; plan.particle_count() * dim],
            velocities: vec![0.0; plan.particle_count() * dim],
        };
        Ok(FrameErrorModel {
            unit_roundoff: precision.epsilon() / 2.0,
            position_roundings: 1.0 + iterations * (equality + 2.0 * contact) + particle_contact,
            velocity_roundings: 4.0
                + 4.0 * friction_families
                + if plan.damping.is_some() { 2.0 } else { 0.0 },
            acceleration,
            origin: origin.to_vec(),
            rounding: Rounding::of(precision),
            probe: CpuBackend::new(plan.clone(), &empty)?,
        })
    }

    /// Largest |x − o| over `states`.
    pub fn device_scale(&self, states: &[&State]) -> f64 {
        let o = &self.origin;
        states
            .iter()
            .flat_map(|s| s.positions.chunks_exact(o.len().max(1)))
            .flat_map(|p| p.iter().zip(o).map(|(x, o)| (x - o).abs()))
            .fold(0.0, f64::max)
    }

    /// (position, velocity) bounds on one frame run by both sides from
    /// `start`, with X = `scale` and V = `speed`: the golden path run
    /// kernel by kernel from `start` (for J_k), the error sums advanced
    /// substep by substep.
    pub fn bounds(
        &mut self,
        start: &State,
        scale: f64,
        speed: f64,
    ) -> Result<(f64, f64), BackendError> {
        self.probe.write_state(start)?;
        let plan = self.probe.plan().clone();
        let (h, u) = (plan.h, self.unit_roundoff);
        let q = u * speed * self.velocity_roundings + 4.0 * u * h * self.acceleration;
        let fresh = u * scale * self.position_roundings + u * h * speed;
        let flip_rounding = (2.0 * plan.dim as f64 + 8.0) * u * scale;
        let (mut ex, mut ev) = (0.0f64, 0.0f64);
        let particles = plan.particle_count();
        for _ in 0..plan.substeps {
            // The error of any position within this substep, before J.
            let error = ex + h * (ev + q) + fresh;
            let substep_start = self.probe.read_state()?.positions;
            let mut jump: f64 = 0.0;
            // M_k per particle; δλ per material slot (λ = 0 at the start).
            let mut material = vec![0.0; particles];
            let mut lambda_error: Vec<Vec<f64>> =
                plan.families.iter().map(|f| vec![0.0; f.len()]).collect();
            for &kernel in &plan.substep_kernels {
                let Kernel::Project { family, color } = kernel else {
                    self.probe.run_kernel(kernel)?;
                    continue;
                };
                let f = &plan.families[family];
                if let FamilyKind::Material { .. } = f.kind {
                    let x = self.probe.read_state()?.positions;
                    let lambda = self.probe.multipliers(family).unwrap_or(&[]).to_vec();
                    color_error(
                        f,
                        color,
                        &x,
                        plan.dim,
                        &plan.inverse_mass,
                        &lambda,
                        &mut lambda_error[family],
                        f.compliance / (h * h),
                        self.rounding,
                        &mut material,
                    );
                    self.probe.run_kernel(kernel)?;
                    continue;
                }
                let FamilyKind::HyperplaneContact { normal, friction } = &f.kind else {
                    self.probe.run_kernel(kernel)?;
                    continue;
                };
                let before = self.probe.read_state()?.positions;
                self.probe.run_kernel(kernel)?;
                if *friction == 0.0 {
                    continue;
                }
                let lambda = self.probe.multipliers(family).unwrap_or(&[]);
                let threshold = 2.0 * (1.0 + friction) * error + flip_rounding;
                for slot in f.color(color) {
                    let l = lambda.get(slot).copied().unwrap_or(0.0);
                    if l <= 0.0 {
                        continue;
                    }
                    let i = f.elements[slot] as usize;
                    let n = plan.dim;
                    let d: Vec<f64> = (0..n)
                        .map(|a| before[i * n + a] - substep_start[i * n + a])
                        .collect();
                    let dn: f64 = d.iter().zip(normal).map(|(d, n)| d * n).sum();
                    let tangential = d
                        .iter()
                        .zip(normal)
                        .map(|(d, n)| (d - dn * n).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    let stick = friction * plan.inverse_mass[i] * l;
                    if (tangential - stick).abs() <= threshold {
                        jump = jump.max(tangential.max(stick));
                    }
                }
            }
            let r = fresh + jump + material.iter().fold(0.0, |m: f64, &e| m.max(e));
            ex += h * (ev + q) + r;
            ev += q + r / h;
        }
        Ok((ex, ev))
    }
}

/// Largest |velocity| over `states`.
pub fn speed(states: &[&State]) -> f64 {
    states
        .iter()
        .flat_map(|s| s.velocities.iter())
        .fold(0.0, |m, v| m.max(v.abs()))
}

impl DivergenceModel for FrameErrorModel {
    fn frame_bounds(
        &mut self,
        start: &State,
        golden: (&StepReport, &State),
        other: (&StepReport, &State),
    ) -> Result<(f64, f64), BackendError> {
        let states = [start, golden.1, other.1];
        let scale = self.device_scale(&states);
        self.bounds(start, scale, speed(&states))
    }

    fn describe(&self) -> String {
        format!(
            "per-frame bound: double sum over the frame's substeps of u {:e} x (X x {} roundings/substep + h V) + static-friction jumps + material elements' conditioning",
            self.unit_roundoff, self.position_roundings
        )
    }
}
