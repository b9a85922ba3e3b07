//! One CPU/GPU pair: each kernel from identical inputs, its bound, the
//! worst ratios printed as `KERNEL` lines.

use super::*;

use super::bounds::{kernel_bounds, scales};

/// One CPU/GPU pair on the same plan and input.
pub(super) struct Pair {
    cpu: CpuBackend,
    gpu: GpuBackend,
    precision: Precision,
    /// f64 on an adapter where bit identity is asserted (bounds 0).
    exact: bool,
    /// f32 on such an adapter: the f32 reference, held to the GPU bit for
    /// bit after every kernel from the same input (the model's bounds are
    /// asserted too, printed as `… model` rows).
    reference: Option<F32Reference>,
    name: String,
    /// Position bound of this substep's Project per family (for Friction).
    lambda_bound: Vec<f64>,
    /// Largest measured / bound over the run, per (kernel kind, metric).
    worst: Vec<(String, f64, f64)>,
}

impl Pair {
    pub(super) fn new(
        adapter: &wgpu::Adapter,
        scene: &Scene,
        precision: Precision,
        name: &str,
    ) -> Self {
        let summary = hyperpbd_gpu::AdapterSummary::of(adapter);
        let plan = Plan::compile(scene).expect("compiles");
        let state = State::from_scene(scene);
        let gpu = GpuBackend::with_adapter(adapter, plan.clone(), &state, precision)
            .unwrap_or_else(|e| panic!("{name}: GPU backend: {e}"));
        let families = plan.families.len();
        let reference = (precision == Precision::F32 && f32_identical(&summary))
            .then(|| F32Reference::new(plan.clone(), &state, gpu.origin().as_slice()).ok())
            .flatten();
        let cpu = CpuBackend::new(plan, &state).expect("CPU backend");
        Pair {
            cpu,
            gpu,
            precision,
            exact: precision == Precision::F64 && f64_identical(&summary),
            reference,
            name: name.into(),
            lambda_bound: vec![0.0; families],
            worst: Vec::new(),
        }
    }

    /// Copies the GPU state into the CPU backend: identical inputs.
    fn sync(&mut self) -> State {
        let state = self.gpu.read_state().expect("GPU read_state");
        self.cpu.write_state(&state).expect("CPU write_state");
        if let Some(r) = self.reference.as_mut() {
            r.write_state(&state).expect("reference write_state");
        }
        state
    }

    /// Runs `kernel` on both from identical inputs and checks the bounds.
    fn run(&mut self, kernel: Kernel) {
        let before = self.sync();
        self.cpu.run_kernel(kernel).expect("CPU kernel");
        self.gpu
            .run_kernel(kernel)
            .unwrap_or_else(|e| panic!("{}: GPU {kernel:?}: {e}", self.name));
        let cpu = self.cpu.read_state().expect("CPU read_state");
        let gpu = self.gpu.read_state().expect("GPU read_state");
        if let Some(r) = self.reference.as_mut() {
            r.run_kernel(kernel)
                .unwrap_or_else(|e| panic!("{}: f32 reference {kernel:?}: {e}", self.name));
            let expected = r.read_state();
            assert!(
                bits(&expected) == bits(&gpu),
                "{} f32: {kernel:?} on llvmpipe differs from the f32 reference from the same \
                 input: max |dx| {:e}, max |dv| {:e}",
                self.name,
                max_abs_diff(&expected.positions, &gpu.positions),
                max_abs_diff(&expected.velocities, &gpu.velocities)
            );
        }
        let plan = self.cpu.plan().clone();
        let s = scales(&[&before, &cpu, &gpu]);
        let (xb, vb) = if self.exact {
            (0.0, 0.0)
        } else {
            kernel_bounds(
                kernel,
                &plan,
                self.precision,
                &s,
                &before,
                &self.lambda_bound,
            )
        };
        match kernel {
            Kernel::Predict => self.lambda_bound.fill(0.0),
            Kernel::Project { family, .. } => self.lambda_bound[family] = xb,
            _ => {}
        }
        let dx = max_abs_diff(&cpu.positions, &gpu.positions);
        let dv = max_abs_diff(&cpu.velocities, &gpu.velocities);
        let kind = format!("{kernel:?}")
            .split([' ', '{'])
            .next()
            .unwrap_or("")
            .to_string();
        for (metric, measured, bound) in [("x", dx, xb), ("v", dv, vb)] {
            assert!(
                measured <= bound,
                "{} {}: {kernel:?}: |{metric}_gpu − {metric}_cpu| = {measured:e} > bound {bound:e} \
                 (X = {:e}, V = {:e})",
                self.name,
                self.precision,
                s.x,
                s.v
            );
            let key = format!("{kind} {metric}");
            if self.reference.is_some() {
                // Exact: the largest measured (NaN bound), the model beside.
                match self.worst.iter_mut().find(|(k, _, _)| *k == key) {
                    Some(w) => w.1 = w.1.max(measured),
                    None => self.worst.push((key.clone(), measured, f64::NAN)),
                }
            }
            let key = match self.reference {
                Some(_) => format!("{key} model"),
                None => key,
            };
            match self.worst.iter_mut().find(|(k, _, _)| *k == key) {
                Some(w) => {
                    if ratio(measured, bound) > ratio(w.1, w.2) {
                        (w.1, w.2) = (measured, bound);
                    }
                }
                None => self.worst.push((key, measured, bound)),
            }
        }
    }

    /// Predict, Project(family, color), Velocity, every Friction, Damping.
    fn substep_with(&mut self, family: usize, color: usize) {
        let plan = self.cpu.plan().clone();
        self.run(Kernel::Predict);
        self.run(Kernel::Project { family, color });
        self.run(Kernel::Velocity);
        for k in &plan.substep_kernels {
            if let Kernel::Friction { .. } = k {
                self.run(*k);
            }
        }
        if plan.damping.is_some() {
            self.run(Kernel::Damping);
        }
    }

    /// Every (family, color), then a print of the worst ratios.
    pub(super) fn every_color(mut self) {
        let plan = self.cpu.plan().clone();
        assert!(!plan.families.is_empty(), "{}: no family", self.name);
        for (f, family) in plan.families.iter().enumerate() {
            for c in 0..family.color_count() {
                self.substep_with(f, c);
            }
        }
        self.print();
    }

    fn print(&self) {
        for (key, measured, bound) in &self.worst {
            let bound = if self.exact || bound.is_nan() {
                "exact".to_string()
            } else {
                format!("{bound:.3e}")
            };
            println!(
                "KERNEL | {} | {key} | {measured:.3e} | {bound} | {}",
                self.name, self.precision
            );
        }
    }
}

fn ratio(measured: f64, bound: f64) -> f64 {
    if bound > 0.0 {
        measured / bound
    } else if measured > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}
