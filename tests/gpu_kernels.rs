//! Every kernel alone, CPU golden path vs GPU, f32 and f64.
//!
//! Each kernel is run on the same input on both backends and the states are
//! compared right after it. Inputs are made identical before every kernel
//! by copying the GPU state into the CPU backend (`write_state`); in f32 the
//! GPU state is f32-representable, so both then hold exactly the same
//! numbers. The substep start `p` is set by `Predict` from that identical
//! state; only the multipliers λ (written by `Project`, read by `Friction`)
//! cannot be copied and carry the previous kernel's rounding.
//!
//! ```text
//! per case, per (family, color):  sync → Predict → cmp → sync → Project(f, c) → cmp
//!                                 → sync → Velocity → cmp → sync → Friction(g) → cmp
//!                                 → sync → Damping → cmp
//! ```
//!
//! # Bounds: ε × magnitude × roundings of that one kernel
//!
//! The GPU evaluates the CPU's expressions in the same order; with equal
//! inputs the only differences are the roundings of the GPU precision
//! (f32: ε = 2⁻²³; parameters h, g, w, f, rest, n, μ are also rounded to f32
//! once, each counted as a rounding). A rounding perturbs a value by at most
//! ε × its magnitude, and every magnitude in a kernel's chain is bounded by
//! the scales below, so a kernel's error is at most ε × scale × r, with r the
//! roundings on the longest chain to one output coordinate (counted from the
//! WGSL; N = dimension):
//!
//! ```text
//! X  largest |coordinate| before/after     V  largest |velocity| before/after
//! A  largest |s g| + |w f|                  κ  conditioning of a measure element
//!
//! Predict        x: ε·8·(X + h(V + hA))     v: ε·8·(V + hA)
//!                (4 parameter roundings h, s·g, w, f; 2 mul, 2 add)
//! Project        x: ε·X·(2 + 2κ·r)          v: 0 (not touched: bit-identical)
//!                coordinate differences ≤ 2X; the final add x += Δ rounds at X
//!                r = 2N + 13 distance       (diff, N squares + sum, sqrt, rest,
//!                                            C, Δλ (3), 1/len, n, w n Δλ, add)
//!                r = 4N + 15 contact        (n·x, rest, C, Δλ, clamp (2),
//!                                            correction, static friction:
//!                                            x − p, n·Δx, tangent, |t|, x −= t)
//!                r = 4N + 8k + 20 measure   (edges, Gram/edge matrix, k×k
//!                                            elimination and adjugate, scale,
//!                                            gradient, Σ w|∇C|², C, Δλ, update)
//!                κ = 1 for distance and contact; for a simplex the Hadamard
//!                ratio Π|e_j| / |det E| (oriented) or Π|e_j|² / det(EᵀE)
//!                (squared measure): the error of an elimination determinant
//!                is relative to Π|e_j|, not to the determinant.
//! Velocity       x: 0                       v: ε·3·V   (x − p, h, division)
//! Friction       x: 0                       v: ε·(5N + 14)·V + μ·B_λ / h
//!                B_λ = the position bound of this substep's Project of the
//!                family (the error of w λ, the normal correction); 0 if the
//!                family was not projected (λ = 0 on both).
//! Damping        x: 0                       v: ε·2·V   (factor, multiply)
//! ```
//!
//! f64 (ε = 2⁻⁵²): the same expressions in the same order, every operation
//! correctly rounded on both sides (lavapipe compiles f64 add, mul, div and
//! sqrt to the x86 instructions the CPU uses), so on lavapipe every kernel
//! is asserted bit-identical (`common::exact`: bound 0, printed `exact`).
//! On other adapters the one licensed difference is contraction: Vulkan
//! lets a driver fuse a·b + c into an FMA unless the SPIR-V says
//! NoContraction, and naga does not say it. A fused pair skips one
//! rounding, so there the f64 bound is a few (R64 = 4) ulps of the same
//! scales, through the same κ and λ propagation as above (ε·X·(2 + 2κ·4)
//! for Project, ε·4·V + μ·B_λ/h for Friction, ε·4·scale for the others) —
//! and velocities of Project, x of Velocity/Friction/Damping stay exactly
//! equal.
//!
//! Decisions (`λ > 0`, static friction `|Δt| ≤ μ w λ`, `len > 0`) are
//! discontinuous; the cases are built so that no element sits within
//! rounding of one: penetrations ≥ 1 mm or clearances ≥ 1 cm; sliding
//! contacts move 8.3 mm tangentially per substep against a static bound
//! ≤ 3.1 mm, sticking ones ≤ 0.07 mm against ≥ 0.6 mm.

