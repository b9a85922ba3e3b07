//! Material scenes shared by the material tests: the smallest one, and
//! the patch test of tests/materials/closed_forms.rs (run on the GPU by
//! tests/gpu/materials_closed_forms.rs).

use super::bound::check_bound;
use hyperpbd::builders::{coords_of, kuhn_grid_elements};
use hyperpbd::core::material::{Law, Material, uniaxial_stretch_under_stress};
use hyperpbd::{ConstraintFamily, ConstraintKind, Damping, Particle, Scene, State};

/// Two Neo-Hookean triangles of the unit square in 2D (E = 100 Pa,
/// ν = 0.3), no authored masses: density 3 lumps 1, 0.5, 1, 0.5 kg onto
/// the corners. dt 0.01 s, one substep, one iteration, no gravity.
pub fn lumped_square() -> Scene {
    let mut scene = Scene::new(2, 0.01, 1, 1);
    for p in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        let mut particle = Particle::new(p.to_vec(), 1.0);
        particle.mass = None;
        scene.particles.push(particle);
    }
    scene.constraints.push(
        ConstraintFamily::material(
            ConstraintKind::NeoHookean,
            100.0,
            0.3,
            vec![vec![0, 1, 2], vec![0, 2, 3]],
        )
        .with_density(3.0),
    );
    scene
}

/// The patch test of `cells` (spacing 1) of the material `kind` (E = 1,
/// ν = 0.2): boundary nodes fixed on the affine map x = F X + b, interior
/// nodes perturbed by up to 0.05 element sizes per axis; dt 0.05 s, 5
/// substeps × 3 iterations, damping 1/s. Returns the scene and, per interior
/// node, its index and affine position.
///
/// The Kuhn elements whose every node is fixed are left out
/// ([`PatchElements::Moving`]): 2 of 32 in 2D (4 × 4), 42 of 162 in 3D,
/// 792 of 1944 in 4D. Such an element moves nothing (every w = 0 in its
/// projection), conflicts with no element in the coloring (fixed
/// particles never do: core/src/coloring.rs), so every other element keeps
/// its colour and order, and its λ is read by nothing: the states are the
/// full grid's bit for bit, which
/// `materials_closed_forms::the_patch_without_its_fixed_elements_is_the_full_patch_bit_for_bit`
/// checks.
pub fn patch(kind: ConstraintKind, cells: &[usize]) -> (Scene, Vec<(usize, Vec<f64>)>) {
    patch_of(kind, cells, PatchElements::Moving)
}

/// Which Kuhn elements of the grid a patch keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PatchElements {
    /// Every element of the grid.
    All,
    /// The elements with at least one interior (dynamic) node.
    Moving,
}

/// The patch of [`patch`] with the elements `elements` keeps.
pub fn patch_of(
    kind: ConstraintKind,
    cells: &[usize],
    elements: PatchElements,
) -> (Scene, Vec<(usize, Vec<f64>)>) {
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
    let moving = |e: &Vec<usize>| e.iter().any(|&p| !scene.particles[p].fixed);
    let kept: Vec<Vec<usize>> = kuhn_grid_elements(cells, 0)
        .into_iter()
        .filter(|e| match elements {
            PatchElements::All => true,
            PatchElements::Moving => moving(e),
        })
        .collect();
    scene
        .constraints
        .push(ConstraintFamily::material(kind, 1.0, 0.2, kept).with_rest_positions(rest));
    (scene, interior)
}

/// Largest distance of an interior node of [`patch`] from its affine
/// position at `state` (in element sizes: the spacing is 1).
pub fn patch_error(state: &State, interior: &[(usize, Vec<f64>)]) -> f64 {
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

/// The constraint kind of `law`.
pub fn kind_of(law: Law) -> ConstraintKind {
    match law {
        Law::StVenantKirchhoff => ConstraintKind::Stvk,
        Law::NeoHookean => ConstraintKind::NeoHookean,
    }
}

/// The bar of the uniaxial test: `hyperpbd::scenes::stretched_bar` of
/// `law` in `dim` dimensions under P = 0.1 E, 10 substeps × 4 iterations
/// (settled over 300 frames).
pub fn uniaxial_bar(law: Law, dim: usize) -> Scene {
    hyperpbd::scenes::stretched_bar(law, dim, 0.1 * hyperpbd::scenes::BAR_YOUNGS, 10, 4)
}

/// Checks the settled [`uniaxial_bar`] `state`: axial strain s − 1 and
/// lateral strain 1 − t within 2 % of `uniaxial_stretch_under_stress`
/// (docs/materials.md §8), printing both `BOUND` lines as `name …`.
pub fn check_uniaxial(name: &str, law: Law, dim: usize, state: &State) {
    let (youngs, poisson) = (hyperpbd::scenes::BAR_YOUNGS, hyperpbd::scenes::BAR_POISSON);
    let material = Material::new(law, dim, youngs, poisson).expect("material");
    let exact = uniaxial_stretch_under_stress(&material, dim, 0.1 * youngs).expect("closed form");
    let (axial, lateral) = hyperpbd::scenes::bar_strains(dim, state);
    let (axial_exact, lateral_exact) = (exact.stretch - 1.0, 1.0 - exact.lateral_stretch);
    let why = "issue 15: within 2 % of the closed form (strain, relative)";
    check_bound(
        &format!("{name} axial strain relative error (strain {axial:.5}, exact {axial_exact:.5})"),
        ((axial - axial_exact) / axial_exact).abs(),
        0.02,
        why,
    );
    check_bound(
        &format!(
            "{name} lateral strain relative error (strain {lateral:.5}, exact {lateral_exact:.5})"
        ),
        ((lateral - lateral_exact) / lateral_exact).abs(),
        0.02,
        why,
    );
}
