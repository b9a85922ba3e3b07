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

use crate::common;

use common::bound::check_bound;
use hyperpbd::core::material::Law;
use hyperpbd::{Backend, CpuBackend, Plan, Scene, State};

fn settle(scene: &Scene, steps: usize) -> State {
    let plan = Plan::compile(scene).expect("valid scene");
    let state = State::from_scene(scene);
    let mut backend = CpuBackend::with_threads(plan, &state, 1).expect("loads");
    for _ in 0..steps {
        backend.step().expect("step");
    }
    backend.read_state().expect("state")
}

#[test]
fn uniaxial_stretch_matches_the_closed_form_within_two_percent() {
    for dim in [2, 3] {
        for law in [Law::StVenantKirchhoff, Law::NeoHookean] {
            let scene = common::materials::uniaxial_bar(law, dim);
            common::materials::check_uniaxial(
                &format!("uniaxial {law} {dim}D"),
                law,
                dim,
                &settle(&scene, 300),
            );
        }
    }
}

/// Largest interior-node distance from the affine map after settling the
/// patch of `cells` (`common::materials::patch`) on the golden path.
fn patch_error(law: Law, cells: &[usize]) -> f64 {
    let (scene, interior) = common::materials::patch(common::materials::kind_of(law), cells);
    common::materials::patch_error(&settle(&scene, 300), &interior)
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

/// The patch leaves out the elements whose every node is fixed
/// (`common::materials::patch`, which says why no bit moves): after
/// `FRAMES_COMPARED` frames the state is the full grid's bit for bit, in
/// 2D, 3D and 4D with both laws, and the full grid has more elements (the
/// comparison is not of a patch with itself).
#[test]
fn the_patch_without_its_fixed_elements_is_the_full_patch_bit_for_bit() {
    use common::exact::bits;
    use common::materials::{PatchElements, kind_of, patch_of};
    const FRAMES_COMPARED: usize = 20;
    for cells in [vec![4, 4], vec![3, 3, 3], vec![3, 3, 3, 3]] {
        for law in [Law::StVenantKirchhoff, Law::NeoHookean] {
            let (full, _) = patch_of(kind_of(law), &cells, PatchElements::All);
            let (moving, _) = patch_of(kind_of(law), &cells, PatchElements::Moving);
            let count = |s: &Scene| s.constraints[0].elements.len();
            assert!(
                count(&moving) < count(&full),
                "{law} {}D: {} of {} elements kept",
                cells.len(),
                count(&moving),
                count(&full)
            );
            assert!(
                bits(&settle(&moving, FRAMES_COMPARED)) == bits(&settle(&full, FRAMES_COMPARED)),
                "{law} {}D: the patch without its fixed elements moved a bit",
                cells.len()
            );
        }
    }
}
