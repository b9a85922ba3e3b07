//! Simplex meshes on the XPBD path (core/src/kinds/mesh_contact.rs): a
//! ball on a flat triangulated floor moves as on the hyperplane at its
//! height (segments in R^2, triangles in R^3, tetrahedra in R^4), slides
//! to rest at μ g, is pushed out of an edge or a vertex along the
//! feature's normal; ties pick the lowest simplex; the hierarchy's choice
//! is the exhaustive scan's; every thread count gives the same bytes; the
//! f32 reference follows the golden path within f32 rounding.

use crate::common::meshes::floor;
use hyperpbd::barrier::{BarrierObstacles, distance_margin};
use hyperpbd::geometry::SimplexHierarchy;
use hyperpbd::kinds::mesh_contact::closest;
use hyperpbd::{Backend, CpuBackend, F32Reference, Obstacle, Particle, Plan, Scene, State};

const G: f64 = 9.81;

fn plane(dim: usize, height: f64, friction: f64) -> Obstacle {
    let mut normal = vec![0.0; dim];
    normal[1] = 1.0;
    Obstacle::Hyperplane {
        normal,
        offset: height,
        friction,
        compliance: 0.0,
        motion: Vec::new(),
    }
}

/// Balls of radius 0.1 dropped from 0.05 above `height` (one over a
/// cell's interior, one over a grid vertex: a shared feature), with
/// lateral velocity `slide` along e_0, gravity −y, on `obstacle`.
fn drop_scene(dim: usize, height: f64, slide: f64, obstacle: Obstacle) -> Scene {
    let mut s = Scene::new(dim, 1.0 / 60.0, 10, 2);
    let mut g = vec![0.0; dim];
    g[1] = -G;
    s.gravity = Some(g);
    for (k, start) in [0.137, 0.25].into_iter().enumerate() {
        let mut x = vec![start; dim];
        x[1] = height + 0.15;
        x[0] = start - 0.5 * k as f64;
        let mut v = vec![0.0; dim];
        v[0] = slide;
        s.particles
            .push(Particle::new(x, 1.0).with_radius(0.1).with_velocity(v));
    }
    s.obstacles = vec![obstacle];
    s
}

fn run(scene: &Scene, steps: usize, threads: usize) -> Vec<State> {
    let plan = Plan::compile(scene).expect("valid scene");
    let mut sim = CpuBackend::with_threads(plan, &State::from_scene(scene), threads).expect("cpu");
    (0..steps)
        .map(|_| {
            sim.step().expect("step");
            sim.read_state().expect("state")
        })
        .collect()
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn a_flat_mesh_moves_a_ball_as_the_plane_at_its_height() {
    let (height, half) = (0.25, 1.0);
    for (dim, cells) in [(2, 8), (3, 4), (4, 2)] {
        for (mu, slide) in [(0.0, 0.0), (0.4, 1.0)] {
            let mesh = drop_scene(dim, height, slide, floor(dim, height, half, cells, mu));
            let flat = drop_scene(dim, height, slide, plane(dim, height, mu));
            let steps = 30;
            let (a, b) = (run(&mesh, steps, 1), run(&flat, steps, 1));
            let worst = (a.iter().zip(&b))
                .map(|(a, b)| max_abs_diff(&a.positions, &b.positions))
                .fold(0.0, f64::max);
            // Both compute C and n to rounding: |x − q| − r against
            // n·x − (h + r), n = (x − q)/|x − q| against e_1. Each update
            // differs by at most the library's distance pad M (‖x‖∞ + G + r)
            // with M = 16 N (N + 4) ε (core/src/barrier.rs), and the
            // updates add: 30 steps × 10 substeps × 2 iterations × 2 balls.
            let updates = (steps * 10 * 2 * 2) as f64;
            let bound = updates * distance_margin(dim, f64::EPSILON) * (half + height + 0.5 + 0.1);
            println!("R^{dim}, μ = {mu}: mesh vs plane {worst:e} m (bound {bound:e})");
            assert!(worst <= bound, "R^{dim} μ {mu}: {worst:e} > {bound:e}");
            // And it rests on the floor: y = h + r at the end.
            let y = a[steps - 1].positions[1];
            assert!((y - (height + 0.1)).abs() <= bound, "y = {y}");
        }
    }
}

#[test]
fn a_ball_sliding_on_a_mesh_decelerates_at_mu_g() {
    let (mu, v0) = (0.3, 2.0);
    for dim in [2, 3, 4] {
        let mut scene = drop_scene(dim, 0.0, v0, floor(dim, 0.0, 4.0, 4, mu));
        scene.particles.truncate(1);
        scene.particles[0].position[1] = 0.1;
        let states = run(&scene, 30, 1);
        // v(t) = v0 − μ g t until it stops (t = v0/(μ g) ≈ 0.68 s).
        for (k, st) in states.iter().enumerate().step_by(6) {
            let t = (k + 1) as f64 / 60.0;
            let want = v0 - mu * G * t;
            let got = st.velocities[0];
            assert!(
                (got - want).abs() <= 0.02 * v0,
                "R^{dim} t {t}: {got} vs {want}"
            );
        }
        let last = &states[29];
        println!(
            "R^{dim}: v(0.5 s) = {:.6} (v0 − μ g t = {:.6})",
            last.velocities[0],
            v0 - mu * G * 0.5
        );
    }
}

/// One step without gravity from `x` against `obstacle` (1 substep, 1
/// iteration): where the ball of radius `r` ends.
fn pushed(dim: usize, obstacle: Obstacle, x: Vec<f64>, r: f64) -> Vec<f64> {
    let mut s = Scene::new(dim, 1.0 / 60.0, 1, 1);
    s.particles = vec![Particle::new(x, 1.0).with_radius(r)];
    s.obstacles = vec![obstacle];
    run(&s, 1, 1)[0].positions.clone()
}

fn mesh(vertices: Vec<Vec<f64>>, simplices: Vec<Vec<usize>>) -> Obstacle {
    Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: 0.0,
        motion: Vec::new(),
    }
}