mod common;

use common::Lcg;

use common::exact::f64_identical;
use common::gpu::adapter_or_skip;
use hyperpbd::compare::{coordinate_scale, max_abs_diff};
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, CpuBackend, FamilyKind, Kernel, Particle, Plan,
    Scene, SceneBuilder, State,
};
use hyperpbd_gpu::{GpuBackend, Precision};

/// Roundings allowed for f64 on a chain the driver may contract.
const R64: f64 = 4.0;

fn eps(precision: Precision) -> f64 {
    precision.epsilon()
}

fn max_abs(values: &[f64]) -> f64 {
    values.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn build(b: SceneBuilder) -> Scene {
    b.build().expect("test scene is valid")
}

/// A chain of `n` particles in R^dim, links of 0.1 m along x0, first
/// particle fixed, over a plane x1 ≥ −0.5 with friction; positions
/// jittered ±1 cm so every link is violated, velocities ±0.5 m/s. (The CPU
/// projects distance with a dimension-specialised loop for N ≤ 4 and the
/// generic gather path above; both are checked.)
fn chain(dim: usize, n: usize) -> Scene {
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(1)
        .gravity_along(1, 9.81)
        .damping(0.5);
    let mut rng = Lcg(n as u64 + 31 * dim as u64);
    for i in 0..n {
        let x: Vec<f64> = (0..dim)
            .map(|a| match a {
                0 => 0.1 * i as f64 + 0.01 * rng.next(),
                1 => 0.3 + 0.01 * rng.next(),
                _ => 0.01 * rng.next(),
            })
            .collect();
        let v: Vec<f64> = (0..dim).map(|_| 0.5 * rng.next()).collect();
        let mut p = Particle::new(x, 0.2 + 0.1 * rng.next().abs());
        if i > 0 {
            p = p.with_velocity(v);
        }
        let index = b.particle(p);
        if i == 0 && n > 1 {
            b.fix(index);
        }
    }
    if n > 1 {
        let links = (1..n).map(|i| vec![i - 1, i]).collect();
        let mut family = ConstraintFamily::new(ConstraintKind::Distance, 1e-7, links);
        family.rest = Some(vec![0.1; n - 1]);
        b.family(family);
    }
    let mut normal = vec![0.0; dim];
    normal[1] = 1.0;
    b.hyperplane(normal, -0.5, 0.3);
    build(b)
}

fn chain3d(n: usize) -> Scene {
    chain(3, n)
}

/// A zigzag strip of `n` particles in 3D with triangles (i, i+1, i+2) as
/// squared-area (k = 2) elements, rest 10 % off the authored value.
fn triangles3d(n: usize) -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(1)
        .gravity_along(1, 9.81)
        .damping(0.5);
    let mut rng = Lcg(7 + n as u64);
    for i in 0..n {
        let x = vec![
            0.1 * i as f64 + 0.01 * rng.next(),
            0.01 * rng.next(),
            0.1 * (i % 2) as f64 + 0.01 * rng.next(),
        ];
        let v = vec![0.3 * rng.next(), 0.3 * rng.next(), 0.3 * rng.next()];
        b.particle(Particle::new(x, 0.1 + 0.05 * rng.next().abs()).with_velocity(v));
    }
    let elements: Vec<Vec<usize>> = (2..n).map(|i| vec![i - 2, i - 1, i]).collect();
    // Right-ish triangles of legs 0.1: area ≈ 0.005, squared ≈ 2.5e-5.
    let mut family = ConstraintFamily::new(ConstraintKind::SimplexMeasure, 1e-9, elements);
    family.rest = Some(vec![2.2e-5; n.saturating_sub(2)]);
    b.family(family);
    build(b)
}

