//! Material families (StVK, Neo-Hookean) on the GPU coupled step against
//! the golden path: hanging blocks, tetrahedra dropped onto a plane with
//! their frame Hessians clipped, the rounding floor, a crushed triangle, an
//! inverted start, R^4 and R^5 simplices, an embedded sheet; and PCG
//! stopped by its budget.

use super::*;

/// The hanging block of tests/implicit/materials.rs (0.4 × 0.2 m of Kuhn
/// triangles, E = 1e4 Pa, ν = 0.3, 1000 kg/m², its top row fixed) under
/// `law`, released at rest: it sags 11 % of its height.
pub(crate) fn hanging_block(law: ConstraintKind) -> Scene {
    use hyperpbd::builders::{coords_of, kuhn_grid_elements};
    let cells = [4, 2];
    let nodes = [cells[0] + 1, cells[1] + 1];
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -common::implicit_scenes::G]);
    for i in 0..nodes[0] * nodes[1] {
        let c = coords_of(i, &nodes);
        let position = vec![0.1 * c[0] as f64, 0.1 * c[1] as f64];
        if c[1] == cells[1] {
            scene.particles.push(hyperpbd::Particle::fixed(position));
        } else {
            let mut p = hyperpbd::Particle::new(position, 1.0);
            p.mass = None;
            scene.particles.push(p);
        }
    }
    scene.constraints.push(
        ConstraintFamily::material(law, 1e4, 0.3, kuhn_grid_elements(&cells, 0))
            .with_density(1000.0),
    );
    scene.solver = Solver::IncrementalPotential(settings(1e3, 1e-3, 1e-6, 50));
    scene
}

/// Material elements whose exact frame Hessian H_F has an eigenvalue
/// below −1e-6 of its largest entry at `state` (core's `material_term` and
/// `project_psd`, as the golden step computes them at its iterates): the
/// projection clips it, beyond the rounding of the zero (rotation) modes.
fn clipped_elements(plan: &Plan, state: &State) -> usize {
    use hyperpbd::implicit::{MaterialHessianScratch, PsdScratch, material_term, project_psd};
    use hyperpbd::material::MaterialScratch;
    let dim = plan.dim;
    let (mut law, mut hessian, mut psd) = (
        MaterialScratch::new(),
        MaterialHessianScratch::new(),
        PsdScratch::new(),
    );
    let mut clipped = 0;
    for family in &plan.families {
        let size = dim * (family.arity - 1);
        for slot in 0..family.len() {
            let members = &family.elements[slot * family.arity..(slot + 1) * family.arity];
            let points: Vec<f64> = members
                .iter()
                .flat_map(|&i| state.position(i as usize).to_vec())
                .collect();
            let Some(m) = family.kind.material_element(slot, &points, dim) else {
                continue;
            };
            let mut gradient = vec![0.0; points.len()];
            let mut block = vec![0.0; size * size];
            if material_term(m, &mut gradient, &mut block, &mut law, &mut hessian).is_err() {
                continue;
            }
            let largest = block.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            let projection = project_psd(&mut block, size, &mut psd);
            // Negative beyond the rounding of the zero (rotation) modes.
            if projection.clipped > 0 && projection.smallest < -1e-6 * largest {
                clipped += 1;
            }
        }
    }
    clipped
}

/// The hanging block under both laws (tests/implicit/materials.rs):
/// material elements' energy, gradient, frame Hessian products and
/// diagonal on the GPU, frame for frame the golden path's bits.
#[test]
fn hanging_stvk_and_neo_hookean_blocks_are_the_golden_path() {
    for (name, law) in [
        ("hanging StVK block", ConstraintKind::Stvk),
        ("hanging Neo-Hookean block", ConstraintKind::NeoHookean),
    ] {
        let scene = hanging_block(law);
        let sag = |s: &State| {
            let lowest = (0..5)
                .map(|i| s.position(i)[1])
                .fold(f64::INFINITY, f64::min);
            (-(lowest + 0.1), 0.0)
        };
        differential(name, &scene, 30, sag);
    }
}