fn assert_close(got: &[f64], want: &[f64], what: &str) {
    let d = max_abs_diff(got, want);
    println!("{what}: {got:?} (want {want:?}, off {d:e})");
    assert!(d <= 1e-14, "{what}: {got:?} vs {want:?}");
}

#[test]
fn a_ball_is_pushed_out_of_an_edge_or_a_vertex_along_its_normal() {
    let triangle = || {
        mesh(
            vec![
                vec![0.0, 0.0, 0.0],
                vec![1.0, 0.0, 0.0],
                vec![0.0, 0.0, 1.0],
            ],
            vec![vec![0, 1, 2]],
        )
    };
    // Beside the edge x = 0 (y = 0 plane): q = (0, 0, 0.5), n = (−0.6, 0.8, 0)/1.
    let got = pushed(3, triangle(), vec![-0.03, 0.04, 0.5], 0.1);
    assert_close(&got, &[-0.06, 0.08, 0.5], "edge of a triangle");
    // Past the vertex (1, 0, 0) along (1, 2, −2)/3.
    let got = pushed(3, triangle(), vec![1.02, 0.04, -0.04], 0.3);
    assert_close(&got, &[1.1, 0.2, -0.2], "vertex of a triangle");
    // A segment's end in R^2: along (3, 4)/5 from (1, 0).
    let segment = mesh(vec![vec![0.0, 0.0], vec![1.0, 0.0]], vec![vec![0, 1]]);
    let got = pushed(2, segment, vec![1.03, 0.04], 0.5);
    assert_close(&got, &[1.3, 0.4], "end of a segment");
    // Inside a tetrahedron of R^4's hyperplane x_3 = 0: along e_3.
    let tet = mesh(
        vec![
            vec![0.0; 4],
            vec![1.0, 0.0, 0.0, 0.0],
            vec![0.0, 1.0, 0.0, 0.0],
            vec![0.0, 0.0, 1.0, 0.0],
        ],
        vec![vec![0, 1, 2, 3]],
    );
    let got = pushed(4, tet, vec![0.1, 0.2, 0.3, 0.05], 0.25);
    assert_close(&got, &[0.1, 0.2, 0.3, 0.25], "face of a tetrahedron");
}

#[test]
fn a_tie_between_simplices_picks_the_lowest_index() {
    // Two parallel segments at y = ±0.1; a ball of radius 0.2 midway is
    // equally far from both: the first listed decides the normal.
    let below = vec![vec![-1.0, -0.1], vec![1.0, -0.1]];
    let above = vec![vec![-1.0, 0.1], vec![1.0, 0.1]];
    let both = |first: &Vec<Vec<f64>>, second: &Vec<Vec<f64>>| {
        let vertices = first.iter().chain(second).cloned().collect();
        mesh(vertices, vec![vec![0, 1], vec![2, 3]])
    };
    let up = pushed(2, both(&below, &above), vec![0.0, 0.0], 0.2);
    assert_close(&up, &[0.0, 0.1], "below listed first: pushed up");
    let down = pushed(2, both(&above, &below), vec![0.0, 0.0], 0.2);
    assert_close(&down, &[0.0, -0.1], "above listed first: pushed down");
}