/// The soft tesseract (81 nodes, 384 oriented 4-simplices), nodes jittered
/// ±2 cm, velocities ±0.3 m/s: every element violated, all colors.
fn tesseract_jittered() -> Scene {
    let mut scene = hyperpbd::scenes::tesseract();
    let mut rng = Lcg(4);
    for p in &mut scene.particles {
        for x in &mut p.position {
            *x += 0.02 * rng.next();
        }
        p.velocity = Some((0..4).map(|_| 0.3 * rng.next()).collect());
    }
    // Rest values of the unjittered block (authored explicitly: left
    // implicit they would be computed from the jittered geometry and every
    // element would start satisfied).
    let clean = hyperpbd::scenes::tesseract();
    let plan = Plan::compile(&clean).expect("tesseract compiles");
    for f in &plan.families {
        let Some(index) = f
            .label
            .strip_prefix("constraints[")
            .and_then(|l| l.strip_suffix(']'))
            .and_then(|l| l.parse::<usize>().ok())
        else {
            continue;
        };
        let mut rest = vec![0.0; f.len()];
        for (slot, &source) in f.source.iter().enumerate() {
            rest[source as usize] = f.rest[slot];
        }
        scene.constraints[index].rest = Some(rest);
    }
    scene
}

/// `n` particles in R^dim over the hyperplane with unit normal tilted 20°
/// from +x1 towards +x0, μ = 0.6 > tan 20°: particle i penetrates by 1–5 mm
/// (even i) or floats 1–5 cm above (odd i); every sixth slides fast along
/// the plane (2 m/s: 8.3 mm per substep against a static bound μ·w·λ ≤
/// 3.1 mm), the others stick (≤ 1 mm/s: ≤ 0.07 mm per substep with gravity's
/// tangential part, against ≥ 0.6 mm).
fn contacts(dim: usize, n: usize) -> Scene {
    let theta: f64 = 20f64.to_radians();
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(1)
        .gravity_along(1, 9.81)
        .damping(0.5);
    let mut normal = vec![0.0; dim];
    normal[0] = theta.sin();
    normal[1] = theta.cos();
    let mut tangent = vec![0.0; dim];
    tangent[0] = theta.cos();
    tangent[1] = -theta.sin();
    let offset = 0.1;
    b.hyperplane(normal.clone(), offset, 0.6);
    let mut rng = Lcg(11 + dim as u64 * 1000 + n as u64);
    for i in 0..n {
        let depth = if i % 2 == 0 {
            -(0.001 + 0.002 * (1.0 + rng.next()))
        } else {
            0.01 + 0.02 * (1.0 + rng.next())
        };
        let along = 0.05 * i as f64;
        let mut x: Vec<f64> = (0..dim)
            .map(|a| (offset + depth) * normal[a] + along * tangent[a])
            .collect();
        for c in x.iter_mut().skip(2) {
            *c = 0.1 * rng.next();
        }
        let speed = if i % 6 == 0 { 2.0 } else { 1e-3 * rng.next() };
        let v: Vec<f64> = (0..dim).map(|a| speed * tangent[a]).collect();
        b.particle(Particle::new(x, 0.5 + 0.25 * rng.next().abs()).with_velocity(v));
    }
    build(b)
}

/// Scales of one comparison.
struct Scales {
    x: f64,
    v: f64,
}

fn scales(states: &[&State]) -> Scales {
    Scales {
        x: states
            .iter()
            .map(|s| coordinate_scale(s))
            .fold(0.0, f64::max),
        v: states
            .iter()
            .map(|s| max_abs(&s.velocities))
            .fold(0.0, f64::max),
    }
}