/// A 3D block of tetrahedra (tests/common/guarded.rs: 3 × 3 × 3 Kuhn
/// cells of 0.1 m, E = 2e5 Pa, ν = 0.3, 0.1 kg nodes) thrown at 4 m/s onto
/// a plane from 0.2 m, StVK and Neo-Hookean: elements compressed against
/// the plane get frame Hessians with negative eigenvalues (StVK softens
/// under compression), so the GPU's Jacobi eigensolver and PSD projection
/// really clip — counted at the golden states with core's functions and
/// asserted for both laws.
#[test]
fn tetrahedral_blocks_dropped_onto_a_plane_are_the_golden_path() {
    for (name, law) in [
        ("StVK tetrahedra onto a plane", ConstraintKind::Stvk),
        (
            "Neo-Hookean tetrahedra onto a plane",
            ConstraintKind::NeoHookean,
        ),
    ] {
        let mut scene = common::guarded::material_block(3, 4.0, law, None, None);
        scene.solver = Solver::IncrementalPotential(settings(1e4, 1e-3, 1e-2, 50));
        let plan = Plan::compile(&scene).expect("compiles");
        let mut clipped = 0;
        let above = |s: &State| {
            let lowest = (0..s.positions.len() / 3)
                .map(|i| s.position(i)[1])
                .fold(f64::INFINITY, f64::min);
            (-lowest, 0.0)
        };
        differential_with(name, &scene, 12, above, |s, _| {
            clipped += clipped_elements(&plan, s);
        });
        println!("{name}: {clipped} clipped element states over 12 frames");
        assert!(clipped > 0, "{name}: no frame Hessian was clipped");
    }
}

/// The hanging blocks asked for an acceleration residual of 1e-14 m/s²,
/// below what their energies resolve: their line searches fail and the
/// minimisations end at the rounding floor, whose resolution adds each
/// material element's δW (core's `material_energy_rounding`, on the host
/// over x_k read back); the statuses and states are the golden path's.
/// (Here −½ g·Δ is below the floor without δW too: a GPU that dropped δW
/// would pass; the host calls the CPU's own function on the same x_k.)
#[test]
fn material_blocks_at_the_rounding_floor_are_the_golden_path() {
    for (name, law) in [
        ("StVK block at the rounding floor", ConstraintKind::Stvk),
        (
            "Neo-Hookean block at the rounding floor",
            ConstraintKind::NeoHookean,
        ),
    ] {
        let mut scene = hanging_block(law);
        scene.solver = Solver::IncrementalPotential(settings(1e3, 1e-3, 1e-14, 50));
        let mut floors = 0;
        differential_with(
            name,
            &scene,
            10,
            |_| (0.0, 1.0),
            |_, reports| {
                floors += reports
                    .iter()
                    .filter(|m| m.status == hyperpbd::MinimisationStatus::RoundingFloor)
                    .count();
            },
        );
        println!("{name}: {floors} of 10 minimisations at the rounding floor");
        assert!(floors > 0, "{name}: no minimisation reached the floor");
    }
}

/// One Neo-Hookean triangle (tests/implicit/materials.rs, E = 100 Pa)
/// whose free vertex moves at `speed` towards its fixed edge.
fn crushed_triangle(speed: f64) -> Scene {
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene
        .particles
        .push(hyperpbd::Particle::fixed(vec![0.0, 0.0]));
    scene
        .particles
        .push(hyperpbd::Particle::fixed(vec![1.0, 0.0]));
    let mut free = hyperpbd::Particle::new(vec![0.0, 1.0], 1.0);
    free.velocity = Some(vec![0.0, -speed]);
    scene.particles.push(free);
    scene.constraints.push(ConstraintFamily::material(
        ConstraintKind::NeoHookean,
        100.0,
        0.3,
        vec![vec![0, 1, 2]],
    ));
    scene.solver = Solver::IncrementalPotential(settings(1e3, 1e-3, 1e-6, 50));
    scene
}