/// `closest` over the hierarchy (the pruned candidates of
/// core/src/kinds/mesh_bounds.rs) against the scan of every simplex at
/// `points`, radii 0 and 0.1, reaches 0, 0.05 and 0.4: the same C and n to
/// the bit. Returns the contacts within reach.
fn assert_as_scan(
    dim: usize,
    vertices: &[Vec<f64>],
    simplices: &[Vec<usize>],
    points: &[Vec<f64>],
) -> usize {
    let indexed = BarrierObstacles::mesh(dim, 0, vertices, simplices);
    let mut every = indexed.clone();
    every.hierarchy = SimplexHierarchy::default();
    assert!(indexed.is_indexed() && !every.is_indexed());
    let (mut n1, mut n2) = (vec![0.0; dim], vec![0.0; dim]);
    let mut seen = 0;
    for x in points {
        for (radius, reach) in [0.0, 0.1]
            .into_iter()
            .flat_map(|r| [(r, 0.0), (r, 0.05), (r, 0.4)])
        {
            let a = closest(&indexed, x, radius, reach, &mut n1);
            let b = closest(&every, x, radius, reach, &mut n2);
            let at = format!("R^{dim} x {x:?} r {radius} reach {reach}");
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{at}");
            if a.is_some() {
                assert_eq!(n1, n2, "{at}");
                seen += 1;
            }
        }
    }
    seen
}

/// `count` points of [−1.2, 1.2]^N (x_1 within ±0.36) from a fixed stream.
fn scattered(dim: usize, count: usize) -> Vec<Vec<f64>> {
    let mut u = 0.123_456_789_f64;
    (0..count)
        .map(|_| {
            (0..dim)
                .map(|a| {
                    u = (u * 9_301.0 + 0.497_5).fract();
                    (2.4 * u - 1.2) * if a == 1 { 0.3 } else { 1.0 }
                })
                .collect()
        })
        .collect()
}

fn floor_mesh(dim: usize, cells: usize) -> (Vec<Vec<f64>>, Vec<Vec<usize>>) {
    let Obstacle::SimplexMesh {
        vertices,
        simplices,
        ..
    } = floor(dim, 0.0, 1.0, cells, 0.0)
    else {
        unreachable!("floor builds a mesh")
    };
    (vertices, simplices)
}

#[test]
fn the_hierarchy_chooses_as_the_exhaustive_scan() {
    for (dim, cells) in [(2, 16), (3, 6), (4, 3)] {
        let (vertices, simplices) = floor_mesh(dim, cells);
        let seen = assert_as_scan(dim, &vertices, &simplices, &scattered(dim, 2000));
        println!("R^{dim}: {seen} contacts within reach, identical");
        assert!(seen > 100);
    }
}

#[test]
fn the_pruned_choice_holds_at_ties_on_features_and_with_degenerate_simplices() {
    for (dim, cells) in [(2, 4), (3, 3), (4, 2)] {
        let (mut vertices, mut simplices) = floor_mesh(dim, cells);
        // Exact ties between simplices: every simplex again, the copies
        // with their vertices reversed (the same set, other rounding).
        let again: Vec<Vec<usize>> = simplices
            .iter()
            .map(|s| s.iter().rev().copied().collect())
            .collect();
        simplices.extend(again);
        // Degenerate simplices: a repeated vertex, a zero-length segment,
        // collinear vertices (an edge's midpoint added as a vertex).
        let (a, b) = (simplices[0][0], simplices[0][1]);
        let mid: Vec<f64> = (0..dim)
            .map(|k| 0.5 * (vertices[a][k] + vertices[b][k]))
            .collect();
        vertices.push(mid);
        let m = vertices.len() - 1;
        simplices.extend([vec![a, a, b], vec![b, b], vec![a, m, b], vec![m, a]]);
        // Points on grid vertices, edges and diagonals (where neighbours
        // tie), at heights 0 (on the mesh: no direction), 0.05 and 0.1.
        let step = 2.0 / cells as f64;
        let mut points = Vec::new();
        for (k, height) in [0.0, 0.05, 0.1].into_iter().enumerate() {
            for i in 0..=cells {
                for offset in [0.0, 0.25 * step, 0.5 * step] {
                    let mut x = vec![-1.0 + i as f64 * step + offset; dim];
                    x[1] = height;
                    if k == 1 && dim > 2 {
                        x[dim - 1] = -1.0 + i as f64 * step;
                    }
                    points.push(x);
                }
            }
            points.push(vertices[m].iter().map(|c| c + height).collect());
        }
        points.extend(scattered(dim, 300));
        let seen = assert_as_scan(dim, &vertices, &simplices, &points);
        println!("R^{dim}: {seen} contacts within reach, identical");
        assert!(seen > 100);
    }
}