/// Largest element conditioning κ of family `family` at `state` (1 for
/// distance and contact families).
fn conditioning(plan: &Plan, family: usize, state: &State) -> f64 {
    let f = &plan.families[family];
    let dim = plan.dim;
    let k = match f.kind {
        FamilyKind::SimplexMeasure { k } => k,
        FamilyKind::OrientedMeasure => dim,
        _ => return 1.0,
    };
    let mut worst: f64 = 1.0;
    for e in 0..f.len() {
        let ids = &f.elements[e * f.arity..(e + 1) * f.arity];
        let x0 = state.position(ids[0] as usize);
        // Edge matrix as columns e_j = x_j − x_0.
        let edges: Vec<Vec<f64>> = ids[1..]
            .iter()
            .map(|&i| {
                state
                    .position(i as usize)
                    .iter()
                    .zip(x0)
                    .map(|(a, b)| a - b)
                    .collect()
            })
            .collect();
        let norms: f64 = edges
            .iter()
            .map(|e| e.iter().map(|c| c * c).sum::<f64>().sqrt())
            .product();
        let kappa = if matches!(f.kind, FamilyKind::OrientedMeasure) {
            let m = nalgebra::DMatrix::from_fn(dim, k, |r, c| edges[c][r]);
            norms / m.determinant().abs()
        } else {
            let m = nalgebra::DMatrix::from_fn(k, k, |r, c| {
                edges[r]
                    .iter()
                    .zip(&edges[c])
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
            });
            norms * norms / m.determinant().abs()
        };
        worst = worst.max(kappa);
    }
    worst
}

/// Roundings of one projection chain (see the module docs).
fn project_roundings(plan: &Plan, family: usize) -> f64 {
    let n = plan.dim as f64;
    match plan.families[family].kind {
        FamilyKind::Distance => 2.0 * n + 13.0,
        // The distance chain plus the clamp's two roundings (λ + Δλ, − λ).
        FamilyKind::Tether => 2.0 * n + 15.0,
        FamilyKind::HyperplaneContact { .. } => 4.0 * n + 15.0,
        FamilyKind::SimplexMeasure { k } => 4.0 * n + 8.0 * k as f64 + 20.0,
        FamilyKind::OrientedMeasure => 4.0 * n + 8.0 * n + 20.0,
        // No derived f32 rounding count for the material kernel yet
        // (tests/gpu_materials.rs: f64 exact, f32 measured).
        FamilyKind::Material { .. } => f64::NAN,
    }
}

/// Bounds of one kernel on (positions, velocities).
fn kernel_bounds(
    kernel: Kernel,
    plan: &Plan,
    precision: Precision,
    s: &Scales,
    before: &State,
    lambda_bound: &[f64],
) -> (f64, f64) {
    let e = eps(precision);
    let f64_run = precision == Precision::F64;
    let r = |rounds: f64| if f64_run { R64 } else { rounds };
    let h = plan.h;
    match kernel {
        Kernel::Predict => {
            let a = hyperpbd::compare_frame::largest_acceleration(plan);
            (
                e * r(8.0) * (s.x + h * (s.v + h * a)),
                e * r(8.0) * (s.v + h * a),
            )
        }
        Kernel::Project { family, .. } => {
            let kappa = conditioning(plan, family, before);
            (
                e * s.x * (2.0 + 2.0 * kappa * r(project_roundings(plan, family))),
                0.0,
            )
        }
        Kernel::Velocity => (0.0, e * r(3.0) * s.v),
        Kernel::Friction { family } => {
            let FamilyKind::HyperplaneContact { friction, .. } = plan.families[family].kind else {
                unreachable!("friction of a contact family")
            };
            let n = plan.dim as f64;
            (
                0.0,
                e * r(5.0 * n + 14.0) * s.v + friction * lambda_bound[family] / h,
            )
        }
        Kernel::Damping => (0.0, e * r(2.0) * s.v),
        Kernel::Broadphase | Kernel::Collide => {
            unreachable!("these cases have no collisions (the GPU backend refuses them)")
        }
        Kernel::Minimise => {
            unreachable!("XPBD scenes only; the barrier path has tests/gpu_barrier.rs")
        }
        Kernel::GuardMeasure { .. } | Kernel::GuardSpeed => {
            unreachable!("these cases have no guards (tests/gpu_guards.rs has them)")
        }
    }
}

/// One CPU/GPU pair on the same plan and input.
struct Pair {
    cpu: CpuBackend,
    gpu: GpuBackend,
    precision: Precision,
    /// f64 on an adapter where bit identity is asserted (bounds 0).
    exact: bool,
    name: String,
    /// Position bound of this substep's Project per family (for Friction).
    lambda_bound: Vec<f64>,
    /// Largest measured / bound over the run, per (kernel kind, metric).
    worst: Vec<(String, f64, f64)>,
}

