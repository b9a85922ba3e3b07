//! Barrier kernels on the GPU against the f64 golden path: the f64 `ln`
//! helper against libm, per-particle barrier energy / gradient / Hessian
//! block / smallest distance, and filter fractions, in f32 and f64, with
//! derived per-particle bounds printed as
//! `BOUND | name | measured | bound | rationale`.
//!
//! ```text
//! δd  = K·ε·S       distance error of the kernel: S = |x|∞ + max |obstacle coordinate| + r,
//!                   K = 16 (DIM + 4) covers the dot products, the Gram solve of a
//!                   well-shaped simplex (condition ≤ ~10) and the upload rounding
//! per obstacle with CPU distance d, direction n, |x − q| = ρ:
//!   Δb   ≤ max± |b(d ± δd) − b(d)|   + 16ε|b|   + κ e² λ
//!   Δg_a ≤ max± |b'(d ± δd) − b'(d)| + 16ε|b'| + 2κ|e| λ + |b'| δn
//!   ΔH   ≤ max± |b''(d ± δd) − b''(d)| + 16ε|b''| + 2κ λ + 2|b''| δn
//!   δn = 8ε (plane) or 2 δd / ρ (simplex);  λ = ln error (2^-21 in f32, 0 in f64:
//!   the arithmetic ln is within 16ε relative, inside the 16ε terms)
//! summed over obstacles. Samples closer than 4 δd to an obstacle are the
//! f32 floor: the kernel cannot resolve d there, they are counted and not
//! compared (in f64 there are none). The f32 filter fraction is certified
//! in exact arithmetic only where d0 > η δd / (1 − η) = 9 δd: the test checks
//! that every f32 fraction keeps d > 0 along the whole cut step in f64 for
//! samples above that floor.
//! ```

mod common;

use common::Lcg;
use common::gpu::adapter_or_skip;
use hyperpbd::barrier::{
    BarrierLaw, BarrierObstacles, FILTER_SAFETY, ParticleBarrier, evaluate_particle_barrier,
    filter_fraction,
};
use hyperpbd::gpu::Precision;
use hyperpbd::gpu::barrier::BarrierKernels;
use hyperpbd::{Obstacle, Scene};

const PRECISIONS: [Precision; 2] = [Precision::F32, Precision::F64];
const COUNTS: [usize; 5] = [0, 1, 63, 65, 200];

fn eps(precision: Precision) -> f64 {
    match precision {
        Precision::F32 => f32::EPSILON as f64,
        Precision::F64 => f64::EPSILON,
    }
}

/// Obstacles in R^dim: two planes, a triangle mesh (dim ≥ 2), a segment
/// mesh, a tetrahedron (dim ≥ 3).
fn obstacles(dim: usize) -> Scene {
    let mut scene = Scene::new(dim, 0.01, 1, 1);
    let mut n = vec![0.0; dim];
    n[0] = 1.0;
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: n,
        offset: -0.4,
        friction: 0.0,
        compliance: 0.0,
    });
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: (0..dim).map(|a| if a == 0 { -1.0 } else { 0.3 }).collect(),
        offset: -1.5,
        friction: 0.0,
        compliance: 0.0,
    });
    let point =
        |c: &[f64]| -> Vec<f64> { (0..dim).map(|a| c.get(a).copied().unwrap_or(0.0)).collect() };
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices: vec![point(&[0.0, 0.0, 0.3]), point(&[0.9, 0.1, 0.2])],
        simplices: vec![vec![0, 1]],
    });
    if dim >= 2 {
        scene.obstacles.push(Obstacle::SimplexMesh {
            vertices: vec![
                point(&[0.0, 0.0]),
                point(&[1.0, 0.0]),
                point(&[0.0, 1.0]),
                point(&[1.0, 1.0]),
            ],
            simplices: vec![vec![0, 1, 2], vec![1, 3, 2]],
        });
    }
    if dim >= 3 {
        scene.obstacles.push(Obstacle::SimplexMesh {
            vertices: vec![
                point(&[0.5, 0.5, -0.6]),
                point(&[1.3, 0.5, -0.6]),
                point(&[0.5, 1.3, -0.6]),
                point(&[0.5, 0.5, -1.4]),
            ],
            simplices: vec![vec![0, 1, 2, 3]],
        });
    }
    scene.solver = hyperpbd::Solver::IncrementalPotential(hyperpbd::IncrementalPotentialSettings {
        barrier_stiffness: 50.0,
        activation_distance: 0.25,
        convergence: hyperpbd::Convergence::PackedGradient { tolerance: 1e-8 },
        max_iterations: 10,
    });
    scene.validate().expect("valid obstacles");
    scene
}

/// `count` feasible particles (d > 1e-4 from every obstacle: the barrier
/// path never evaluates anything else), most of them within d^ of some
/// obstacle.
fn samples(
    geometry: &BarrierObstacles,
    dim: usize,
    count: usize,
    seed: u64,
) -> (Vec<f64>, Vec<f64>) {
    let mut rng = Lcg(seed);
    let mut x = Vec::new();
    let mut r = Vec::new();
    let mut n = vec![0.0; dim];
    while r.len() < count {
        let p: Vec<f64> = (0..dim)
            .map(|a| {
                if a < 2 {
                    0.5 + 0.6 * rng.next()
                } else {
                    0.3 * rng.next()
                }
            })
            .collect();
        let radius = 0.01 * (1.0 + rng.next());
        if (0..geometry.len()).all(|o| geometry.distance(o, &p, radius, &mut n) > 1e-4) {
            x.extend(p);
            r.push(radius);
        }
    }
    (x, r)
}

