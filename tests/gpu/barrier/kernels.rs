//! Barrier kernels against the golden path: the f64 `ln`, per-particle energy,
//! gradient, Hessian block and smallest distance, filter fractions; in
//! f32 on llvmpipe also bit for bit against the f32 reference
//! (`hyperpbd_cpu::f32_reference::barrier`).

use super::*;
use common::exact::f32_identical;
use hyperpbd_cpu::f32_reference::barrier as reference;

/// The f32 reference's kernel inputs where f32 results are held bit for
/// bit to it (f32 on llvmpipe: `common::exact::f32_identical`).
fn reference_inputs(
    summary: &hyperpbd::gpu::AdapterSummary,
    precision: Precision,
    dim: usize,
    law: &BarrierLaw,
    geometry: &BarrierObstacles,
) -> Option<reference::BarrierInputs> {
    (precision == Precision::F32 && f32_identical(summary))
        .then(|| reference::BarrierInputs::new(dim, law, geometry))
}

/// Values as uploaded in f32: each rounded once.
fn f32s(values: &[f64]) -> Vec<f32> {
    values.iter().map(|&v| v as f32).collect()
}

/// Asserts a GPU value read back from f32 is `expected` bit for bit.
fn assert_bits(what: &str, got: f64, expected: f64) {
    assert!(
        got.to_bits() == expected.to_bits(),
        "{what}: GPU {got:e} ({:#018x}) vs f32 reference {expected:e} ({:#018x})",
        got.to_bits(),
        expected.to_bits()
    );
}

/// Prints the BOUND line of `identical` f32 rows bit-identical to the
/// f32 reference, after checking every sampled particle was compared.
fn report_identical(what: &str, dim: usize, identical: usize) {
    let sampled: usize = COUNTS.iter().sum();
    assert_eq!(
        identical, sampled,
        "{what} dim {dim}: every particle compared to the f32 reference"
    );
    print_bound(
        format_args!("{what} f32 dim {dim} vs f32 reference ({identical} particles bit-identical)"),
        "0",
        "0",
        "llvmpipe (common::exact::f32_identical): the f32 rows are bit-identical to the f32 reference",
    );
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
        motion: Vec::new(),
    });
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: (0..dim).map(|a| if a == 0 { -1.0 } else { 0.3 }).collect(),
        offset: -1.5,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    let point =
        |c: &[f64]| -> Vec<f64> { (0..dim).map(|a| c.get(a).copied().unwrap_or(0.0)).collect() };
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices: vec![point(&[0.0, 0.0, 0.3]), point(&[0.9, 0.1, 0.2])],
        simplices: vec![vec![0, 1]],
        friction: 0.0,
        motion: Vec::new(),
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
            friction: 0.0,
            motion: Vec::new(),
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
            friction: 0.0,
            motion: Vec::new(),
        });
    }
    scene.solver = hyperpbd::Solver::IncrementalPotential(hyperpbd::IncrementalPotentialSettings {
        barrier_stiffness: 50.0,
        activation_distance: 0.25,
        convergence: hyperpbd::Convergence::PackedGradient { tolerance: 1e-8 },
        max_iterations: 10,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
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
    let e = precision.epsilon();
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
        print_bound(
            format_args!(
                "ln {precision} vs libm, {} values over the precision's range",
                values.len()
            ),
            format_args!("{worst:.3}"),
            "1",
            "fraction of the allowance (f64: 4 ulp of ln x; f32: ε(0.5 + 3|ln x|) + 2^-21)",
        );
    }
}

#[test]
fn barrier_evaluation_matches_the_golden_path() {
    for precision in PRECISIONS {
        let Some((adapter, summary)) =
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
            let reference = reference_inputs(&summary, precision, dim, &law, &geometry);
            let mut bit_identical = 0;
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
                    if let Some(inputs) = &reference {
                        let t = reference::evaluate(inputs, &f32s(xi), r[i] as f32);
                        let at = |what: &str| format!("dim {dim} particle {i} of {count}: {what}");
                        let energy = if t.energy >= f32::MAX {
                            f64::INFINITY
                        } else {
                            f64::from(t.energy)
                        };
                        assert_bits(&at("energy"), gpu.energy[i], energy);
                        for a in 0..dim {
                            let got = gpu.gradient[i * dim + a];
                            assert_bits(&at("gradient"), got, f64::from(t.gradient[a]));
                        }
                        for a in 0..dim * dim {
                            let got = gpu.hessian[i * dim * dim + a];
                            assert_bits(&at("hessian"), got, f64::from(t.hessian[a]));
                        }
                        let d = f64::from(t.min_distance);
                        assert_bits(&at("min distance"), gpu.min_distance[i], d);
                        bit_identical += 1;
                    }
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
            if reference.is_some() {
                report_identical("barrier evaluation", dim, bit_identical);
            }
            if precision == Precision::F64 {
                assert_eq!(floor, 0, "f64 has no floor at these scales");
                print_bound(
                    format_args!("barrier energy/gradient/hessian f64 dim {dim}, ln-only bound"),
                    format_args!("{worst_tight:.3e}"),
                    "1",
                    "distances bit-identical; 16u of every term holding ln (f64 ln within 4 ulp)",
                );
            }
            for (k, name) in ["energy", "gradient", "hessian block", "min distance"]
                .iter()
                .enumerate()
            {
                print_bound(
                    format_args!(
                        "barrier {name} {precision} dim {dim} ({compared} particles, {identical} bit-identical, {floor} under the f32 floor)"
                    ),
                    format_args!("{:.3e}", worst[k]),
                    "1",
                    "largest measured/derived-bound ratio (module docs)",
                );
            }
        }
    }
}

#[test]
fn filter_fractions_match_the_golden_path_and_stay_certified() {
    for precision in PRECISIONS {
        let Some((adapter, summary)) = adapter_or_skip(
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
            let reference = reference_inputs(&summary, precision, dim, &law, &geometry);
            let mut bit_identical = 0;
            let e = precision.epsilon();
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
                    if let Some(inputs) = &reference {
                        let t =
                            reference::filter_fraction(inputs, &f32s(xi), r[i] as f32, &f32s(di));
                        let at = format!("dim {dim} particle {i} of {count}: filter fraction");
                        assert_bits(&at, gpu[i], f64::from(t));
                        bit_identical += 1;
                    }
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
            if reference.is_some() {
                report_identical("filter fraction", dim, bit_identical);
            }
            print_bound(
                format_args!(
                    "filter fraction {precision} dim {dim} ({checked} particles, {cut} cut)"
                ),
                format_args!("{worst:.3e}"),
                "1",
                "largest measured/derived-bound ratio; every GPU fraction keeps d > 0 along the cut step (f64 check)",
            );
        }
    }
}