impl Pair {
    fn new(adapter: &wgpu::Adapter, scene: &Scene, precision: Precision, name: &str) -> Self {
        let summary = hyperpbd_gpu::AdapterSummary::of(adapter);
        let plan = Plan::compile(scene).expect("compiles");
        let state = State::from_scene(scene);
        let gpu = GpuBackend::with_adapter(adapter, plan.clone(), &state, precision)
            .unwrap_or_else(|e| panic!("{name}: GPU backend: {e}"));
        let families = plan.families.len();
        let cpu = CpuBackend::new(plan, &state).expect("CPU backend");
        Pair {
            cpu,
            gpu,
            precision,
            exact: precision == Precision::F64 && f64_identical(&summary),
            name: name.into(),
            lambda_bound: vec![0.0; families],
            worst: Vec::new(),
        }
    }

    /// Copies the GPU state into the CPU backend: identical inputs.
    fn sync(&mut self) -> State {
        let state = self.gpu.read_state().expect("GPU read_state");
        self.cpu.write_state(&state).expect("CPU write_state");
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
    fn every_color(mut self) {
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
            let bound = if self.exact {
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

/// Every case of this file for one precision.
fn all_kernels(precision: Precision, test: &str) {
    let Some((adapter, _)) = adapter_or_skip(test, precision) else {
        return;
    };
    for (dim, n) in [(6, 37), (8, 37)] {
        Pair::new(
            &adapter,
            &chain(dim, n),
            precision,
            &format!("distance chain {dim}D({n})"),
        )
        .every_color();
    }
    for n in [37, 129] {
        Pair::new(
            &adapter,
            &chain3d(n),
            precision,
            &format!("distance chain3d({n})"),
        )
        .every_color();
    }
    Pair::new(
        &adapter,
        &triangles3d(37),
        precision,
        "simplex_measure k=2 triangles3d(37)",
    )
    .every_color();
    Pair::new(
        &adapter,
        &tesseract_jittered(),
        precision,
        "oriented_measure tesseract 4D",
    )
    .every_color();
    for (dim, n) in [(3, 129), (5, 37)] {
        Pair::new(
            &adapter,
            &contacts(dim, n),
            precision,
            &format!("contact+friction {dim}D({n})"),
        )
        .every_color();
    }
    // One particle: its only family is the plane contact; it penetrates and
    // slides.
    Pair::new(
        &adapter,
        &contacts(3, 1),
        precision,
        "one particle contact 3D(1)",
    )
    .every_color();
}

#[test]
fn every_kernel_alone_matches_the_cpu_f32() {
    all_kernels(Precision::F32, "every_kernel_alone_matches_the_cpu_f32");
}

#[test]
fn every_kernel_alone_matches_the_cpu_f64() {
    all_kernels(Precision::F64, "every_kernel_alone_matches_the_cpu_f64");
}

/// The cases are what they claim: the families, colors and the
/// static-friction regimes the bounds rely on.
#[test]
fn cases_cover_every_family_kind_and_sizes_not_dividing_the_workgroup() {
    let tess = Plan::compile(&tesseract_jittered()).unwrap();
    assert!(matches!(tess.families[0].kind, FamilyKind::OrientedMeasure));
    assert_eq!(tess.dim, 4);
    let tri = Plan::compile(&triangles3d(37)).unwrap();
    assert_eq!(tri.families[0].kind, FamilyKind::SimplexMeasure { k: 2 });
    assert_eq!(tri.dim, 3);
    for n in [37, 129] {
        let chain = Plan::compile(&chain3d(n)).unwrap();
        assert_eq!(chain.families[0].kind, FamilyKind::Distance);
        assert_ne!(n % 64, 0);
        assert!(chain.families[1].kind.is_inequality());
    }
    let one = Plan::compile(&contacts(3, 1)).unwrap();
    assert_eq!(one.particle_count(), 1);
    assert!(
        one.substep_kernels
            .contains(&Kernel::Friction { family: 0 })
    );
    for (dim, n) in [(3, 129), (5, 37)] {
        let plan = Plan::compile(&contacts(dim, n)).unwrap();
        assert!(
            plan.substep_kernels
                .contains(&Kernel::Friction { family: 0 })
        );
        assert!(plan.substep_kernels.contains(&Kernel::Damping));
    }
}

/// The empty scene: loads, steps (no kernel calls), reads back empty, on
/// both backends and both precisions.
#[test]
fn empty_scene_steps_and_stays_empty() {
    let scene = build(SceneBuilder::new(3).gravity_along(1, 9.81).damping(1.0));
    let plan = Plan::compile(&scene).unwrap();
    assert!(plan.substep_kernels.is_empty());
    let state = State::from_scene(&scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).unwrap();
    let cpu_report = cpu.step().expect("CPU steps an empty scene");
    // Equal to the GPU's but for the CPU thread count (who computed, not what).
    let cpu_report = hyperpbd::StepReport {
        threads: 0,
        ..cpu_report
    };
    assert!(cpu_report.kernel_calls.is_empty() && cpu_report.residuals.is_empty());
    assert!(cpu.read_state().unwrap().is_empty());
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, _)) = adapter_or_skip("empty_scene_steps_and_stays_empty", precision)
        else {
            return;
        };
        let mut gpu = GpuBackend::with_adapter(&adapter, plan.clone(), &state, precision).unwrap();
        for _ in 0..3 {
            let report = gpu.step().expect("GPU steps an empty scene");
            assert_eq!(report, cpu_report, "{precision}: empty-scene reports");
        }
        let read = gpu.read_state().unwrap();
        assert!(read.is_empty() && read.velocities.is_empty() && read.dim == 3);
        gpu.write_state(&read)
            .expect("write_state of the empty state");
    }
}

/// FORMER MISMATCH (fixed; this test keeps the two agreeing). `run_kernel`
/// accepts different kernel sets on the two backends:
///
/// - CPU: `check_kernel` (core/src/backend.rs) only checks that the kernel
///   names something in the plan, so `Friction { family }` of a contact
///   family with μ = 0, and `Predict` / `Velocity` on a plan with no dynamic
///   particle (empty schedule), run.
/// - GPU: additionally requires the kernel to be in `plan.substep_kernels`
///   (it only has parameter blocks for scheduled calls) and returns
///   `InvalidCall("… is not in this plan's schedule")`.
///
/// Measured before the fix (lavapipe): frictionless plane `Friction { family: 1 }`: CPU
/// `Ok(())`, GPU `Err(InvalidCall)`; all-fixed scene `Predict` and
/// `Velocity`: CPU `Ok(())`, GPU `Err(InvalidCall)`. Kernel-level
/// comparisons need one rule for both (most simply: `check_kernel` also
/// requires `plan.substep_kernels.contains(&kernel)`).
#[test]
fn run_kernel_accepts_the_same_kernels_on_both_backends() {
    let Some((adapter, _)) = adapter_or_skip(
        "run_kernel_accepts_the_same_kernels_on_both_backends",
        Precision::F32,
    ) else {
        return;
    };
    let mut frictionless = contacts(3, 5);
    frictionless.constraints.clear();
    if let hyperpbd::Obstacle::Hyperplane { friction, .. } = &mut frictionless.obstacles[0] {
        *friction = 0.0;
    }
    let mut frozen = chain3d(5);
    for p in &mut frozen.particles {
        p.fixed = true;
        p.velocity = None;
    }
    let cases = [
        (&frictionless, Kernel::Friction { family: 0 }),
        (&frozen, Kernel::Predict),
        (&frozen, Kernel::Velocity),
    ];
    let mut mismatches = Vec::new();
    for (scene, kernel) in cases {
        let plan = Plan::compile(scene).unwrap();
        let state = State::from_scene(scene);
        let mut cpu = CpuBackend::new(plan.clone(), &state).unwrap();
        let mut gpu = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F32).unwrap();
        let (c, g) = (
            cpu.run_kernel(kernel).is_ok(),
            gpu.run_kernel(kernel).is_ok(),
        );
        if c != g {
            mismatches.push(format!("{kernel:?}: cpu ok = {c}, gpu ok = {g}"));
        }
    }
    assert!(mismatches.is_empty(), "{}", mismatches.join("\n"));
}