fn scale(x: &[f64], geometry: &BarrierObstacles, radius: f64) -> f64 {
    let coords = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let geo = geometry
        .plane_offsets
        .iter()
        .chain(&geometry.simplex_vertices)
        .fold(0.0f64, |m, v| m.max(v.abs()));
    coords + geo + radius
}

struct Bounds {
    energy: f64,
    gradient: f64,
    hessian: f64,
    distance: f64,
    floor: bool,
}

fn bounds(
    law: &BarrierLaw,
    geometry: &BarrierObstacles,
    x: &[f64],
    radius: f64,
    precision: Precision,
) -> Bounds {
    let dim = x.len();
    let e = eps(precision);
    let delta_d = 16.0 * (dim as f64 + 4.0) * e * scale(x, geometry, radius);
    let ln_error = match precision {
        Precision::F32 => 2f64.powi(-21),
        Precision::F64 => 0.0,
    };
    let mut out = Bounds {
        energy: 0.0,
        gradient: 0.0,
        hessian: 0.0,
        distance: delta_d,
        floor: false,
    };
    let mut n = vec![0.0; dim];
    for o in 0..geometry.len() {
        let d = geometry.distance(o, x, radius, &mut n);
        if d <= 4.0 * delta_d {
            out.floor = true;
        }
        let delta_n = if o < geometry.plane_count() {
            8.0 * e
        } else {
            2.0 * delta_d / (d + radius)
        };
        let (b, b1, b2) = law.evaluate(d);
        let spread = |k: usize| {
            let at = |t: f64| {
                let v = law.evaluate(t);
                [v.0, v.1, v.2][k]
            };
            let centre = [b, b1, b2][k];
            (at(d + delta_d) - centre)
                .abs()
                .max((at(d - delta_d) - centre).abs())
        };
        let dist = (d - law.activation_distance)
            .abs()
            .min(law.activation_distance);
        let kappa = law.stiffness;
        if d - delta_d >= law.activation_distance {
            continue;
        }
        out.energy += spread(0) + 16.0 * e * b.abs() + kappa * dist * dist * ln_error;
        out.gradient +=
            spread(1) + 16.0 * e * b1.abs() + 2.0 * kappa * dist * ln_error + b1.abs() * delta_n;
        out.hessian +=
            spread(2) + 16.0 * e * b2.abs() + 2.0 * kappa * ln_error + 2.0 * b2.abs() * delta_n;
    }
    out
}

#[test]
fn f64_ln_matches_libm_over_a_wide_range() {
    for precision in PRECISIONS {
        let Some((adapter, _)) =
            adapter_or_skip("f64_ln_matches_libm_over_a_wide_range", precision)
        else {
            continue;
        };
        let law = BarrierLaw {
            stiffness: 1.0,
            activation_distance: 1.0,
        };
        let kernels =
            BarrierKernels::new(&adapter, precision, 1, law, &BarrierObstacles::default())
                .expect("kernels");
        let mut values = Vec::new();
        for k in -600..=600 {
            values.push(10f64.powf(k as f64 / 2.0));
            values.push(1.7 * 10f64.powf(k as f64 / 2.0));
        }
        for k in 1..=15 {
            let t = 10f64.powi(-k);
            values.extend([
                1.0 + t,
                1.0 - t,
                2f64.sqrt() * (1.0 + t),
                0.5f64.sqrt() * (1.0 - t),
            ]);
        }
        values.extend([1.0, 2.0, 0.5, f64::MIN_POSITIVE, f64::MAX]);
        if precision == Precision::F32 {
            values.retain(|&v| v > 1e-37 && v < 1e37);
        }
        let got = kernels.ln(&values).expect("ln");
        let mut worst: f64 = 0.0;
        for (&v, &g) in values.iter().zip(&got) {
            let exact = libm::log(v);
            let allowed = match precision {
                // 4 ulp of the result.
                Precision::F64 => 4.0 * f64::EPSILON * exact.abs(),
                // Input rounded to f32 (ε/2 absolute in ln), the Vulkan
                // allowance for log (3 ulp, 2^-21 absolute near 1).
                Precision::F32 => {
                    f64::from(f32::EPSILON) * (0.5 + 3.0 * exact.abs()) + 2f64.powi(-21)
                }
            };
            worst = worst.max((g - exact).abs() / allowed.max(f64::MIN_POSITIVE));
            assert!(
                (g - exact).abs() <= allowed,
                "{precision}: ln({v:e}) = {g:e}, libm {exact:e}, allowed {allowed:e}"
            );
        }
        println!(
            "BOUND | ln {precision} vs libm, {} values over the precision's range | {worst:.3} | 1 | fraction of the allowance (f64: 4 ulp of ln x; f32: ε(0.5 + 3|ln x|) + 2^-21)",
            values.len()
        );
    }
}

