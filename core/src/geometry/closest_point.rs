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
    let grams = Grams::of(p, vertices, dim, count);
    let mut search = Search {
        p,
        vertices,
        dim,
        count,
        grams: &grams,
        best: ClosestPoint {
            distance: f64::INFINITY,
            witness: [0.0; MAX_SIMPLEX_ORDER + 1],
            face: 0,
        },
        best_squared: f64::INFINITY,
    };
    let mut r = [0.0f64; D];
    let r = &mut r[..dim];
    // The faces 1, 2, … < 2^count in order, each with its mask a literal:
    // the inlined face code then indexes its members by constants and
    // keeps λ in registers (a loop over a variable mask stored λ lane by
    // lane and read it back whole, stalling on every face).
    macro_rules! faces {
        ($($face:literal)*) => {
            $(if $face < 1u32 << count {
                search.consider($face, r, offset);
            })*
        };
    }
    faces!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
    search.best.distance = search.best_squared.sqrt();
    search.best
}

/// The enumeration of [`closest_in`]: the simplex, its Gram systems and
/// the closest candidate so far.
struct Search<'a> {
    p: &'a [f64],
    vertices: &'a [f64],
    dim: usize,
    count: usize,
    grams: &'a Grams,
    best: ClosestPoint,
    best_squared: f64,
}

impl Search<'_> {
    /// The face `face`'s projection as a candidate: kept (its r = p − q in
    /// `offset`) when it is closer than every earlier one.
    #[inline(always)]
    fn consider(&mut self, face: u32, r: &mut [f64], offset: &mut [f64]) {
        let Some(lambda) = self.grams.face_projection(face) else {
            return;
        };
        // r = p − Σ λ_j v_j, accumulated in vertex order.
        r.copy_from_slice(self.p);
        for j in 0..self.count {
            if face & (1 << j) != 0 {
                for a in 0..self.dim {
                    r[a] -= lambda[j] * self.vertices[j * self.dim + a];
                }
            }
        }
        let squared: f64 = r.iter().map(|x| x * x).sum();
        if squared < self.best_squared {
            self.best_squared = squared;
            self.best.witness = lambda;
            self.best.face = face;
            offset.copy_from_slice(r);
        }
    }
}

/// The Gram systems of every face, by the face's anchor (its lowest
/// vertex a): for a < j ≤ k,
/// `gram[a][j][k] = (v_j − v_a)·(v_k − v_a)` and
/// `rhs[a][j] = (v_j − v_a)·(p − v_a)`. A face with anchor a reads its
/// entries from row a, so each product sum is formed once per simplex,
/// not once per face holding it (a triangle: 7 sums, not 12), with the
/// same operations in the same order as a face would form it.
struct Grams {
    gram: [[[f64; MAX_SIMPLEX_ORDER + 1]; MAX_SIMPLEX_ORDER + 1]; MAX_SIMPLEX_ORDER],
    rhs: [[f64; MAX_SIMPLEX_ORDER + 1]; MAX_SIMPLEX_ORDER],
}

impl Grams {
    #[inline(always)]
    fn of(p: &[f64], vertices: &[f64], dim: usize, count: usize) -> Grams {
        let mut grams = Grams {
            gram: [[[0.0; MAX_SIMPLEX_ORDER + 1]; MAX_SIMPLEX_ORDER + 1]; MAX_SIMPLEX_ORDER],
            rhs: [[0.0; MAX_SIMPLEX_ORDER + 1]; MAX_SIMPLEX_ORDER],
        };
        let v = |j: usize, a: usize| vertices[j * dim + a];
        for anchor in 0..count.saturating_sub(1) {
            for js in anchor + 1..count {
                for jt in js..count {
                    let g: f64 = (0..dim)
                        .map(|a| (v(js, a) - v(anchor, a)) * (v(jt, a) - v(anchor, a)))
                        .sum();
                    grams.gram[anchor][js][jt] = g;
                    // (a − c)(b − c) = (b − c)(a − c) exactly: the same
                    // sum as the face's G[t][s] forms.
                    grams.gram[anchor][jt][js] = g;
                }
                grams.rhs[anchor][js] = (0..dim)
                    .map(|a| (v(js, a) - v(anchor, a)) * (p[a] - v(anchor, a)))
                    .sum();
            }
        }
        grams
    }

