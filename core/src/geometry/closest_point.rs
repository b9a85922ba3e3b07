//! Closest point of a k-simplex (k = 0…3) in R^N to a point, with its
//! barycentric witness.
//!
//! ```text
//! for every nonempty face F = {v_a, …} of the simplex (bitmask order 1, 2, 3, …):
//!   E = [v_b − v_a …],  solve (EᵀE) μ = Eᵀ(p − v_a)        (Gram system, SPD)
//!   λ_a = 1 − Σ μ,  λ_b = μ_b
//!   if every λ ≥ 0:  candidate q = Σ λ v,  r = p − q,  |r|²
//! closest = the candidate with the smallest |r|² (first one on a tie)
//! ```
//! The closest point of a convex simplex lies in the relative interior of
//! exactly one face, where it is that face's affine projection; every
//! candidate lies in the simplex, so none is closer than the true point.
//! The minimum over candidates is therefore the closest point, decided by
//! enumeration alone: there is no tolerance and no "close enough" band.
//! Each candidate is evaluated in f64 (Gram solve by Gaussian elimination
//! on an SPD matrix, which needs no pivoting); a non-degenerate simplex
//! (checked at validation) keeps every Gram matrix nonsingular. The face
//! test reads the computed λ, so within rounding of a face boundary the
//! neighbouring face may be chosen; both candidates are then within
//! rounding of the true point, and the distance differs by rounding only
//! (no error bound is published beyond that).

// Index loops mirror the math (and the WGSL port) line by line.
#![allow(clippy::needless_range_loop)]

/// Largest simplex order supported (tetrahedra).
pub const MAX_SIMPLEX_ORDER: usize = 3;

/// The closest point of a simplex to a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosestPoint {
    /// |p − q| (≥ 0).
    pub distance: f64,
    /// Barycentric coordinates of q over the simplex's k + 1 vertices
    /// (zeros past k; exactly zero for vertices outside the active face).
    pub witness: [f64; MAX_SIMPLEX_ORDER + 1],
    /// Bitmask of the active face (bit j: vertex j).
    pub face: u32,
}

/// Closest point of the simplex `vertices` (k + 1 points, flat,
/// `vertices[j * dim + a]`) to `p`. Writes `r = p − q` into `offset`
/// (length `dim`). `k + 1` must be 1…4.
pub fn closest_point_on_simplex(
    p: &[f64],
    vertices: &[f64],
    dim: usize,
    offset: &mut [f64],
) -> ClosestPoint {
    // The same code with N a constant in R^2–R^4 (unrolled loops, the
    // same operations in the same order) and a scratch of a few
    // coordinates there (no 2 KiB to clear).
    match dim {
        2 => closest_in::<4>(p, vertices, 2, offset),
        3 => closest_in::<4>(p, vertices, 3, offset),
        4 => closest_in::<4>(p, vertices, 4, offset),
        _ => closest_in::<{ crate::MAX_DIM }>(p, vertices, dim, offset),
    }
}

/// [`closest_point_on_simplex`] with a scratch of `D` ≥ `dim` coordinates.
#[inline(always)]
fn closest_in<const D: usize>(
    p: &[f64],
    vertices: &[f64],
    dim: usize,
    offset: &mut [f64],
) -> ClosestPoint {
    let count = vertices.len() / dim;
    let mut best = ClosestPoint {
        distance: f64::INFINITY,
        witness: [0.0; MAX_SIMPLEX_ORDER + 1],
        face: 0,
    };
    let mut best_squared = f64::INFINITY;
    let mut r = [0.0f64; D];
    let r = &mut r[..dim];
    for face in 1u32..(1 << count) {
        let Some(lambda) = face_projection(p, vertices, dim, face) else {
            continue;
        };
        if lambda.iter().any(|&l| l < 0.0) {
            continue;
        }
        // r = p − Σ λ_j v_j, accumulated in vertex order.
        r.copy_from_slice(p);
        for j in 0..count {
            if face & (1 << j) != 0 {
                for a in 0..dim {
                    r[a] -= lambda[j] * vertices[j * dim + a];
                }
            }
        }
        let squared: f64 = r.iter().map(|x| x * x).sum();
        if squared < best_squared {
            best_squared = squared;
            best.witness = lambda;
            best.face = face;
            offset.copy_from_slice(r);
        }
    }
    best.distance = best_squared.sqrt();
    best
}

/// Barycentric coordinates of the affine projection of `p` onto the face
/// `face` (zeros outside it), or `None` if its Gram matrix is singular.
#[inline(always)]
fn face_projection(
    p: &[f64],
    vertices: &[f64],
    dim: usize,
    face: u32,
) -> Option<[f64; MAX_SIMPLEX_ORDER + 1]> {
    let mut members = [0usize; MAX_SIMPLEX_ORDER + 1];
    let mut size = 0;
    for j in 0..=MAX_SIMPLEX_ORDER {
        if face & (1 << j) != 0 {
            members[size] = j;
            size += 1;
        }
    }
    let mut lambda = [0.0; MAX_SIMPLEX_ORDER + 1];
    let anchor = members[0];
    let rest = &members[1..size];
    let m = rest.len();
    if m == 0 {
        lambda[anchor] = 1.0;
        return Some(lambda);
    }
    let v = |j: usize, a: usize| vertices[j * dim + a];
    // Gram matrix G = EᵀE and right-hand side Eᵀ(p − v_anchor).
    let mut g = [[0.0f64; MAX_SIMPLEX_ORDER]; MAX_SIMPLEX_ORDER];
    let mut rhs = [0.0f64; MAX_SIMPLEX_ORDER];
    for (s, &js) in rest.iter().enumerate() {
        for (t, &jt) in rest.iter().enumerate() {
            g[s][t] = (0..dim)
                .map(|a| (v(js, a) - v(anchor, a)) * (v(jt, a) - v(anchor, a)))
                .sum();
        }
        rhs[s] = (0..dim)
            .map(|a| (v(js, a) - v(anchor, a)) * (p[a] - v(anchor, a)))
            .sum();
    }
    let mu = solve_spd(&mut g, &mut rhs, m)?;
    let mut sum = 0.0;
    for (s, &js) in rest.iter().enumerate() {
        lambda[js] = mu[s];
        sum += mu[s];
    }
    lambda[anchor] = 1.0 - sum;
    Some(lambda)
}

/// Solves G μ = b for an SPD m×m G (m ≤ 3) by Gaussian elimination
/// without pivoting; `None` on a zero pivot.
#[inline(always)]
fn solve_spd(
    g: &mut [[f64; MAX_SIMPLEX_ORDER]; MAX_SIMPLEX_ORDER],
    b: &mut [f64; MAX_SIMPLEX_ORDER],
    m: usize,
) -> Option<[f64; MAX_SIMPLEX_ORDER]> {
    for c in 0..m {
        if g[c][c] <= 0.0 || !g[c][c].is_finite() {
            return None;
        }
        for r in c + 1..m {
            let factor = g[r][c] / g[c][c];
            for s in c..m {
                g[r][s] -= factor * g[c][s];
            }
            b[r] -= factor * b[c];
        }
    }
    let mut mu = [0.0; MAX_SIMPLEX_ORDER];
    for c in (0..m).rev() {
        let mut value = b[c];
        for s in c + 1..m {
            value -= g[c][s] * mu[s];
        }
        mu[c] = value / g[c][c];
    }
    Some(mu)
}