#[test]
fn barrier_evaluation_matches_the_golden_path() {
    for precision in PRECISIONS {
        let Some((adapter, _)) =
            adapter_or_skip("barrier_evaluation_matches_the_golden_path", precision)
        else {
            continue;
        };
        for dim in [1usize, 2, 3, 4, 8] {
            let scene = obstacles(dim);
            let geometry = BarrierObstacles::compile(&scene);
            let law = BarrierLaw {
                stiffness: 50.0,
                activation_distance: 0.25,
            };
            let kernels =
                BarrierKernels::new(&adapter, precision, dim, law, &geometry).expect("kernels");
            let mut worst = [0.0f64; 4];
            let mut worst_tight: f64 = 0.0;
            let mut floor = 0;
            let mut compared = 0;
            let mut identical = 0;
            for count in COUNTS {
                let (x, r) = samples(&geometry, dim, count, 17 + count as u64 + dim as u64);
                let gpu = kernels.evaluate(&x, &r).expect("evaluate");
                assert_eq!(gpu.energy.len(), count);
                let mut cpu = ParticleBarrier::new(dim);
                for i in 0..count {
                    let xi = &x[i * dim..(i + 1) * dim];
                    evaluate_particle_barrier(&law, &geometry, xi, r[i], &mut cpu);
                    let b = bounds(&law, &geometry, xi, r[i], precision);
                    if b.floor {
                        floor += 1;
                        continue;
                    }
                    compared += 1;
                    let de = (gpu.energy[i] - cpu.energy).abs();
                    let dg = (0..dim)
                        .map(|a| (gpu.gradient[i * dim + a] - cpu.gradient[a]).abs())
                        .fold(0.0, f64::max);
                    let dh = (0..dim * dim)
                        .map(|a| (gpu.hessian[i * dim * dim + a] - cpu.hessian[a]).abs())
                        .fold(0.0, f64::max);
                    let dd = (gpu.min_distance[i] - cpu.min_distance).abs();
                    if de == 0.0 && dg == 0.0 && dh == 0.0 && dd == 0.0 {
                        identical += 1;
                    }
                    let ratios = [
                        de / b.energy.max(f64::MIN_POSITIVE),
                        dg / b.gradient.max(f64::MIN_POSITIVE),
                        dh / b.hessian.max(f64::MIN_POSITIVE),
                        dd / b.distance,
                    ];
                    for k in 0..4 {
                        worst[k] = worst[k].max(if [de, dg, dh, dd][k] == 0.0 {
                            0.0
                        } else {
                            ratios[k]
                        });
                    }
                    if precision == Precision::F64 {
                        // f64: distances and directions come out bit-identical
                        // (same operations in the same order); only ln differs
                        // (≤ 4 ulp, its own test), and its change re-rounds
                        // through ≤ 4 products: 8u of each term that holds ln.
                        let u = f64::EPSILON / 2.0;
                        let (mut te, mut tg, mut th) = (0.0, 0.0, 0.0);
                        let mut nn = vec![0.0; dim];
                        for o in 0..geometry.len() {
                            let d = geometry.distance(o, xi, r[i], &mut nn);
                            if d >= law.activation_distance {
                                continue;
                            }
                            let (bb, b1, b2) = law.evaluate(d);
                            let ln = libm::log(d / law.activation_distance).abs();
                            let ed = (d - law.activation_distance).abs();
                            te += 16.0 * u * bb.abs();
                            tg += 16.0 * u * (b1.abs() + 2.0 * law.stiffness * ed * ln);
                            th += 16.0 * u * (b2.abs() + 2.0 * law.stiffness * ln);
                        }
                        assert_eq!(dd, 0.0, "f64 distances are bit-identical");
                        assert!(
                            de <= te && dg <= tg && dh <= th,
                            "f64 tight: {de:e}/{te:e} {dg:e}/{tg:e} {dh:e}/{th:e}"
                        );
                        for (m, t) in [(de, te), (dg, tg), (dh, th)] {
                            if m > 0.0 {
                                worst_tight = worst_tight.max(m / t);
                            }
                        }
                    }
                    assert!(
                        de <= b.energy && dg <= b.gradient && dh <= b.hessian && dd <= b.distance,
                        "{precision} dim {dim} particle {i} of {count}: energy {de:e}/{:e}, gradient {dg:e}/{:e}, hessian {dh:e}/{:e}, distance {dd:e}/{:e}",
                        b.energy,
                        b.gradient,
                        b.hessian,
                        b.distance
                    );
                }
            }
            if precision == Precision::F64 {
                assert_eq!(floor, 0, "f64 has no floor at these scales");
                println!(
                    "BOUND | barrier energy/gradient/hessian f64 dim {dim}, ln-only bound | {worst_tight:.3e} | 1 | distances bit-identical; 16u of every term holding ln (f64 ln within 4 ulp)"
                );
            }
            for (k, name) in ["energy", "gradient", "hessian block", "min distance"]
                .iter()
                .enumerate()
            {
                println!(
                    "BOUND | barrier {name} {precision} dim {dim} ({compared} particles, {identical} bit-identical, {floor} under the f32 floor) | {:.3e} | 1 | largest measured/derived-bound ratio (module docs)",
                    worst[k]
                );
            }
        }
    }
}

