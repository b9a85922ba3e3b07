//! Quadratic bending (`"model": "quadratic"`, Bergou et al. 2006,
//! `core/src/kinds/bending.rs`): the weights vanish on every flat placement
//! of the hinge, rigid motions carry no force, C = |v| is the closed form
//! 2 s |e| sin(φ/2) and ½k|v|² has the constant Hessian k·k_j k_l δ_ab, the
//! fold stays finite near flat and near shut, a hinge bent to 90° unfolds
//! without flipping, the per-element weights follow their elements into
//! colour order, and bad input is refused by name.

use crate::common;

use common::Lcg;
use common::hinges::{assert_no_rigid_force, opened, random_hinge};
use hyperpbd::builders::GridSpec;
use hyperpbd::core::expr::{Columns, Tape};
use hyperpbd::kinds::{BendingModel, ExpressionKind, quadratic_weights};
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, CpuBackend, FamilyKind, Particle, Plan, Scene,
    SceneBuilder, State,
};

const U: f64 = f64::EPSILON / 2.0;

/// One quadratic bending element over `points` (4 particles, all dynamic).
fn hinge(points: &[Vec<f64>]) -> Scene {
    let dim = points[0].len();
    let mut scene = Scene::new(dim, 1.0 / 60.0, 10, 4);
    scene.particles = (points.iter())
        .map(|p| Particle::new(p.clone(), 1.0))
        .collect();
    scene.constraints.push(
        ConstraintFamily::new(ConstraintKind::Bending, 0.0, vec![vec![0, 1, 2, 3]])
            .with_model(BendingModel::Quadratic),
    );
    scene
}

fn kind_of(plan: &Plan) -> &ExpressionKind {
    match &plan.families[0].kind {
        FamilyKind::Expression(kind) => kind,
        other => panic!("bending compiles to an expression, not {other:?}"),
    }
}

/// The outputs of `tape` (one of `kind`'s) for element 0 at `points`.
fn outputs(kind: &ExpressionKind, tape: &Tape, points: &[f64]) -> Vec<f64> {
    let dim = points.len() / 4;
    let mut columns = Columns::new();
    let read = |k: usize| points[k];
    kind.eval_slots(
        tape,
        dim,
        &[0, 1, 2, 3],
        &kind.constants,
        0..1,
        read,
        &mut columns,
    );
    tape.outputs().map(|s| columns.get(s, 0)).collect()
}

/// A random flat hinge in a random 2-plane of R^dim: x2 and x3 on
/// opposite sides of the edge.
fn flat_hinge(rng: &mut Lcg, dim: usize) -> Vec<Vec<f64>> {
    let mut u: Vec<f64> = (0..dim).map(|_| rng.next()).collect();
    let mut w: Vec<f64> = (0..dim).map(|_| rng.next()).collect();
    let norm = |v: &[f64]| v.iter().map(|c| c * c).sum::<f64>().sqrt();
    let n = norm(&u);
    u.iter_mut().for_each(|c| *c /= n);
    let d: f64 = u.iter().zip(&w).map(|(a, b)| a * b).sum();
    w.iter_mut().zip(&u).for_each(|(c, a)| *c -= d * a);
    let n = norm(&w);
    w.iter_mut().for_each(|c| *c /= n);
    let origin: Vec<f64> = (0..dim).map(|_| rng.next()).collect();
    let (p0, p1) = ([rng.next(), rng.next()], [rng.next() + 2.0, rng.next()]);
    let (ex, ey) = (p1[0] - p0[0], p1[1] - p0[1]);
    let side = |s: f64, t: f64| [p0[0] + t * ex - s * ey, p0[1] + t * ey + s * ex];
    let p2 = side(0.2 + rng.next().abs(), 0.5 * rng.next() + 0.5);
    let p3 = side(-0.2 - rng.next().abs(), 0.5 * rng.next() + 0.5);
    [p0, p1, p2, p3]
        .iter()
        .map(|p| {
            (0..dim)
                .map(|a| origin[a] + p[0] * u[a] + p[1] * w[a])
                .collect()
        })
        .collect()
}

