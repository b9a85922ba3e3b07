//! The material families against closed forms, on the CPU golden path.
//!
//! **Uniaxial stretch** (docs/materials.md §8): a free–free slender bar
//! (length 10, width 1: 20 × 2 (× 2) cells of Kuhn simplices) pulled by
//! equal and opposite nominal tractions ±P on its end faces, as dead
//! forces P·A_i on the end-face nodes (A_i the node's lumped share of the
//! rest face: the consistent load of linear simplices), nothing fixed, so
//! the lateral contraction is free. After settling under velocity damping
//! the axial strain s − 1, measured between the cross-sections at x = 2.5
//! and x = 7.5, is within 2 % of the closed form
//! `uniaxial_stretch_under_stress` (and the lateral strain 1 − t at the
//! middle section likewise). The homogeneous uniaxial state is an exact
//! equilibrium of the discrete bar (linear simplices, consistent load),
//! so what remains is XPBD's finite-iteration offset and the settling.
//!
//! **Patch test**: boundary nodes of a Kuhn grid fixed on an affine map
//! x = F X + b, interior nodes perturbed; the affine state is the
//! equilibrium of any homogeneous hyperelastic law, and after settling
//! every interior node is within 1e-4 of the element size of it
//! (2D, 3D, 4D, both laws).
//!
//! Each prints `BOUND | name | measured | bound | rationale`.

mod common;

use common::bound::check_bound;
use hyperpbd::builders::{coords_of, kuhn_grid_elements};
use hyperpbd::core::material::{Law, Material, uniaxial_stretch_under_stress};
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, CpuBackend, Damping, Particle, Plan, Scene, State,
};

fn kind_of(law: Law) -> ConstraintKind {
    match law {
        Law::StVenantKirchhoff => ConstraintKind::Stvk,
        Law::NeoHookean => ConstraintKind::NeoHookean,
    }
}

fn settle(scene: &Scene, steps: usize) -> State {
    let plan = Plan::compile(scene).expect("valid scene");
    let state = State::from_scene(scene);
    let mut backend = CpuBackend::with_threads(plan, &state, 1).expect("loads");
    for _ in 0..steps {
        backend.step().expect("step");
    }
    backend.read_state().expect("state")
}

const YOUNGS: f64 = hyperpbd::scenes::BAR_YOUNGS;
const POISSON: f64 = hyperpbd::scenes::BAR_POISSON;

/// The settled bar of `law` in `dim` dimensions under traction `p`
/// (`hyperpbd::scenes::stretched_bar`, 10 substeps × 4 iterations, 300
/// frames): (axial strain s − 1, lateral strain 1 − t).
fn stretched_bar(law: Law, dim: usize, p: f64) -> (f64, f64) {
    let scene = hyperpbd::scenes::stretched_bar(law, dim, p, 10, 4);
    hyperpbd::scenes::bar_strains(dim, &settle(&scene, 300))
}

#[test]
fn uniaxial_stretch_matches_the_closed_form_within_two_percent() {
    let p = 0.1 * YOUNGS;
    for dim in [2, 3] {
        for law in [Law::StVenantKirchhoff, Law::NeoHookean] {
            let material = Material::new(law, dim, YOUNGS, POISSON).expect("material");
            let exact = uniaxial_stretch_under_stress(&material, dim, p).expect("closed form");
            let (axial, lateral) = stretched_bar(law, dim, p);
            let (axial_exact, lateral_exact) = (exact.stretch - 1.0, 1.0 - exact.lateral_stretch);
            let why = "issue 15: within 2 % of the closed form (strain, relative)";
            check_bound(
                &format!(
                    "uniaxial {law} {dim}D axial strain relative error (strain {axial:.5}, exact {axial_exact:.5})"
                ),
                ((axial - axial_exact) / axial_exact).abs(),
                0.02,
                why,
            );
            check_bound(
                &format!(
                    "uniaxial {law} {dim}D lateral strain relative error (strain {lateral:.5}, exact {lateral_exact:.5})"
                ),
                ((lateral - lateral_exact) / lateral_exact).abs(),
                0.02,
                why,
            );
        }
    }
}

/// Largest interior-node distance from the affine map after settling a
/// patch of `cells` (spacing 1) whose boundary sits on x = F X + b.
fn patch_error(law: Law, cells: &[usize]) -> f64 {
    let dim = cells.len();
    let nodes: Vec<usize> = cells.iter().map(|c| c + 1).collect();
    let count: usize = nodes.iter().product();
    // F = I + a fixed small non-symmetric matrix (det > 0), b a shift.
    let f = |a: usize, b: usize| {
        let delta = if a == b { 1.0 } else { 0.0 };
        delta + 0.08 * (((3 * a + 5 * b) % 7) as f64 / 7.0 - 0.4)
    };
    let affine = |x: &[f64]| -> Vec<f64> {
        (0..dim)
            .map(|a| 0.25 + (0..dim).map(|b| f(a, b) * x[b]).sum::<f64>())
            .collect()
    };
    let mut scene = Scene::new(dim, 0.05, 5, 3);
    scene.damping = Some(Damping { rate: 1.0 });
    let mut rest = Vec::new();
    let mut interior = Vec::new();
    for i in 0..count {
        let c = coords_of(i, &nodes);
        let reference: Vec<f64> = c.iter().map(|&ci| ci as f64).collect();
        let mapped = affine(&reference);
        let boundary = c.iter().zip(cells).any(|(&ci, &n)| ci == 0 || ci == n);
        if boundary {
            scene.particles.push(Particle::fixed(mapped));
        } else {
            // A deterministic perturbation of 0.1 element sizes.
            let perturbed = mapped
                .iter()
                .enumerate()
                .map(|(a, v)| v + 0.1 * ((((i * 7 + a * 3) % 5) as f64) / 4.0 - 0.5))
                .collect();
            scene.particles.push(Particle::new(perturbed, 1.0));
            interior.push((i, mapped));
        }
        rest.push(reference);
    }
    scene.constraints.push(
        ConstraintFamily::material(kind_of(law), 1.0, 0.2, kuhn_grid_elements(cells, 0))
            .with_rest_positions(rest),
    );
    let state = settle(&scene, 300);
    interior
        .iter()
        .map(|(i, mapped)| {
            state
                .position(*i)
                .iter()
                .zip(mapped)
                .map(|(x, y)| (x - y) * (x - y))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max)
}

#[test]
fn patch_test_interior_returns_to_the_affine_map() {
    for cells in [vec![4, 4], vec![3, 3, 3], vec![3, 3, 3, 3]] {
        for law in [Law::StVenantKirchhoff, Law::NeoHookean] {
            let error = patch_error(law, &cells);
            check_bound(
                &format!(
                    "patch test {law} {}D interior error / element size",
                    cells.len()
                ),
                error,
                1e-4,
                "issue 15: interior nodes back on the affine map to 1e-4 of the element size",
            );
        }
    }
}