#[test]
fn filter_fractions_match_the_golden_path_and_stay_certified() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip(
            "filter_fractions_match_the_golden_path_and_stay_certified",
            precision,
        ) else {
            continue;
        };
        for dim in [1usize, 2, 3, 4, 8] {
            let scene = obstacles(dim);
            let geometry = BarrierObstacles::compile(&scene);
            let law = BarrierLaw {
                stiffness: 50.0,
                activation_distance: 0.25,
            };
            let kernels =
                BarrierKernels::new(&adapter, precision, dim, law, &geometry).expect("kernels");
            let e = eps(precision);
            let mut worst: f64 = 0.0;
            let mut cut = 0;
            let mut checked = 0;
            for count in COUNTS {
                let (x, r) = samples(&geometry, dim, count, 99 + count as u64 + dim as u64);
                let mut rng = Lcg(5 + count as u64);
                let deltas: Vec<f64> = (0..count * dim).map(|_| 0.8 * rng.next()).collect();
                let gpu = kernels.filter_fractions(&x, &r, &deltas).expect("filter");
                let mut n = vec![0.0; dim];
                for i in 0..count {
                    let xi = &x[i * dim..(i + 1) * dim];
                    let di = &deltas[i * dim..(i + 1) * dim];
                    let cpu = filter_fraction(&geometry, xi, r[i], di);
                    let delta_d = 16.0 * (dim as f64 + 4.0) * e * scale(xi, &geometry, r[i]);
                    let length = di.iter().map(|c| c * c).sum::<f64>().sqrt();
                    // Bound: max over obstacles of η (δd/a + d0 δa/a²), δa = 16 (DIM+4) ε |Δ|.
                    let mut bound: f64 = 0.0;
                    let mut smallest = f64::INFINITY;
                    for o in 0..geometry.len() {
                        let d0 = geometry.distance(o, xi, r[i], &mut n);
                        smallest = smallest.min(d0);
                        let a = if o < geometry.plane_count() {
                            -(0..dim).map(|k| n[k] * di[k]).sum::<f64>()
                        } else {
                            length
                        };
                        let da = 16.0 * (dim as f64 + 4.0) * e * length;
                        if a > da && FILTER_SAFETY * (d0 - delta_d) / (a + da) < 1.0 {
                            bound = bound.max(
                                FILTER_SAFETY * (delta_d / (a - da) + d0 * da / ((a - da) * a)),
                            );
                        }
                    }
                    if smallest <= 9.0 * delta_d {
                        continue; // under the floor: neither compared nor certified
                    }
                    checked += 1;
                    if cpu < 1.0 {
                        cut += 1;
                    }
                    let diff = (gpu[i] - cpu).abs();
                    worst = worst.max(if diff == 0.0 {
                        0.0
                    } else {
                        diff / bound.max(f64::MIN_POSITIVE)
                    });
                    assert!(
                        diff <= bound,
                        "{precision} dim {dim} particle {i}: fraction {} vs {cpu}: {diff:e} > {bound:e}",
                        gpu[i]
                    );
                    // Certified: the cut step keeps d > 0 (checked in f64).
                    for s in 0..=16 {
                        let y: Vec<f64> = (0..dim)
                            .map(|k| xi[k] + gpu[i] * s as f64 / 16.0 * di[k])
                            .collect();
                        for o in 0..geometry.len() {
                            assert!(
                                geometry.distance(o, &y, r[i], &mut n) > 0.0,
                                "{precision} dim {dim} particle {i}: GPU fraction {} crosses obstacle {o}",
                                gpu[i]
                            );
                        }
                    }
                }
            }
            assert!(checked == 0 || cut > 0, "no step was cut");
            println!(
                "BOUND | filter fraction {precision} dim {dim} ({checked} particles, {cut} cut) | {worst:.3e} | 1 | largest measured/derived-bound ratio; every GPU fraction keeps d > 0 along the cut step (f64 check)"
            );
        }
    }
}

// ---------------------------------------------------------------------------
// Whole steps: GpuBarrierBackend against the CPU golden backend
// ---------------------------------------------------------------------------

use hyperpbd::compare_barrier::BarrierErrorModel;
use hyperpbd::gpu::GpuBarrierBackend;
use hyperpbd::{Backend, Convergence, CpuBackend, MinimisationStatus, Particle, Plan, State};

fn solver(
    convergence: Convergence,
    kappa: f64,
    dhat: f64,
    max_iterations: u32,
) -> hyperpbd::Solver {
    hyperpbd::Solver::IncrementalPotential(hyperpbd::IncrementalPotentialSettings {
        barrier_stiffness: kappa,
        activation_distance: dhat,
        convergence,
        max_iterations,
    })
}

fn smallest_distance(scene: &Scene, state: &State) -> f64 {
    let geometry = BarrierObstacles::compile(scene);
    let mut n = vec![0.0; scene.dim];
    let mut d = f64::INFINITY;
    for (i, p) in scene.particles.iter().enumerate() {
        if p.fixed {
            continue;
        }
        for o in 0..geometry.len() {
            d = d.min(geometry.distance(o, state.position(i), p.radius, &mut n));
        }
    }
    d
}

