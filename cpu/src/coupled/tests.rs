//! Finite-difference checks of the coupled objective with material terms
//! (docs/implicit.md §2, §7): the step's own ∇F against central
//! differences of its own F (the line search's difference form), and its
//! Hessian–vector product (M + h² Σ K⁺) p against central differences of
//! ∇F where no block is clipped; an inverting trial's change is +∞.

use super::elements::{Elements, Terms};
use super::particles::{Context, Particles};
use super::{change, setup};
use crate::parallel::Workers;
use hyperpbd_core::implicit::{MaterialHessianScratch, PsdScratch, material_term, project_psd};
use hyperpbd_core::material::{MaterialElement, MaterialScratch};
use hyperpbd_core::{
    ConstraintFamily, ConstraintKind, Convergence, IncrementalPotentialSettings, Particle, Plan,
    Scene, Solver, SolverPlan,
};

fn solver() -> Solver {
    Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: 1e3,
        activation_distance: 1e-3,
        convergence: Convergence::PackedGradient { tolerance: 1e-12 },
        max_iterations: 10,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    })
}

/// 2D: a Neo-Hookean square (two triangles, corner 0 fixed), a StVK
/// segment family (k = 1, a smaller block than the triangles') and a
/// distance spring, under gravity.
fn planar() -> Scene {
    let mut scene = Scene::new(2, 0.01, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81]);
    scene.particles.push(Particle::fixed(vec![0.0, 0.0]));
    for (p, m) in [([1.0, 0.0], 1.0), ([1.0, 1.0], 0.5), ([0.0, 1.0], 2.0)] {
        let mut particle = Particle::new(p.to_vec(), m);
        particle.velocity = Some(vec![0.3 * m, -0.2]);
        scene.particles.push(particle);
    }
    scene.constraints.push(ConstraintFamily::material(
        ConstraintKind::NeoHookean,
        100.0,
        0.3,
        vec![vec![0, 1, 2], vec![0, 2, 3]],
    ));
    scene.constraints.push(ConstraintFamily::material(
        ConstraintKind::Stvk,
        50.0,
        0.2,
        vec![vec![1, 2], vec![2, 3]],
    ));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-2,
        vec![vec![1, 3]],
    ));
    scene.solver = solver();
    scene
}

/// 3D: one StVK and one Neo-Hookean tetrahedron sharing a face.
fn solid() -> Scene {
    let mut scene = Scene::new(3, 0.01, 1, 1);
    scene.gravity = Some(vec![0.0, 0.0, -9.81]);
    let corners = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
    ];
    for (i, c) in corners.iter().enumerate() {
        let mut particle = Particle::new(c.to_vec(), 1.0 + 0.25 * i as f64);
        particle.velocity = Some(vec![0.1, -0.2 * i as f64, 0.05]);
        scene.particles.push(particle);
    }
    let law = |kind, elements| ConstraintFamily::material(kind, 80.0, 0.25, elements);
    scene
        .constraints
        .push(law(ConstraintKind::Stvk, vec![vec![0, 1, 2, 3]]));
    scene
        .constraints
        .push(law(ConstraintKind::NeoHookean, vec![vec![1, 4, 2, 3]]));
    scene.solver = solver();
    scene
}

/// The step's F, ∇F and H⁺p at one point, through its own passes.
struct Objective {
    plan: Plan,
    workers: Workers,
    particles: Particles,
    elements: Elements,
    start: Vec<f64>,
}

impl Objective {
    fn new(scene: &Scene) -> Objective {
        let plan = Plan::compile(scene).expect("valid scene");
        let state = hyperpbd_core::State::from_scene(scene);
        let mut particles = Particles::default();
        let force = vec![0.0; state.positions.len()];
        setup::start(
            &plan,
            &state.positions,
            &state.velocities,
            &force,
            &mut particles,
        );
        let SolverPlan::IncrementalPotential(ip) = &plan.solver else {
            unreachable!("implicit scene")
        };
        let coupled = ip.coupled.as_ref().expect("coupled");
        let workers = Workers::serial();
        let mut lags = setup::Setup::default();
        lags.lags(&workers, &plan, ip, coupled, &mut particles)
            .expect("feasible start");
        let mut elements = Elements::default();
        elements.rebuild(&plan, &[], &[]);
        let start = state.positions.clone();
        Objective {
            plan,
            workers,
            particles,
            elements,
            start,
        }
    }

    /// (∇F(x), F(y) − F(x) for each y of `trials`, H⁺ p for each p of `directions`).
    fn at(&mut self, x: &[f64], trials: &[Vec<f64>], directions: &[Vec<f64>]) -> Evaluation {
        let SolverPlan::IncrementalPotential(ip) = &self.plan.solver else {
            unreachable!("implicit scene")
        };
        let terms = Terms {
            plan: &self.plan,
            law: &ip.law,
            start: &self.start,
            lags: &[],
            slip_length: 1e-3,
        };
        let context = Context {
            plan: &self.plan,
            ip,
            slip_length: 1e-3,
        };
        let w = &self.workers;
        let mut gradient = vec![0.0; x.len()];
        self.elements.evaluate(w, &terms, x).expect("finite at x");
        let (particles, elements) = (&mut self.particles, &mut self.elements);
        particles
            .gradient(w, &context, elements, x, &mut gradient)
            .expect("finite gradient");
        let (mut changes, mut scratch) = (Vec::new(), Vec::new());
        let changes = trials
            .iter()
            .map(|y| {
                change(
                    w,
                    &context,
                    &terms,
                    particles,
                    elements,
                    x,
                    y,
                    &mut changes,
                    &mut scratch,
                )
            })
            .collect();
        elements.curvatures(w, &terms, x).expect("curvature at x");
        let products = directions
            .iter()
            .map(|p| {
                let mut out = vec![0.0; x.len()];
                elements.fill_slots(w, &terms, p, false);
                particles.product(w, &context, elements, p, &mut out);
                out
            })
            .collect();
        Evaluation {
            gradient,
            changes,
            products,
        }
    }
}