#[test]
fn the_weights_vanish_on_every_flat_hinge_in_any_dimension() {
    let mut rng = Lcg(0x9a3d_f1a7);
    let mut checked = 0;
    for dim in 3..=6 {
        for _ in 0..200 {
            let points = flat_hinge(&mut rng, dim);
            let flat = points.concat();
            let k = quadratic_weights(&flat, dim).expect("a proper hinge");
            // v = Σ_j k_j (x_j − x0) at the authored (flat) positions.
            let mut scale = 0.0;
            let mut v2 = 0.0;
            for a in 0..dim {
                let mut v = 0.0;
                for j in 1..4 {
                    let d = flat[j * dim + a] - flat[a];
                    v += k[j - 1] * d;
                    scale += (k[j - 1] * d).abs();
                }
                v2 += v * v;
            }
            assert!(
                v2.sqrt() <= 64.0 * U * scale,
                "dim {dim}: |v| = {:e}",
                v2.sqrt()
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 800);
}

#[test]
fn rigid_motions_carry_no_force() {
    let mut rng = Lcg(0x0b3e_c0de);
    let mut checked = 0;
    for dim in 3..=5 {
        for _ in 0..200 {
            let points = random_hinge(&mut rng, dim);
            let plan = Plan::compile(&hinge(&points)).expect("compiles");
            let kind = kind_of(&plan);
            let x = points.concat();
            let out = outputs(kind, &kind.gradient, &x);
            let g = &out[1..];
            assert!(out[0] > 0.0 && g.iter().all(|v| v.is_finite()));
            assert_no_rigid_force(dim, &x, g);
            checked += 1;
        }
    }
    assert_eq!(checked, 600);
}

// `opened(θ)`: |e| = h_A = h_B = 1, so s = √(6/(|e|(h_A + h_B))) = √3.

#[test]
fn the_fold_is_the_closed_form_and_finite_near_flat_and_near_shut() {
    let plan = Plan::compile(&hinge(&opened(2.0))).expect("compiles");
    let kind = kind_of(&plan);
    let s = 3f64.sqrt();
    // k1 = s (cot_A0 + cot_B0) = s (0.4 + 0.6), k2 = −s |e|/h_A, k3 = −s |e|/h_B.
    let expected = [s, -s, -s];
    for (k, e) in kind.constants(0).iter().zip(expected) {
        assert!(
            (k - e).abs() <= 4.0 * U * s,
            "weights {:?}",
            kind.constants(0)
        );
    }
    assert_eq!(plan.families[0].rest, vec![0.0], "the rest is flat");
    let mut thetas: Vec<f64> = (1..32)
        .map(|i| std::f64::consts::PI * i as f64 / 32.0)
        .collect();
    for eps in [1e-2, 1e-4, 1e-8, 1e-12, 0.0] {
        thetas.extend([std::f64::consts::PI - eps, eps]);
    }
    for theta in thetas {
        let out = outputs(kind, &kind.gradient, &opened(theta).concat());
        let phi = std::f64::consts::PI - theta;
        // C = |v| = 2 s |e| sin(φ/2): energy ½k|v|² = 12 k |e| sin²(φ/2)/(h_A + h_B).
        let closed = 2.0 * s * (phi / 2.0).sin();
        assert!(
            out[0].is_finite() && out[0] >= 0.0,
            "θ = {theta}: C = {}",
            out[0]
        );
        assert!(
            (out[0] - closed).abs() <= 1e-14,
            "θ = {theta}: C = {} ≠ {closed}",
            out[0]
        );
        let energy = 0.5 * out[0] * out[0];
        let closed_energy = 12.0 * (phi / 2.0).sin().powi(2) / 2.0;
        assert!(
            (energy - closed_energy).abs() <= 1e-13,
            "θ = {theta}: ½|v|² = {energy}"
        );
        // ∇C = v̂ k_j: finite wherever v ≠ 0 (at v = 0 it is undefined and
        // the projection makes no response: the step test below).
        if out[0] > 0.0 {
            assert!(out[1..].iter().all(|g| g.is_finite()), "θ = {theta}: ∇C");
        }
    }
}

#[test]
fn half_v_squared_has_the_constant_hessian_k_j_k_l() {
    let mut rng = Lcg(0x4e55_1a17);
    let points: Vec<Vec<f64>> = (0..4)
        .map(|_| (0..4).map(|_| rng.next()).collect())
        .collect();
    let plan = Plan::compile(&hinge(&points)).expect("compiles");
    let kind = kind_of(&plan);
    let tape = kind.hessian_tape().expect("the Hessian tape fits");
    let k = kind.constants(0);
    let weights = [-(k[0] + k[1] + k[2]), k[0], k[1], k[2]];
    let dim = 4;
    let n = 4 * dim;
    for trial in 0..20 {
        let x: Vec<f64> = (0..n).map(|_| 2.0 * rng.next()).collect();
        let out = outputs(kind, tape, &x);
        let (c, g) = (out[0], &out[1..1 + n]);
        let h = &out[1 + n..];
        let mut worst: f64 = 0.0;
        for p in 0..n {
            for q in p..n {
                // ∇²(C²/2) = ∇C ∇Cᵀ + C ∇²C against k_j k_l δ_ab.
                let energy = g[p] * g[q] + c * h[tape.hessian_index(p, q)];
                let (j, a, l, b) = (p / dim, p % dim, q / dim, q % dim);
                let exact = if a == b { weights[j] * weights[l] } else { 0.0 };
                worst = worst.max((energy - exact).abs());
            }
        }
        let scale = weights.iter().map(|w| w * w).fold(0.0, f64::max);
        assert!(
            worst <= 1e-13 * scale,
            "trial {trial}: {worst:e} off k_j k_l"
        );
    }
}

#[test]
fn a_flat_hinge_makes_no_response_and_a_bent_one_unfolds_without_flipping() {
    // Flat (v = 0 to rounding), no gravity: nothing moves beyond rounding.
    let flat = hinge(&opened(std::f64::consts::PI));
    let mut cpu = hyperpbd::cpu_backend(&flat).expect("loads");
    for frame in 0..10 {
        cpu.step()
            .unwrap_or_else(|e| panic!("flat frame {frame}: {e}"));
    }
    let moved = (cpu.read_state().expect("s").positions.iter())
        .zip(flat.particles.iter().flat_map(|p| p.position.clone()))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(moved <= 1e-14, "a flat hinge moved {moved:e}");
    // Exactly flat (v = 0 to the bit: ∇C = v/|v| undefined): no response on
    // the standard update and on the primal-residual one, golden and f32.
    let symmetric = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.5, -0.5, 0.0],
    ];
    let mut exact = hinge(&symmetric.map(|p| p.to_vec()));
    let plan = Plan::compile(&exact).expect("compiles");
    let out = outputs(
        kind_of(&plan),
        &kind_of(&plan).gradient,
        &symmetric.concat(),
    );
    assert!(
        out[0] == 0.0 && out[1..].iter().all(|g| g.is_nan()),
        "{out:?}"
    );
    for primal in [false, true] {
        exact.solver = hyperpbd::Solver::Xpbd(hyperpbd::XpbdSettings {
            primal_residual: primal,
        });
        let plan = Plan::compile(&exact).expect("compiles");
        let state = State::from_scene(&exact);
        let mut cpu = CpuBackend::new(plan.clone(), &state).expect("loads");
        let mut f32 = hyperpbd::F32Reference::new(plan, &state, &[0.0; 3]).expect("loads");
        for frame in 0..5 {
            cpu.step()
                .unwrap_or_else(|e| panic!("primal {primal} frame {frame}: {e}"));
            f32.step()
                .unwrap_or_else(|e| panic!("f32 primal {primal} frame {frame}: {e}"));
        }
        let bits = |s: &State| s.positions.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&cpu.read_state().expect("s")),
            bits(&state),
            "primal {primal}"
        );
    }
    // Bent to 90°: x0, x1, x2 fixed, x3 moves; rest flat.
    let mut scene = hinge(&opened(std::f64::consts::FRAC_PI_2));
    for i in 0..3 {
        scene.particles[i] = Particle::fixed(scene.particles[i].position.clone());
    }
    scene.damping = Some(hyperpbd::Damping { rate: 2.0 });
    let plan = Plan::compile(&scene).expect("compiles");
    let mut cpu = CpuBackend::new(plan.clone(), &State::from_scene(&scene)).expect("loads");
    let kind = kind_of(&plan).clone();
    let mut last = f64::INFINITY;
    for frame in 0..60 {
        cpu.step().unwrap_or_else(|e| panic!("frame {frame}: {e}"));
        let x = cpu.read_state().expect("s").positions;
        let c = outputs(&kind, &kind.value, &x)[0];
        assert!(c.is_finite(), "frame {frame}: C = {c}");
        // The wing never passes through flat to the other side (z < 0).
        assert!(x[11] >= -1e-12, "frame {frame}: z = {}", x[11]);
        last = c;
    }
    assert!(last <= 1e-12, "after 1 s |v| = {last:e}");
}