/// The triangle crushed at 200 m/s: its inertial prediction is inverted
/// (J < 0), so the warm start falls back to x^t and the first trials are
/// law refusals (F = +∞, rejected) on both paths, bit for bit.
#[test]
fn a_crushed_neo_hookean_triangle_is_the_golden_path() {
    let height = |s: &State| (-s.positions[5], 0.0);
    differential(
        "Neo-Hookean triangle crushed at 200 m/s",
        &crushed_triangle(200.0),
        30,
        height,
    );
}

/// An element inverted at the step's start is the golden path's typed
/// refusal (`Refusal::Material`, the same family, element and J), and the
/// GPU state is rolled back byte for byte.
#[test]
fn an_element_inverted_at_the_start_is_the_golden_refusal() {
    let Some((adapter, _)) = adapter_or_skip("inverted start", Precision::F64) else {
        return;
    };
    let mut scene = crushed_triangle(0.0);
    scene.particles[2].position = vec![0.0, -1.0];
    let rest = vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![0.0, 1.0]];
    scene.constraints[0] = scene.constraints[0].clone().with_rest_positions(rest);
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut gpu =
        GpuCoupledBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("loads");
    let before = gpu.read_state().expect("state");
    let gpu_error = gpu.step().expect_err("an inverted start is refused");
    let cpu_error = common::cpu_backend(&scene, 1)
        .step()
        .expect_err("an inverted start is refused");
    assert_eq!(format!("{gpu_error:?}"), format!("{cpu_error:?}"));
    assert!(
        gpu_error.to_string().contains("constraints[0] element 0"),
        "{gpu_error}"
    );
    assert_eq!(bits(&before), bits(&gpu.read_state().expect("state")));
}

/// One Kuhn cell of 0.1 m in R^`dim` (StVK, ν = 0.1, 0.1 kg nodes)
/// thrown at 4 m/s onto a plane from 0.2 m.
fn one_cell_block(dim: usize) -> Scene {
    use hyperpbd::SceneBuilder;
    use hyperpbd::builders::BlockSpec;
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 30.0)
        .substeps(1)
        .iterations(10)
        .gravity_along(1, -9.81);
    let mut origin = vec![0.0; dim];
    origin[1] = 0.2;
    b.soft_block(&BlockSpec {
        cells: vec![1; dim],
        origin,
        spacing: 0.1,
        mass: 0.1,
        compliance: 1e-7,
        edge_compliance: None,
    });
    let mut up = vec![0.0; dim];
    up[1] = 1.0;
    b.hyperplane(up, 0.0, 0.0);
    let mut scene = b.build().expect("valid block");
    for p in &mut scene.particles {
        let mut v = vec![0.0; dim];
        v[1] = -4.0;
        p.velocity = Some(v);
    }
    let elements = scene.constraints[0].elements.clone();
    scene.constraints = vec![ConstraintFamily::material(
        ConstraintKind::Stvk,
        2e5,
        0.1,
        elements,
    )];
    scene.solver = Solver::IncrementalPotential(settings(1e4, 1e-3, 1e-2, 50));
    scene
}

/// Frame Hessians of 4- and 5-simplices (16 × 16, 25 × 25): in R^4 the
/// step is the golden path's (24 elements, 2 frames); in R^5 the Jacobi
/// sweeps exceed llvmpipe's loop budget, which the kernel detects: on
/// lavapipe the step is refused naming a material element (a typed
/// `GpuError::Unsupported`, the state rolled back, never a different
/// result); an adapter without the budget runs it, held to the golden path.
#[test]
fn higher_dimensional_material_elements_are_the_golden_path_or_refused_as_too_long() {
    let Some((adapter, summary)) = adapter_or_skip("R^5 material block", Precision::F64) else {
        return;
    };
    let above = |s: &State| (-s.positions[1], 0.0);
    differential(
        "one Kuhn cell of StVK 4-simplices",
        &one_cell_block(4),
        2,
        above,
    );
    let scene = one_cell_block(5);
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut gpu =
        GpuCoupledBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("loads");
    match gpu.step() {
        Err(BackendError::Gpu(GpuError::Unsupported { what })) => {
            assert!(what.contains("loops of material element"), "{what}");
            assert_eq!(bits(&state), bits(&gpu.read_state().expect("state")));
            println!("R^5 material block: {what}");
        }
        Err(e) => panic!("expected the loop refusal or a step, got {e}"),
        Ok(_) => {
            let mut cpu = common::cpu_backend(&scene, 1);
            cpu.step().expect("cpu");
            let golden = cpu.read_state().expect("cpu");
            if f64_identical(&summary) {
                assert!(bits(&golden) == bits(&gpu.read_state().expect("gpu")));
            }
        }
    }
}

