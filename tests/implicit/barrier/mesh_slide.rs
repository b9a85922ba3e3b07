//! Sliding over a triangle mesh in 4D.

use super::*;

use hyperpbd::builders::triangle_grid;

/// A 4×4 grid of squares, each split into two triangles, in the x0-x1
/// plane of R^4; gravity along −x3. A particle launched along x0 at 1 m/s
/// slides across several triangles and edges (frictionless), x2 stays
/// exactly 0, the height stays in the barrier band, and d stays > 0 at
/// every step. The barrier is a sum over simplices, so near a shared edge
/// the neighbouring triangle's term (measured to its edge) pushes away
/// from that triangle with a horizontal component — the seed's "each cell's
/// barrier pushes away from itself" / "a shared edge carries both adjacent
/// cells' terms". Crossing edges therefore exchanges momentum with those
/// bumps, and the slide is not the ideal flat-plane slide; the test bounds
/// the travel against the flat value and prints the measured deviation.
#[test]
fn particle_slides_over_a_triangle_mesh_in_4d() {
    let dim = 4;
    let mut scene = Scene::new(dim, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, 0.0, 0.0, -9.81]);
    scene.particles.push(
        Particle::new(vec![0.1, 1.1, 0.0, 0.05], 1.0).with_velocity(vec![1.0, 0.0, 0.0, 0.0]),
    );
    scene.obstacles.push(triangle_grid(dim, [0, 1], 5, 0.5));
    scene.solver = ip(
        1e3,
        0.02,
        Convergence::MaxAccelerationResidual { tolerance: 1e-4 },
        100,
    );
    scene.validate().expect("valid");
    let mut b = cpu(&scene);
    let mut smallest = f64::INFINITY;
    let steps = 90;
    for _ in 0..steps {
        let report = b.step().expect("step");
        assert_eq!(report.minimisation[0].status, MinimisationStatus::Converged);
        let s = b.read_state().expect("state");
        let d = min_distance(&scene, &s);
        assert!(d > 0.0);
        smallest = smallest.min(d);
    }
    let s = b.read_state().expect("state");
    let x = s.position(0);
    println!("slide: final {x:?}, smallest d {smallest:e}");
    assert_eq!(x[2], 0.0, "no force has a component along x2");
    assert!(
        x[3] > 0.0 && x[3] < 0.02,
        "height {} outside the barrier band",
        x[3]
    );
    assert!(x[0] > 1.0, "crossed several triangles (x0 = {})", x[0]);
    bound(
        "slide: |x0 − (x0(0) + v t)| / (v t)",
        (x[0] - (0.1 + 1.5)).abs() / 1.5,
        0.1,
        "per-simplex barrier sum: edge bumps of height ~d^ exchange momentum; 10% of the flat-plane travel (not a rounding bound)",
    );
    assert!(smallest > 0.0);
}