struct Evaluation {
    gradient: Vec<f64>,
    changes: Vec<f64>,
    products: Vec<Vec<f64>>,
}

/// Clipped eigenvalues of every material element's H_F at `x`.
fn clipped(plan: &Plan, x: &[f64]) -> usize {
    let dim = plan.dim;
    let mut count = 0;
    for family in &plan.families {
        for e in 0..family.len() {
            let Some((material, rest)) = family.kind.rest_view(e) else {
                continue;
            };
            let members = &family.elements[e * family.arity..(e + 1) * family.arity];
            let points: Vec<f64> = members
                .iter()
                .flat_map(|&i| x[i as usize * dim..(i as usize + 1) * dim].to_vec())
                .collect();
            let size = dim * (family.arity - 1);
            let mut h = vec![0.0; size * size];
            let mut grad = vec![0.0; points.len()];
            let (mut s, mut hs) = (MaterialScratch::new(), MaterialHessianScratch::new());
            let m = MaterialElement {
                material,
                points: &points,
                dim,
                rest,
            };
            material_term(m, &mut grad, &mut h, &mut s, &mut hs).expect("admissible");
            count += project_psd(&mut h, size, &mut PsdScratch::new()).clipped;
        }
    }
    count
}

/// A deterministic point near the start: a stretch plus a small shear
/// (no element compressed, so no block is clipped), the fixed particle
/// left in place.
fn stretched(scene: &Scene, plan: &Plan) -> Vec<f64> {
    let dim = scene.dim;
    let mut x = Vec::new();
    for (i, p) in scene.particles.iter().enumerate() {
        for a in 0..dim {
            let free = plan.inverse_mass[i] > 0.0;
            let shear = if a == 0 {
                0.03 * p.position[dim - 1]
            } else {
                0.0
            };
            x.push(if free {
                (1.0 + 0.08 * (a + 1) as f64) * p.position[a] + shear + 0.01
            } else {
                p.position[a]
            });
        }
    }
    x
}

fn unit(len: usize, k: usize) -> Vec<f64> {
    let mut u = vec![0.0; len];
    u[k] = 1.0;
    u
}

fn check_gradient_and_product(scene: &Scene) {
    let mut objective = Objective::new(scene);
    let x = stretched(scene, &objective.plan);
    assert_eq!(clipped(&objective.plan, &x), 0, "a point where H⁺ = H");
    let n = x.len();
    let eps = 1e-6;
    let moved = |k: usize, s: f64| -> Vec<f64> {
        let mut y = x.clone();
        y[k] += s;
        y
    };
    let trials: Vec<Vec<f64>> = (0..n)
        .flat_map(|k| [moved(k, eps), moved(k, -eps)])
        .collect();
    let directions: Vec<Vec<f64>> = (0..n).map(|k| unit(n, k)).collect();
    let at_x = objective.at(&x, &trials, &directions);
    let scale = at_x.gradient.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let inverse_mass = objective.plan.inverse_mass.clone();
    let free = |k: usize| inverse_mass[k / scene.dim] > 0.0;
    // A fixed particle holds no coordinate: its gradient entries are 0.
    for k in (0..n).filter(|&k| free(k)) {
        let fd = (at_x.changes[2 * k] - at_x.changes[2 * k + 1]) / (2.0 * eps);
        let error = (fd - at_x.gradient[k]).abs();
        assert!(
            error <= 1e-7 * scale,
            "∂F/∂x[{k}]: step {} against central difference {fd} (|g|∞ {scale})",
            at_x.gradient[k]
        );
    }
    // Columns of H⁺ against central differences of ∇F, for the free
    // coordinates (CG's directions are 0 on fixed ones); fixed rows are 0.
    let mut largest: f64 = 0.0;
    let mut worst: f64 = 0.0;
    for k in (0..n).filter(|&k| free(k)) {
        let plus = objective.at(&moved(k, eps), &[], &[]).gradient;
        let minus = objective.at(&moved(k, -eps), &[], &[]).gradient;
        for r in 0..n {
            let fd = (plus[r] - minus[r]) / (2.0 * eps);
            let expected = if free(r) { fd } else { 0.0 };
            largest = largest.max(expected.abs());
            worst = worst.max((at_x.products[k][r] - expected).abs());
        }
    }
    println!(
        "{}D: H⁺p against central differences of ∇F: {worst:e} of {largest:e}",
        scene.dim
    );
    assert!(
        worst <= 1e-6 * largest,
        "H⁺p against central differences of ∇F: {worst:e} (largest entry {largest:e})"
    );
}

#[test]
fn planar_materials_gradient_and_product_match_central_differences() {
    check_gradient_and_product(&planar());
}

#[test]
fn solid_materials_gradient_and_product_match_central_differences() {
    check_gradient_and_product(&solid());
}

#[test]
fn an_inverting_trial_changes_f_by_plus_infinity() {
    let scene = planar();
    let mut objective = Objective::new(&scene);
    let x = objective.start.clone();
    // Particle 2 through the edge 0–1 of triangle (0, 1, 2): J < 0.
    let mut inverted = x.clone();
    inverted[5] = -0.5;
    let at_x = objective.at(&x, &[inverted], &[]);
    assert_eq!(at_x.changes[0], f64::INFINITY);
}