/// Runs `steps` steps on the CPU and on the GPU at `precision`, checking the
/// divergence against [`BarrierErrorModel`] and d > 0 (in f64, on the GPU's
/// own state) after every step. Returns (worst ratio, steps with identical
/// states, smallest d on the GPU, "dx / bound, dv / bound" at the last step).
fn whole_steps(
    adapter: &wgpu::Adapter,
    scene: &Scene,
    precision: Precision,
    steps: u64,
) -> (f64, u64, f64, String) {
    let plan = Plan::compile(scene).expect("valid");
    let state = State::from_scene(scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let mut gpu =
        GpuBarrierBackend::with_adapter(adapter, plan.clone(), &state, precision).expect("gpu");
    let mut model = BarrierErrorModel::new(&plan, precision);
    let mut scale = hyperpbd::compare::coordinate_scale(&state);
    let mut worst: f64 = 0.0;
    let mut identical = 0;
    let mut smallest = f64::INFINITY;
    let mut last = String::new();
    for step in 1..=steps {
        let a = cpu.step().expect("cpu step");
        let b = gpu.step().expect("gpu step");
        assert_eq!(a.minimisation.len(), b.minimisation.len());
        for m in &b.minimisation {
            assert!(
                !matches!(m.status, MinimisationStatus::Refused(_)),
                "{precision}: {m:?}"
            );
        }
        let golden = cpu.read_state().expect("cpu state");
        let other = gpu.read_state().expect("gpu state");
        scale = scale.max(hyperpbd::compare::coordinate_scale(&golden));
        model.advance(&a.minimisation, &b.minimisation, scale);
        let dx = hyperpbd::compare::max_abs_diff(&golden.positions, &other.positions);
        let dv = hyperpbd::compare::max_abs_diff(&golden.velocities, &other.velocities);
        let (px, pv) = (model.position_bound(), model.velocity_bound());
        assert!(
            dx <= px && dv <= pv,
            "{precision} step {step}: |dx| {dx:e}/{px:e}, |dv| {dv:e}/{pv:e}"
        );
        if dx == 0.0 && dv == 0.0 {
            identical += 1;
        }
        worst = worst.max(dx / px).max(dv / pv);
        last = format!("{dx:.2e} / {px:.2e}, {dv:.2e} / {pv:.2e}");
        let d = smallest_distance(scene, &other);
        assert!(
            scene.particles.iter().all(|p| p.fixed) || d > 0.0,
            "{precision} step {step}: GPU state at d = {d:e}"
        );
        smallest = smallest.min(d);
    }
    (worst, identical, smallest, last)
}

fn drop_scene(count: usize, speed: f64, convergence: Convergence) -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    let mut rng = Lcg(3 + count as u64);
    for i in 0..count {
        scene.particles.push(
            Particle::new(
                vec![0.3 * rng.next(), 1.0 + 0.5 * rng.next(), 0.3 * rng.next()],
                1.0 + 0.5 * rng.next(),
            )
            .with_velocity(vec![0.0, -speed * (0.5 + 0.5 * rng.next()), 0.0])
            .with_radius(0.05),
        );
        if i % 7 == 3 {
            scene.particles.push(Particle::fixed(vec![5.0, -1.0, 0.0]));
        }
    }
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.0,
        compliance: 0.0,
    });
    scene.solver = solver(convergence, 1e3, 0.01, 200);
    scene
}