#[test]
fn every_thread_count_gives_the_same_bytes() {
    // 1,600 balls (over one 1,024-element chunk) on a bumpy mesh with friction.
    let dim = 3;
    let mut s = Scene::new(dim, 1.0 / 60.0, 4, 2);
    s.gravity = Some(vec![0.0, -G, 0.0]);
    let mut obstacle = floor(dim, 0.0, 2.0, 8, 0.5);
    if let Obstacle::SimplexMesh { vertices, .. } = &mut obstacle {
        for (k, v) in vertices.iter_mut().enumerate() {
            v[1] = 0.05 * ((k * 7) % 5) as f64;
        }
    }
    s.obstacles = vec![obstacle];
    for k in 0..1600 {
        let (a, b) = ((k % 40) as f64, (k / 40) as f64);
        let x = vec![-1.9 + 0.095 * a, 0.35, -1.9 + 0.095 * b];
        s.particles.push(
            Particle::new(x, 1.0)
                .with_radius(0.04)
                .with_velocity(vec![0.5, 0.0, -0.3]),
        );
    }
    let one = run(&s, 20, 1);
    let four = run(&s, 20, 4);
    assert_eq!(one[19].hash(), four[19].hash(), "1 vs 4 threads");
    let resting = one[19].positions.chunks(3).filter(|x| x[1] < 0.3).count();
    println!(
        "{resting} of 1600 balls down on the mesh; hash {:016x}",
        one[19].hash()
    );
    assert!(resting > 1500);
}

#[test]
fn the_f32_reference_follows_the_golden_path() {
    for dim in [2, 3, 4] {
        let scene = drop_scene(dim, 0.25, 1.0, floor(dim, 0.25, 1.0, 4, 0.4));
        let plan = Plan::compile(&scene).expect("valid");
        let mut r = F32Reference::new(plan.clone(), &State::from_scene(&scene), &vec![0.0; dim])
            .expect("the f32 reference runs meshes");
        let mut golden = CpuBackend::new(plan, &State::from_scene(&scene)).expect("cpu");
        let mut worst = 0.0f64;
        for _ in 0..30 {
            r.step().expect("reference step");
            golden.step().expect("golden step");
            let (a, b) = (r.read_state(), golden.read_state().expect("read"));
            worst = worst.max(max_abs_diff(&a.positions, &b.positions));
        }
        // f32 rounding (ε = 1.2e-7) of O(1) m coordinates over 600
        // substeps of a landing, sliding ball: ~1e-6; a wrong normal or
        // a dropped friction term is off by centimetres.
        println!("R^{dim}: f32 reference vs golden {worst:e} m");
        assert!(worst > 0.0 && worst < 1e-4, "R^{dim}: {worst:e}");
    }
}

/// An edit of a mesh's vertices, simplices and friction.
type MeshEdit = dyn Fn(&mut Vec<Vec<f64>>, &mut Vec<Vec<usize>>, &mut f64);