#[test]
fn the_weights_follow_their_elements_into_colour_order() {
    let mut b = SceneBuilder::new(3).dt(1.0 / 60.0).substeps(4);
    let grid = b.grid(&GridSpec::cloth(6, 5, 0.1, 1.0));
    let f = b
        .grid_bending(&grid, 1e-3, BendingModel::Quadratic)
        .expect("hinges");
    let mut scene = b.build().expect("valid");
    // A sheared, stretched sheet: no two hinges share their weights.
    for p in &mut scene.particles {
        let [x, y, z] = p.position[..] else {
            panic!("R^3")
        };
        p.position = vec![x * (1.0 + 0.3 * z), y, z + 0.2 * x * x];
    }
    let plan = Plan::compile(&scene).expect("compiles");
    let family = &plan.families[f];
    assert!(family.color_count() > 1);
    let FamilyKind::Expression(kind) = &family.kind else {
        panic!("an expression")
    };
    assert_eq!(kind.constants.len(), 3 * family.len());
    let mut moved = 0;
    for slot in 0..family.len() {
        let authored = family.authored_element(slot);
        moved += usize::from(authored != slot);
        let points: Vec<f64> = (scene.constraints[f].elements[authored].iter())
            .flat_map(|&i| scene.particles[i].position.clone())
            .collect();
        let expected = quadratic_weights(&points, 3).expect("proper");
        let bits = |k: &[f64]| k.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(kind.constants(slot)), bits(&expected), "slot {slot}");
        assert_eq!(family.rest[slot], 0.0);
    }
    assert!(moved > 0, "colouring reordered some hinges");
}