#[test]
fn seed_example_on_the_gpu() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip("seed_example_on_the_gpu", precision) else {
            continue;
        };
        for (dt, convergence, expected) in [
            (5e-6, Convergence::PackedGradient { tolerance: 1e-8 }, 1.0),
            (2e-6, Convergence::PackedGradient { tolerance: 1e-8 }, 0.0),
            (
                2e-6,
                Convergence::MaxAccelerationResidual { tolerance: 1e-3 },
                1.0,
            ),
        ] {
            let mut scene = Scene::new(1, dt, 1, 1);
            scene
                .particles
                .push(Particle::new(vec![0.0], 1.0).with_force(vec![1000.0]));
            scene.solver = solver(convergence, 1.0, 0.1, 20);
            let plan = Plan::compile(&scene).unwrap();
            let state = State::from_scene(&scene);
            let mut cpu = CpuBackend::new(plan.clone(), &state).unwrap();
            let mut gpu =
                GpuBarrierBackend::with_adapter(&adapter, plan, &state, precision).unwrap();
            let steps = (1e-3 / dt).round() as usize;
            let below_floor = precision == Precision::F32
                && matches!(convergence, Convergence::MaxAccelerationResidual { .. });
            if below_floor {
                // The acceleration residual of f32 positions cannot fall below
                // ~ε X / h² (X the coordinate, h = 2e-6: ε X / h² ≈ 3e4 X m/s²),
                // under the tolerance 1e-3 m/s² once X ≳ 1e-7 m. Those steps end
                // at the rounding floor (typed status, accepted), never with a
                // silently different criterion; the velocity then carries the
                // position rounding, ≤ 4 ε X / h per step.
                let mut floors = 0;
                for _ in 0..steps {
                    let report = gpu.step().expect("accepted");
                    match report.minimisation[0].status {
                        MinimisationStatus::Converged => {}
                        MinimisationStatus::RoundingFloor => floors += 1,
                        ref other => panic!("unexpected {other:?}"),
                    }
                }
                let v = gpu.read_state().unwrap().velocities[0];
                let bound = 4.0 * steps as f64 * eps(precision) * 5e-4 / dt;
                println!(
                    "BOUND | seed example f32 dt {dt:e} max_acceleration_residual 1e-3 ({floors} of {steps} steps at the rounding floor): |v − 1| | {:e} | {bound:e} | position rounding ≤ 4 ε X / h per step, X ≤ 5e-4 m",
                    (v - 1.0).abs()
                );
                assert!(floors > 0, "f32 reaches its floor at dt 2e-6");
                assert!((v - 1.0).abs() <= bound);
                continue;
            }
            for _ in 0..steps {
                let a = cpu.step().unwrap();
                let b = gpu.step().unwrap();
                assert_eq!(b.minimisation[0].status, MinimisationStatus::Converged);
                if precision == Precision::F64 {
                    assert_eq!(
                        a.minimisation, b.minimisation,
                        "f64: same iterations and residuals"
                    );
                }
            }
            let v_cpu = cpu.read_state().unwrap().velocities[0];
            let v_gpu = gpu.read_state().unwrap().velocities[0];
            if precision == Precision::F64 {
                assert_eq!(
                    v_gpu.to_bits(),
                    v_cpu.to_bits(),
                    "f64 GPU is bit-identical to the golden path"
                );
            }
            // f32: each step's v = (x − x_prev)/h rounds at ε|x|/h ≤ 1.2e-7·5e-4/2e-6;
            // the packed floor at dt 2e-6 still converges at the warm start (0 exactly).
            let bound = if expected == 0.0 {
                0.0
            } else {
                64.0 * eps(precision) * 5e-4 / dt + 1e-9
            };
            println!(
                "BOUND | seed example {precision} dt {dt:e} {}: |v − {expected}| | {:e} | {bound:e} | v = (x − x_prev)/h rounds at ε|x|/h per step",
                convergence.as_str(),
                (v_gpu - expected).abs()
            );
            assert!(
                (v_gpu - expected).abs() <= bound,
                "{precision}: v = {v_gpu}"
            );
        }
    }
}

#[test]
fn whole_steps_match_the_golden_path() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip("whole_steps_match_the_golden_path", precision)
        else {
            continue;
        };
        // f32: the acceleration residual's rounding floor is ~ε X / h² ≈ 1e-2 m/s²
        // in free flight (X = 2, h = 1/60) and ~b''(d) ε X / m ≈ 0.1–0.3 m/s² in
        // resting contact (b'' ≈ 4e5 N/m at d ≈ 5e-4); the tolerance sits above it.
        let tolerance = match precision {
            Precision::F32 => 1.0,
            Precision::F64 => 1e-4,
        };
        for (count, speed) in [(0, 1.0), (1, 1.0), (1, 100.0), (65, 10.0), (200, 100.0)] {
            let scene = drop_scene(
                count,
                speed,
                Convergence::MaxAccelerationResidual { tolerance },
            );
            let (worst, identical, smallest, last) = whole_steps(&adapter, &scene, precision, 60);
            println!(
                "BOUND | whole step {precision}: drop on a plane, {count} particles at up to {speed} m/s, 60 steps ({identical} bit-identical, smallest d {smallest:.2e}; final |dx|, |dv| vs bound: {last}) | {worst:.3e} | 1 | largest ratio to BarrierErrorModel (src/compare_barrier.rs)"
            );
        }
        // A 4D triangle mesh (slide) and the packed criterion.
        let mut scene = Scene::new(4, 1.0 / 60.0, 2, 1);
        scene.gravity = Some(vec![0.0, 0.0, 0.0, -9.81]);
        let mut vertices = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                vertices.push(vec![i as f64 * 0.5, j as f64 * 0.5, 0.0, 0.0]);
            }
        }
        let mut simplices = Vec::new();
        for i in 0..2 {
            for j in 0..2 {
                let v = |a: usize, b: usize| a * 3 + b;
                simplices.push(vec![v(i, j), v(i + 1, j), v(i, j + 1)]);
                simplices.push(vec![v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
        scene.obstacles.push(Obstacle::SimplexMesh {
            vertices,
            simplices,
        });
        scene.particles.push(
            Particle::new(vec![0.1, 0.6, 0.0, 0.05], 1.0).with_velocity(vec![0.5, 0.0, 0.0, 0.0]),
        );
        let tolerance = match precision {
            Precision::F32 => 1e-4,
            Precision::F64 => 1e-9,
        };
        scene.solver = solver(Convergence::PackedGradient { tolerance }, 1e3, 0.02, 100);
        let (worst, identical, smallest, last) = whole_steps(&adapter, &scene, precision, 60);
        println!(
            "BOUND | whole step {precision}: slide over a 4D triangle mesh, 2 substeps, packed gradient, 60 steps ({identical} bit-identical, smallest d {smallest:.2e}; final |dx|, |dv| vs bound: {last}) | {worst:.3e} | 1 | largest ratio to BarrierErrorModel"
        );
    }
}

/// The f32 floor near d → 0: 200 particles hitting a plane at up to
/// 100 m/s are driven to d ~ 1e-5 within an iteration or two, where b'' is
/// ~1e9 N/m and the f32 acceleration residual cannot fall below
/// b'' ε X / m. There every particle ends at its rounding floor (the
/// expected Newton decrease is below the rounding of F's change) and the
/// minimisation reports `RoundingFloor`; a refusal would be typed and
/// rolled back. The GPU never hands back a state at d ≤ 0 (checked in f64
/// after every accepted step).
#[test]
fn f32_floor_near_contact_never_tunnels() {
    let Some((adapter, _)) =
        adapter_or_skip("f32_floor_near_contact_never_tunnels", Precision::F32)
    else {
        return;
    };
    let scene = drop_scene(
        200,
        100.0,
        Convergence::MaxAccelerationResidual { tolerance: 1e-3 },
    );
    let plan = Plan::compile(&scene).unwrap();
    let mut gpu =
        GpuBarrierBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), Precision::F32)
            .unwrap();
    let (mut accepted, mut at_floor, mut refused) = (0, 0, 0);
    let mut smallest = f64::INFINITY;
    for _ in 0..30 {
        let before = gpu.read_state().unwrap();
        match gpu.step() {
            Ok(report) => {
                accepted += 1;
                at_floor += report
                    .minimisation
                    .iter()
                    .filter(|m| m.status == MinimisationStatus::RoundingFloor)
                    .count();
                let s = gpu.read_state().unwrap();
                let d = smallest_distance(&scene, &s);
                assert!(d > 0.0);
                smallest = smallest.min(d);
            }
            Err(hyperpbd::BackendError::Step(hyperpbd::StepError::MinimisationRefused {
                ..
            })) => {
                refused += 1;
                assert_eq!(gpu.read_state().unwrap().hash(), before.hash());
                break;
            }
            Err(e) => panic!("unexpected {e}"),
        }
    }
    println!(
        "f32 floor: 200 particles at up to 100 m/s, tolerance 1e-3 m/s²: {accepted} steps accepted ({at_floor} at the rounding floor), {refused} refused; smallest d {smallest:e}"
    );
    // A tolerance below the f32 floor must end in RoundingFloor (accepted,
    // reported), never in a refusal or a false convergence.
    assert_eq!(refused, 0, "a step below the f32 floor was refused");
    assert_eq!(accepted, 30);
    assert!(at_floor > 0, "no substep reported the rounding floor");
}

