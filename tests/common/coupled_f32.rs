//! The per-step check of the GPU's coupled step in f32 against the golden
//! path (docs/bounds.md "Coupled implicit step in f32"), shared by
//! `tests/gpu/coupled_f32.rs` and the stability suite: a CPU probe is
//! restarted from the GPU's state before each step, both take the step,
//! and `hyperpbd_verify::compare_coupled` bounds their distance from the f64
//! gradients at both iterates (`hyperpbd::coupled_gradient`). Asserted
//! every step: finite values, every gap > 0 in f64 against the authored
//! geometry, and the bound wherever the module states one.

use hyperpbd::{Backend, CpuBackend, Plan, State, coupled_gradient};
use hyperpbd_verify::compare_coupled::coupled_step_bound;

/// The smallest gap of any free particle to any obstacle and of any ball
/// pair (with collisions), in f64 against the authored geometry; ∞ with
/// neither.
pub fn smallest_gap(plan: &Plan, x: &[f64]) -> f64 {
    let dim = plan.dim;
    let Some(ip) = plan.incremental_potential() else {
        return f64::INFINITY;
    };
    let mut normal = vec![0.0; dim];
    let mut gap = f64::INFINITY;
    let n = plan.particle_count();
    for i in (0..n).filter(|&i| plan.inverse_mass[i] > 0.0) {
        let xi = &x[i * dim..(i + 1) * dim];
        for o in 0..ip.obstacles.len() {
            gap = gap.min(ip.obstacles.distance(o, xi, plan.radius[i], &mut normal));
        }
    }
    if ip.coupled.as_ref().is_some_and(|c| c.collisions) {
        for i in 0..n {
            for j in i + 1..n {
                let l = (0..dim)
                    .map(|a| (x[j * dim + a] - x[i * dim + a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                gap = gap.min(l - plan.radius[i] - plan.radius[j]);
            }
        }
    }
    gap
}

/// The run's check: the CPU probe and what the steps measured.
pub struct F32Check {
    plan: Plan,
    probe: CpuBackend,
    /// Steps checked.
    pub steps: usize,
    /// Worst measured / bound, its step, measured and bound.
    pub worst: (f64, usize, f64, f64),
    /// Largest |x_gpu − x_cpu| (any coordinate).
    pub largest: f64,
    /// Smallest gap (∞ without obstacles and pairs).
    pub closest: f64,
    /// Smallest μ_i / m_i.
    pub modulus_fraction: f64,
    /// Largest share of the gradients' rounding in a bound.
    pub rounding_share: f64,
    /// The first step without a stated bound, and why.
    pub unbounded: Option<(usize, String)>,
    /// Worst velocity measured / bound, its step, measured and bound.
    pub worst_velocity: (f64, usize, f64, f64),
}

impl F32Check {
    /// A check of `plan`'s steps (a coupled plan).
    pub fn new(plan: &Plan, initial: &State) -> Self {
        F32Check {
            plan: plan.clone(),
            probe: CpuBackend::with_threads(plan.clone(), initial, 1).expect("the CPU loads"),
            steps: 0,
            worst: (0.0, 0, 0.0, 0.0),
            largest: 0.0,
            closest: f64::INFINITY,
            modulus_fraction: f64::INFINITY,
            rounding_share: 0.0,
            unbounded: None,
            worst_velocity: (0.0, 0, 0.0, 0.0),
        }
    }

    /// One step: `start` the GPU's state before it, `after` after it.
    /// Panics (naming `case`) where an assertion fails.
    pub fn step(&mut self, case: &str, start: &State, after: &State) {
        let step = self.steps;
        self.steps += 1;
        let plan = &self.plan;
        let x_gpu = &after.positions;
        assert!(
            x_gpu.iter().chain(&after.velocities).all(|v| v.is_finite()),
            "{case}: step {step}: a non-finite gpu-f32 value"
        );
        let gap = smallest_gap(plan, x_gpu);
        assert!(gap > 0.0, "{case}: step {step}: gap {gap:e} ≤ 0 in f32");
        self.closest = self.closest.min(gap);
        self.probe.write_state(start).expect("cpu restart");
        if let Err(e) = self.probe.step() {
            // The golden step itself refuses from this (f32-rounded) start:
            // there is no f64 iterate to compare with.
            self.unbounded
                .get_or_insert((step, format!("the CPU probe refused: {e}")));
            return;
        }
        let cpu_state = self.probe.read_state().expect("cpu");
        let x_cpu = cpu_state.positions.clone();
        self.largest = self
            .largest
            .max(hyperpbd_verify::compare::max_abs_diff(x_gpu, &x_cpu));
        let from = (&start.positions[..], &start.velocities[..]);
        let gradient = |x: &[f64]| {
            coupled_gradient(plan, from, &plan.force, x)
                .unwrap_or_else(|r| panic!("{case}: step {step}: ∇F: {r:?}"))
        };
        let (g_gpu, g_cpu) = (gradient(x_gpu), gradient(&x_cpu));
        match coupled_step_bound(plan, from, x_gpu, &x_cpu, &g_gpu, &g_cpu) {
            Ok(b) => {
                for k in 0..b.bound.len() {
                    assert!(
                        b.measured[k] <= b.bound[k],
                        "{case}: step {step}: particle {k}: |x_gpu − x_cpu| = {:e} > bound {:e} \
                         (‖g‖_A⁻¹ gpu {:e}, cpu {:e}, rounding {:e})",
                        b.measured[k],
                        b.bound[k],
                        b.gradient_norms.0,
                        b.gradient_norms.1,
                        b.rounding
                    );
                }
                self.modulus_fraction = self.modulus_fraction.min(b.modulus_fraction);
                let total = b.gradient_norms.0 + b.gradient_norms.1 + b.rounding;
                if total > 0.0 {
                    self.rounding_share = self.rounding_share.max(b.rounding / total);
                }
                let (i, ratio) = b.worst();
                if b.bound.is_empty() {
                    return;
                }
                self.velocity(case, step, start, after, &cpu_state, &b.bound);
                if ratio > self.worst.0 || self.steps == 1 {
                    self.worst = (ratio, step, b.measured[i], b.bound[i]);
                }
            }
            Err(why) => {
                self.unbounded.get_or_insert((step, why));
            }
        }
    }

    /// The velocity bound of one step: both runs set v = (x − x^t)/h from
    /// the same x^t, so per particle
    /// |v_gpu − v_cpu| ≤ B_i / h + 3 u₃₂ |v_gpu| + 2 ε₆₄ (|x_cpu| + |x^t|) / h
    /// (B_i the position bound; f32's x − x^t, h and the quotient each round
    /// once relative to v; the CPU's f64 difference relative to the
    /// coordinates).
    fn velocity(
        &mut self,
        case: &str,
        step: usize,
        start: &State,
        after: &State,
        cpu: &State,
        bound: &[f64],
    ) {
        let (dim, h) = (self.plan.dim, self.plan.h);
        let u32 = f64::from(f32::EPSILON) / 2.0;
        let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>().sqrt();
        for i in (0..bound.len()).filter(|&i| self.plan.inverse_mass[i] > 0.0) {
            let span = i * dim..(i + 1) * dim;
            let (vg, vc) = (
                &after.velocities[span.clone()],
                &cpu.velocities[span.clone()],
            );
            let diff: Vec<f64> = vg.iter().zip(vc).map(|(p, q)| p - q).collect();
            let measured = norm(&diff);
            let limit = bound[i] / h
                + 3.0 * u32 * norm(vg)
                + 2.0
                    * f64::EPSILON
                    * (norm(&cpu.positions[span.clone()]) + norm(&start.positions[span]))
                    / h;
            assert!(
                measured <= limit,
                "{case}: step {step}: particle {i}: |v_gpu − v_cpu| = {measured:e} > {limit:e}"
            );
            let ratio = measured / limit;
            if ratio > self.worst_velocity.0 {
                self.worst_velocity = (ratio, step, measured, limit);
            }
        }
    }

    /// "measured/bound r (step s: m ≤ b)" or "none stated (step s: why)".
    pub fn describe(&self) -> String {
        match &self.unbounded {
            Some((step, why)) => format!(
                "max |x_gpu − x_cpu| {:.3e}, no bound stated (step {step}: {why})",
                self.largest
            ),
            None => format!(
                "measured/bound {:.6} (step {}: {:.3e} ≤ {:.3e}; min μ_i/m_i {:.3}, max |dx| {:.3e})",
                self.worst.0,
                self.worst.1,
                self.worst.2,
                self.worst.3,
                self.modulus_fraction,
                self.largest
            ),
        }
    }
}
