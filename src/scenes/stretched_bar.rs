//! The uniaxial-stretch bar of docs/materials.md §8: a free–free slender
//! bar of Kuhn simplices pulled by equal and opposite nominal tractions on
//! its end faces, and the strains it settles to (the closed-form check of
//! `tests/materials/closed_forms.rs` and the accuracy report's stretch
//! case).
//!
//! ```text
//! bar      20 × 2 (× 2) cells of 0.5 m (length 10, width 1), Kuhn simplices
//!          of one `law` family (E = 100 Pa, ν = 0.3, density 1: lumped
//!          masses), no particle fixed (lateral contraction free)
//! load     ±P · A_i along axis 0 on the end-face nodes, A_i the node's
//!          lumped share of the rest face (the consistent load of linear
//!          simplices); damping 6/s so it settles
//! strains  axial  s − 1 = (mean x of section 15 − mean x of section 5) / 5 − 1
//!          lateral 1 − t = 1 − (mean y of the top row − of the bottom row) / 1
//!          at the middle section (x index 10)
//! ```

use hyperpbd_core::builders::{coords_of, kuhn_grid_elements};
use hyperpbd_core::material::Law;
use hyperpbd_core::{ConstraintFamily, ConstraintKind, Damping, Particle, Scene, State};

/// Young's modulus of the bar (Pa).
pub const BAR_YOUNGS: f64 = 100.0;
/// Poisson's ratio of the bar.
pub const BAR_POISSON: f64 = 0.3;
/// Cells along the bar (axis 0) and across it (every other axis).
const CELLS: (usize, usize) = (20, 2);
/// Cell edge (m).
const SPACING: f64 = 0.5;

/// The bar's cells per axis in `dim` dimensions.
fn cells(dim: usize) -> Vec<usize> {
    let mut cells = vec![CELLS.1; dim];
    cells[0] = CELLS.0;
    cells
}

/// The bar of `law` in `dim` (2 or 3) dimensions under nominal traction
/// `traction` (Pa), dt 1/60 s with `substeps` × `iterations`.
pub fn stretched_bar(law: Law, dim: usize, traction: f64, substeps: u32, iterations: u32) -> Scene {
    let cells = cells(dim);
    let nodes: Vec<usize> = cells.iter().map(|c| c + 1).collect();
    let count: usize = nodes.iter().product();
    let mut scene = Scene::new(dim, 1.0 / 60.0, substeps, iterations);
    scene.damping = Some(Damping { rate: 6.0 });
    for i in 0..count {
        let c = coords_of(i, &nodes);
        let position: Vec<f64> = c.iter().map(|&ci| ci as f64 * SPACING).collect();
        let mut particle = Particle::new(position, 1.0);
        particle.mass = None;
        if c[0] == 0 || c[0] == cells[0] {
            // Lumped share of the rest end face: half a cell per boundary axis.
            let area: f64 = c[1..]
                .iter()
                .zip(&cells[1..])
                .map(|(&ci, &n)| {
                    if ci == 0 || ci == n {
                        SPACING / 2.0
                    } else {
                        SPACING
                    }
                })
                .product();
            let sign = if c[0] == 0 { -1.0 } else { 1.0 };
            let mut force = vec![0.0; dim];
            force[0] = sign * traction * area;
            particle = particle.with_force(force);
        }
        scene.particles.push(particle);
    }
    let kind = match law {
        Law::StVenantKirchhoff => ConstraintKind::Stvk,
        Law::NeoHookean => ConstraintKind::NeoHookean,
    };
    scene.constraints.push(
        ConstraintFamily::material(kind, BAR_YOUNGS, BAR_POISSON, kuhn_grid_elements(&cells, 0))
            .with_density(1.0),
    );
    scene
}

/// (axial strain s − 1, lateral strain 1 − t) of the bar of
/// [`stretched_bar`] in `dim` dimensions at `state` (see the module docs).
pub fn bar_strains(dim: usize, state: &State) -> (f64, f64) {
    let cells = cells(dim);
    let nodes: Vec<usize> = cells.iter().map(|c| c + 1).collect();
    let count: usize = nodes.iter().product();
    let mean = |filter: &dyn Fn(&[usize]) -> bool, axis: usize| {
        let members: Vec<usize> = (0..count)
            .filter(|&i| filter(&coords_of(i, &nodes)))
            .collect();
        members
            .iter()
            .map(|&i| state.position(i)[axis])
            .sum::<f64>()
            / members.len() as f64
    };
    let section = |i0: usize| mean(&|c: &[usize]| c[0] == i0, 0);
    let axial = (section(15) - section(5)) / (10.0 * SPACING) - 1.0;
    let side = |c1: usize| mean(&|c: &[usize]| c[0] == 10 && c[1] == c1, 1);
    let width = cells[1] as f64 * SPACING;
    let lateral = 1.0 - (side(cells[1]) - side(0)) / width;
    (axial, lateral)
}
