//! Closest points on simplices in R^N: the variational inequality and closed forms.

use super::*;

/// q is the closest point of a convex set S to p iff (p − q)·(y − q) ≤ 0
/// for every y in S; for a simplex it suffices to check the vertices. The
/// witness must be a convex combination reproducing q.
#[test]
fn closest_point_satisfies_the_variational_inequality_in_r4() {
    let dim = 4;
    let mut rng = Lcg(7);
    let mut worst: f64 = 0.0;
    let mut worst_witness: f64 = 0.0;
    for k in 0..=3 {
        for _ in 0..400 {
            let vertices: Vec<f64> = (0..(k + 1) * dim).map(|_| rng.next()).collect();
            let p: Vec<f64> = (0..dim).map(|_| 2.0 * rng.next()).collect();
            let mut r = vec![0.0; dim];
            let c = closest_point_on_simplex(&p, &vertices, dim, &mut r);
            let q: Vec<f64> = (0..dim).map(|a| p[a] - r[a]).collect();
            let sum: f64 = c.witness[..=k].iter().sum();
            assert!(c.witness.iter().all(|&l| l >= 0.0), "negative witness");
            worst_witness = worst_witness.max((sum - 1.0).abs());
            for a in 0..dim {
                let from_witness: f64 = (0..=k).map(|j| c.witness[j] * vertices[j * dim + a]).sum();
                worst_witness = worst_witness.max((from_witness - q[a]).abs());
            }
            assert!((c.distance - r.iter().map(|x| x * x).sum::<f64>().sqrt()).abs() <= 1e-15);
            for j in 0..=k {
                let y = &vertices[j * dim..(j + 1) * dim];
                let inner: f64 = (0..dim).map(|a| r[a] * (y[a] - q[a])).sum();
                worst = worst.max(inner);
            }
        }
    }
    // Values are O(1); a Gram solve and a few dot products of O(1) terms
    // round at a few ulps each.
    bound(
        "closest point: max (p−q)·(v−q) over vertices",
        worst,
        1e-13,
        "O(1) coordinates, Gram solve of size ≤ 3: ~100 u",
    );
    bound(
        "closest point: witness consistency",
        worst_witness,
        1e-13,
        "Σλ = 1 and Σλv = q to ~100 u",
    );
}

/// Closed forms: a point above a triangle's interior in R^4, one beside an
/// edge, one in a vertex region, and a point on the simplex (d = 0).
#[test]
fn closest_point_closed_forms() {
    let dim = 4;
    // Triangle in the x0-x1 plane.
    let tri = [0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0];
    let mut r = vec![0.0; dim];
    let c = closest_point_on_simplex(&[0.5, 0.5, 3.0, 4.0], &tri, dim, &mut r);
    assert_eq!(c.distance, 5.0);
    assert_eq!(c.face, 0b111);
    assert_eq!(c.witness, [0.5, 0.25, 0.25, 0.0]);
    // Beside the hypotenuse: closest point (1, 1).
    let c = closest_point_on_simplex(&[2.0, 2.0, 0.0, 0.0], &tri, dim, &mut r);
    assert_eq!(c.face, 0b110);
    assert!((c.distance - 2f64.sqrt()).abs() < 1e-15);
    // Vertex region of vertex 0.
    let c = closest_point_on_simplex(&[-1.0, -1.0, 1.0, 1.0], &tri, dim, &mut r);
    assert_eq!(c.face, 0b001);
    assert_eq!(c.distance, 2.0);
    // On the segment: distance exactly 0.
    let seg = [0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0];
    let c = closest_point_on_simplex(&[1.0, 0.0, 0.0, 0.0], &seg, dim, &mut r);
    assert_eq!(c.distance, 0.0);
    assert_eq!(c.witness, [0.75, 0.25, 0.0, 0.0]);
    // Tetrahedron in R^4, point straight above its interior along x3.
    let tet = [
        0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
    ];
    let c = closest_point_on_simplex(&[0.25, 0.25, 0.25, -2.0], &tet, dim, &mut r);
    assert_eq!(c.face, 0b1111);
    assert_eq!(c.distance, 2.0);
    assert_eq!(r, vec![0.0, 0.0, 0.0, -2.0]);
}