#[test]
fn gpu_infeasible_start_is_refused_before_anything_moves() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip(
            "gpu_infeasible_start_is_refused_before_anything_moves",
            precision,
        ) else {
            continue;
        };
        let scene = drop_scene(
            3,
            1.0,
            Convergence::MaxAccelerationResidual { tolerance: 0.1 },
        );
        let plan = Plan::compile(&scene).unwrap();
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), precision)
                .unwrap();
        gpu.step().unwrap();
        let mut bad = gpu.read_state().unwrap();
        bad.positions[3 + 1] = -0.5;
        gpu.write_state(&bad).unwrap();
        let written = gpu.read_state().unwrap();
        let err = gpu.step().expect_err("infeasible");
        let text = err.to_string();
        assert!(text.contains("particle 1 starts at distance"), "{text}");
        assert_eq!(gpu.read_state().unwrap().hash(), written.hash());
    }
}

/// A refusal after accepted substeps (the CPU twin is in tests/barrier.rs):
/// gravity pointing away from the plane moves the particle by h²g per
/// substep and adds as much speed, until the Newton slope ≈ m|Δ|² overflows
/// the precision (h²g = 1e153 m in f64, 1e18 m in f32). The refusal's
/// substep > 0 proves the state had moved; the GPU must restore it byte
/// for byte from its device copies.
#[test]
fn gpu_refusal_after_accepted_substeps_rolls_back_byte_for_byte() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip(
            "gpu_refusal_after_accepted_substeps_rolls_back_byte_for_byte",
            precision,
        ) else {
            continue;
        };
        let mut scene = drop_scene(
            1,
            0.0,
            Convergence::MaxAccelerationResidual { tolerance: 1.0 },
        );
        let g = match precision {
            Precision::F32 => 1e22,
            Precision::F64 => 1e157,
        };
        scene.dt = 0.4;
        scene.substeps = 40; // h = 0.01
        scene.gravity = Some(vec![0.0, g, 0.0]);
        let plan = Plan::compile(&scene).unwrap();
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), precision)
                .unwrap();
        let before = gpu.read_state().unwrap();
        let err = gpu.step().expect_err("the slope overflows");
        match &err {
            hyperpbd::BackendError::Step(hyperpbd::StepError::MinimisationRefused {
                substep,
                ..
            }) => assert!(
                *substep > 0,
                "{precision}: refused in substep 0: nothing moved"
            ),
            other => panic!("{precision}: unexpected {other:?}"),
        }
        assert_eq!(
            gpu.read_state().unwrap().hash(),
            before.hash(),
            "{precision}"
        );
        println!("{precision}: {err}");
    }
}