#[test]
fn bad_quadratic_input_is_refused_by_name() {
    let error = |scene: &Scene| scene.validate().expect_err("refused").to_string();
    // x2 on the edge's line: triangle A has no area.
    let mut degenerate = hinge(&opened(1.0));
    degenerate.particles[2].position = vec![0.5, 0.0, 0.0];
    let message = error(&degenerate);
    assert!(
        message.starts_with("constraints[0].elements[0]:") && message.contains("nonzero size"),
        "{message}"
    );
    let mut negative = hinge(&opened(1.0));
    negative.constraints[0].rest = Some(vec![-0.5]);
    let message = error(&negative);
    assert!(
        message.starts_with("constraints[0].rest[0]:") && message.contains(">= 0"),
        "{message}"
    );
    let mut distance = hinge(&opened(1.0));
    distance.constraints[0].kind = ConstraintKind::Distance;
    distance.constraints[0].elements = vec![vec![0, 1]];
    let message = error(&distance);
    assert!(
        message.starts_with("constraints[0].model: not used by distance families"),
        "{message}"
    );
    let json = r#"{"dim": 3, "dt": 0.1, "particles": [{"position": [0, 0, 0], "mass": 1}],
        "constraints": [{"type": "bending", "model": "linear", "elements": []}]}"#;
    let message = Scene::from_json_str(json).expect_err("refused").to_string();
    assert!(
        message.starts_with("constraints[0].model: unknown variant `linear`"),
        "{message}"
    );
    // Written and read back, the model stays.
    let scene = hinge(&opened(1.0));
    let text = scene.to_json_string();
    assert!(text.contains(r#""model":"quadratic""#), "{text}");
    assert_eq!(Scene::from_json_str(&text).expect("reads"), scene);
}