#[test]
fn the_plan_and_validation_of_a_mesh_on_the_xpbd_path() {
    use hyperpbd::{FamilyKind, Kernel, SceneError, Solver, XpbdSettings};
    let scene = |friction: f64| drop_scene(3, 0.0, 0.0, floor(3, 0.0, 1.0, 2, friction));
    let plan = Plan::compile(&scene(0.0)).expect("a mesh is an XPBD contact");
    let family = &plan.families[0];
    assert_eq!(family.kind.name(), "mesh_contact");
    assert!(matches!(family.kind, FamilyKind::MeshContact { .. }));
    assert_eq!((family.len(), family.rest.clone()), (2, vec![0.1, 0.1]));
    assert_eq!(plan.obstacle_families, vec![Some(0)]);
    let friction =
        |p: &Plan| (p.substep_kernels.iter()).any(|k| matches!(k, Kernel::Friction { .. }));
    assert!(!friction(&plan), "no friction kernel without μ");
    assert!(friction(&Plan::compile(&scene(0.5)).expect("valid")));
    // Bad meshes are refused with their field paths, as on the barrier path.
    let refused = |edit: &MeshEdit| {
        let mut s = scene(0.0);
        let Obstacle::SimplexMesh {
            vertices,
            simplices,
            friction,
            ..
        } = &mut s.obstacles[0]
        else {
            unreachable!("a mesh")
        };
        edit(vertices, simplices, friction);
        s.validate().expect_err("refused")
    };
    let e = refused(&|_, s, _| s[3][2] = 99);
    assert!(
        matches!(&e, SceneError::VertexOutOfRange { path, index: 99, .. } if path == "obstacles[0].simplices[3][2]"),
        "{e:?}"
    );
    let e = refused(&|v, _, _| v[4][1] = f64::NAN);
    assert!(
        matches!(&e, SceneError::NonFinite { path, .. } if path == "obstacles[0].vertices[4][1]"),
        "{e:?}"
    );
    let e = refused(&|_, _, f| *f = -0.5);
    assert!(
        matches!(&e, SceneError::NegativeFriction { path, .. } if path == "obstacles[0].friction"),
        "{e:?}"
    );
    let e = refused(&|_, s, _| s[0] = vec![0, 1, 2, 3, 4]);
    assert!(
        matches!(&e, SceneError::WrongSimplexArity { path, .. } if path == "obstacles[0].simplices[0]"),
        "{e:?}"
    );
    let mut primal = scene(0.0);
    primal.solver = Solver::Xpbd(XpbdSettings {
        primal_residual: true,
    });
    let e = primal.validate().expect_err("refused");
    assert!(
        matches!(&e, SceneError::UnsupportedBySolver { path, solver: "xpbd", .. } if path == "obstacles[0]"),
        "{e:?}"
    );
    // Friction in JSON, round trip.
    let text = r#"{"dim": 2, "dt": 0.01, "particles": [{"position": [0, 1], "mass": 1}],
        "obstacles": [{"type": "simplex_mesh", "vertices": [[-1, 0], [1, 0]], "simplices": [[0, 1]], "friction": 0.3}]}"#;
    let s = Scene::from_json_str(text).expect("valid");
    assert_eq!(
        Scene::from_json_str(&s.to_json_string()).expect("round trip"),
        s
    );
}

#[test]
fn a_failed_step_leaves_the_state_as_it_was() {
    let scene = drop_scene(3, 0.0, 0.0, floor(3, 0.0, 1.0, 2, 0.5));
    let plan = Plan::compile(&scene).expect("valid");
    let mut sim = CpuBackend::new(plan, &State::from_scene(&scene)).expect("cpu");
    sim.step().expect("step");
    let mut state = sim.read_state().expect("state");
    state.velocities[1] = f64::INFINITY;
    sim.write_state(&state).expect("write");
    let written = sim.read_state().expect("state");
    sim.step().expect_err("a non-finite update fails the step");
    assert_eq!(sim.read_state().expect("state"), written);
}

#[test]
fn a_ball_resting_on_a_mesh_reports_m_g() {
    use hyperpbd::Backend;
    for dim in [2, 3, 4] {
        let mut s = drop_scene(dim, 0.0, 0.0, floor(dim, 0.0, 1.0, 2, 0.5));
        s.particles.truncate(1);
        s.particles[0].position[1] = 0.1;
        s.particles[0].mass = Some(3.0);
        let plan = Plan::compile(&s).expect("valid");
        let mut b = CpuBackend::with_threads(plan, &State::from_scene(&s), 1).expect("cpu");
        b.request_contact_forces(true)
            .expect("the CPU reports forces");
        let mut last = None;
        for _ in 0..60 {
            last = b.step().expect("step").contact_forces;
        }
        let f = last.expect("requested forces are reported");
        let mut want = vec![0.0; dim];
        want[1] = 3.0 * G;
        let off = max_abs_diff(f.obstacle(0), &want);
        let own = max_abs_diff(f.particle(0), &want);
        println!(
            "R^{dim}: mesh force {:?} (m g = {:.6}), off {off:e}",
            f.obstacle(0),
            3.0 * G
        );
        // The plane's closed form, 1e-9 relative (tests/contact_forces.rs).
        assert!(off <= 1e-9 * 3.0 * G && own <= 1e-9 * 3.0 * G, "{f:?}");
    }
}