/// The GPU barrier path is bit-identical across runs on one adapter (no
/// float atomics, fixed reduction tree), in both precisions.
#[test]
fn gpu_barrier_path_is_deterministic() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip("gpu_barrier_path_is_deterministic", precision)
        else {
            continue;
        };
        let scene = hyperpbd::scenes::barrier4d();
        let plan = Plan::compile(&scene).unwrap();
        let run = || {
            let mut gpu = GpuBarrierBackend::with_adapter(
                &adapter,
                plan.clone(),
                &State::from_scene(&scene),
                precision,
            )
            .unwrap();
            let mut reports = Vec::new();
            for _ in 0..30 {
                reports.push(gpu.step().unwrap().minimisation);
            }
            (gpu.read_state().unwrap().hash(), reports)
        };
        let (a, ra) = run();
        let (b, rb) = run();
        assert_eq!(a, b, "{precision}: two runs differ");
        assert_eq!(ra, rb, "{precision}: reports differ");
        println!("DETERMINISM | barrier4d {precision} 30 steps | {a:016x}");
    }
}

/// One particle thrown at a plane at 1e4 m/s (167 m per step at dt = 1/60,
/// from 2 m away) on the GPU, both precisions: no accepted state reaches
/// d ≤ 0 (checked in f64), and every step is accepted.
#[test]
fn gpu_drop_at_1e4_m_per_s_never_tunnels() {
    for precision in PRECISIONS {
        let Some((adapter, _)) =
            adapter_or_skip("gpu_drop_at_1e4_m_per_s_never_tunnels", precision)
        else {
            continue;
        };
        let tolerance = match precision {
            Precision::F32 => 1.0,
            Precision::F64 => 1e-4,
        };
        let mut scene = drop_scene(1, 1.0, Convergence::MaxAccelerationResidual { tolerance });
        scene.particles[0].velocity = Some(vec![0.0, -1e4, 0.0]);
        let plan = Plan::compile(&scene).unwrap();
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), precision)
                .unwrap();
        let mut smallest = f64::INFINITY;
        let mut statuses = Vec::new();
        for _ in 0..120 {
            let report = gpu.step().expect("accepted");
            statuses.extend(report.minimisation.into_iter().map(|m| m.status));
            let d = smallest_distance(&scene, &gpu.read_state().unwrap());
            assert!(d > 0.0, "{precision}: d = {d:e}");
            smallest = smallest.min(d);
        }
        let floors = statuses
            .iter()
            .filter(|s| **s == MinimisationStatus::RoundingFloor)
            .count();
        println!(
            "{precision}: 1e4 m/s drop, 120 steps, smallest d {smallest:e}, {floors} at the rounding floor"
        );
    }
}

/// f32 far from the world origin: the same drop 1e5 m away (scene and
/// plane moved together) stays within the bound of the scene at the origin,
/// because `GpuBarrierBackend` stores f32 positions relative to a scene
/// origin and shifts the obstacles with them (`gpu/src/origin.rs`). In f32
/// world coordinates every position there would be rounded to
/// ulp(1e5)/2 = 3.9e-3 m, above that bound.
#[test]
fn f32_far_from_the_origin_keeps_the_accuracy_of_the_origin() {
    let precision = Precision::F32;
    let Some((adapter, _)) = adapter_or_skip(
        "f32_far_from_the_origin_keeps_the_accuracy_of_the_origin",
        precision,
    ) else {
        return;
    };
    let offset = 1e5;
    let tolerance = Convergence::MaxAccelerationResidual { tolerance: 1.0 };
    let near = drop_scene(65, 10.0, tolerance);
    let mut far = near.clone();
    for p in &mut far.particles {
        p.position[0] += offset;
        p.position[1] += offset;
    }
    let Obstacle::Hyperplane { offset: plane, .. } = &mut far.obstacles[0] else {
        unreachable!("drop_scene has one plane");
    };
    *plane += offset;

    let plan = Plan::compile(&far).expect("valid");
    let state = State::from_scene(&far);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let mut gpu =
        GpuBarrierBackend::with_adapter(&adapter, plan.clone(), &state, precision).expect("gpu");
    // The model of the scene at the origin: coordinates of size |x_near|.
    let mut model = BarrierErrorModel::new(&plan, precision);
    let near_scale = hyperpbd::compare::coordinate_scale(&State::from_scene(&near));
    let mut worst: f64 = 0.0;
    for step in 1..=30 {
        let a = cpu.step().expect("cpu step");
        let b = gpu.step().expect("gpu step");
        model.advance(&a.minimisation, &b.minimisation, near_scale);
        let golden = cpu.read_state().expect("cpu state");
        let other = gpu.read_state().expect("gpu state");
        let dx = hyperpbd::compare::max_abs_diff(&golden.positions, &other.positions);
        let bound = model.position_bound();
        assert!(dx <= bound, "step {step}: |dx| {dx:e} > {bound:e}");
        let d = smallest_distance(&far, &other);
        assert!(d > 0.0, "step {step}: GPU state at d = {d:e}");
        worst = worst.max(dx / bound);
    }
    println!(
        "BOUND | barrier f32 drop at 1e5 m | {worst:.3e} of the bound at the origin | 1 | \
         origin shift; without it ulp(1e5)/2 = 3.9e-3 m per coordinate"
    );
}