    /// Barycentric coordinates of the affine projection of `p` onto the
    /// face `face` (zeros outside it), or `None` if its Gram matrix is
    /// singular or a coordinate is negative (the projection is not a
    /// candidate). Each coordinate is tested as it is formed: a test of
    /// the whole array after its scalar stores read it back in wide loads
    /// that the CPU cannot forward from those stores (a quarter of this
    /// function's time, measured).
    #[inline(always)]
    fn face_projection(&self, face: u32) -> Option<[f64; MAX_SIMPLEX_ORDER + 1]> {
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
        // Gram matrix G = EᵀE and right-hand side Eᵀ(p − v_anchor),
        // E = [v_b − v_anchor …] over the rest of the face.
        let mut g = [[0.0f64; MAX_SIMPLEX_ORDER]; MAX_SIMPLEX_ORDER];
        let mut rhs = [0.0f64; MAX_SIMPLEX_ORDER];
        for (s, &js) in rest.iter().enumerate() {
            for (t, &jt) in rest.iter().enumerate() {
                g[s][t] = self.gram[anchor][js][jt];
            }
            rhs[s] = self.rhs[anchor][js];
        }
        let mu = solve_spd(&mut g, &mut rhs, m)?;
        let mut sum = 0.0;
        let mut negative = false;
        for (s, &js) in rest.iter().enumerate() {
            lambda[js] = mu[s];
            negative |= mu[s] < 0.0;
            sum += mu[s];
        }
        let first = 1.0 - sum;
        lambda[anchor] = first;
        // `x < 0` is false for a NaN: a NaN coordinate is kept, as the
        // face's computed candidate.
        negative |= first < 0.0;
        (!negative).then_some(lambda)
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A face's projection with its Gram system formed from the vertices
    /// for that face alone (what [`Grams`] shares between faces), kept
    /// when no coordinate is negative.
    fn face_alone(p: &[f64], vertices: &[f64], dim: usize, face: u32) -> Option<[f64; 4]> {
        let members: Vec<usize> = (0..4).filter(|j| face & (1 << j) != 0).collect();
        let (anchor, rest) = (members[0], &members[1..]);
        let mut lambda = [0.0; 4];
        if rest.is_empty() {
            lambda[anchor] = 1.0;
            return Some(lambda);
        }
        let v = |j: usize, a: usize| vertices[j * dim + a];
        let mut g = [[0.0f64; 3]; 3];
        let mut rhs = [0.0f64; 3];
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
        let mu = solve_spd(&mut g, &mut rhs, rest.len())?;
        let mut sum = 0.0;
        for (s, &js) in rest.iter().enumerate() {
            lambda[js] = mu[s];
            sum += mu[s];
        }
        lambda[anchor] = 1.0 - sum;
        (!lambda.iter().any(|&l| l < 0.0)).then_some(lambda)
    }

    /// The closest point with every face formed alone, in a loop over the
    /// masks (the enumeration of the module docs, written plainly).
    fn closest_alone(p: &[f64], vertices: &[f64], dim: usize, offset: &mut [f64]) -> ClosestPoint {
        let count = vertices.len() / dim;
        let mut best = ClosestPoint {
            distance: f64::INFINITY,
            witness: [0.0; 4],
            face: 0,
        };
        let mut best_squared = f64::INFINITY;
        for face in 1u32..(1 << count) {
            let Some(lambda) = face_alone(p, vertices, dim, face) else {
                continue;
            };
            let mut r = p.to_vec();
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
                offset.copy_from_slice(&r);
            }
        }
        best.distance = best_squared.sqrt();
        best
    }

    /// Every face of segments, triangles and tetrahedra in R^1–R^5 (far
    /// from the origin, degenerate ones and points on vertices included):
    /// the shared Gram entries give each face's λ bit for bit, the same faces
    /// are candidates, and the closest point is the plain enumeration's.
    #[test]
    fn shared_gram_entries_give_every_face_its_own_bits() {
        let mut rng = crate::expr::tests::random::Rng(0x9e37_79b9_7f4a_7c15);
        let mut next = || rng.uniform(-0.5, 0.5);
        let mut faces = 0;
        for dim in 1..=5 {
            for count in 2..=4 {
                for case in 0..200 {
                    let offset = if case % 3 == 0 { 1000.0 } else { 0.0 };
                    let mut vertices: Vec<f64> =
                        (0..count * dim).map(|_| offset + next()).collect();
                    if case % 7 == 0 {
                        // Degenerate: the last vertex repeats the first.
                        let first = vertices[..dim].to_vec();
                        vertices[(count - 1) * dim..].copy_from_slice(&first);
                    }
                    let mut p: Vec<f64> = (0..dim).map(|_| offset + 2.0 * next()).collect();
                    if case % 11 == 0 {
                        p.copy_from_slice(&vertices[dim..2 * dim]);
                    }
                    let mut offset = vec![0.0; dim];
                    let found = closest_point_on_simplex(&p, &vertices, dim, &mut offset);
                    let mut expected_offset = vec![0.0; dim];
                    let expected = closest_alone(&p, &vertices, dim, &mut expected_offset);
                    assert_eq!(
                        (
                            found.distance.to_bits(),
                            found.witness.map(f64::to_bits),
                            found.face
                        ),
                        (
                            expected.distance.to_bits(),
                            expected.witness.map(f64::to_bits),
                            expected.face
                        ),
                        "dim {dim}, {count} vertices, case {case}"
                    );
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&offset), bits(&expected_offset));
                    let grams = Grams::of(&p, &vertices, dim, count);
                    for face in 1u32..(1 << count) {
                        let shared = grams.face_projection(face).map(|l| l.map(f64::to_bits));
                        let alone =
                            face_alone(&p, &vertices, dim, face).map(|l| l.map(f64::to_bits));
                        assert_eq!(
                            shared, alone,
                            "dim {dim}, {count} vertices, case {case}, face {face}"
                        );
                        faces += 1;
                    }
                }
            }
        }
        assert_eq!(faces, 5 * 200 * (3 + 7 + 15));
    }
}