/// Embedded elements (k < N) in two families of different orders: a
/// hanging 0.3 × 0.2 m sheet of Neo-Hookean triangles in R^3 (its measure
/// ratio from the Cholesky factor of C, not a determinant), tilted out of
/// its plane, with StVK segments (k = 1) along its free edge, released at
/// rest: the frame Hessians of both orders (6 × 6 and 3 × 3 in one frames
/// buffer) on the GPU, frame for frame the golden path's bits.
#[test]
fn an_embedded_sheet_with_edge_segments_is_the_golden_path() {
    use hyperpbd::builders::{coords_of, kuhn_grid_elements};
    let cells = [3, 2];
    let nodes = [cells[0] + 1, cells[1] + 1];
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -common::implicit_scenes::G, 0.0]);
    for i in 0..nodes[0] * nodes[1] {
        let c = coords_of(i, &nodes);
        let (u, w) = (0.1 * c[0] as f64, 0.1 * c[1] as f64);
        // The sheet spans x and y, leaning 0.3 of its height along z.
        let position = vec![u, w, 0.3 * (0.2 - w)];
        if c[1] == cells[1] {
            scene.particles.push(hyperpbd::Particle::fixed(position));
        } else {
            let mut p = hyperpbd::Particle::new(position, 1.0);
            p.mass = None;
            scene.particles.push(p);
        }
    }
    scene.constraints.push(
        ConstraintFamily::material(
            ConstraintKind::NeoHookean,
            1e4,
            0.3,
            kuhn_grid_elements(&cells, 0),
        )
        .with_density(1000.0),
    );
    scene.constraints.push(ConstraintFamily::material(
        ConstraintKind::Stvk,
        1e3,
        0.0,
        (0..cells[0]).map(|k| vec![k, k + 1]).collect(),
    ));
    scene.solver = Solver::IncrementalPotential(settings(1e3, 1e-3, 1e-6, 50));
    let sag = |s: &State| {
        let lowest = (0..nodes[0])
            .map(|i| s.position(i)[1])
            .fold(f64::INFINITY, f64::min);
        (-(lowest + 0.1), 0.0)
    };
    differential("embedded NH sheet with StVK edge segments", &scene, 30, sag);
}

#[test]
fn pcg_stopped_by_its_budget_is_the_golden_path() {
    // Two CG iterations per Newton direction cannot solve the chain's 24
    // coordinates: directions end at the budget, where the device's
    // recurrence (cp_cg_beta) must stop exactly as core's pcg_on does.
    let mut scene = alternating_chain();
    if let Solver::IncrementalPotential(s) = &mut scene.solver {
        s.cg_iterations = Some(2);
    }
    let mut cpu = common::cpu_backend(&scene, 1);
    let mut at_budget = 0;
    for _ in 0..10 {
        for m in cpu.step().expect("cpu").minimisation {
            at_budget += m.cg_iterations.iter().filter(|&&c| c == 2).count();
        }
    }
    assert!(at_budget > 0, "no direction reached the CG budget of 2");
    let links = |s: &State| {
        let x = &s.positions;
        let worst = (0..12)
            .map(|k| ((x[2 * k + 2] - x[2 * k]).hypot(x[2 * k + 3] - x[2 * k + 1]) - 0.1).abs())
            .fold(0.0, f64::max);
        (worst, 1e-2)
    };
    differential("chain 1:1e6, CG budget 2", &scene, 10, links);
}
