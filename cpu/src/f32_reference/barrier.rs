//! The barrier kernels of `shaders/barrier.wgsl` in f32, line for line in
//! the shader's operation order: `evaluate` (per particle, over every
//! obstacle, planes then simplices: Σ b, Σ b' n, Σ b'' n nᵀ and the
//! smallest d capped at d^) and `filter_fraction` (the certified step fraction).
//!
//! ```text
//! uploaded, each f64 rounded to f32 once (gpu/src/barrier.rs):
//!   geometry  [plane normals, planes·DIM | plane offsets, planes |
//!              simplex vertices, simplices·4·DIM]   (obstacle_geometry, push_reals)
//!             in device coordinates: plane offsets c − n·o, vertices v − o
//!             (local_obstacles; the kernel-level BarrierKernels uploads
//!             the obstacles as given, o = 0)
//!   arity     u32 per simplex
//!   κ, d^, η  BarrierLaw::stiffness, ::activation_distance, FILTER_SAFETY
//!             (barrier_params; its `scale` is not read by these kernels)
//!   x, r, Δ   per particle (x − o on the step path)
//! kernel    obstacle_distance (plane: (n·x − c) − r; simplex: every face's
//!           Gram solve without pivots, smallest |x − q|², first on a tie,
//!           n = (x − q)/|x − q|), barrier_law by f32_reference::ln
//! read back energy (REAL_MAX = f32::MAX stands for +∞), gradient,
//!           Hessian block, scalar (smallest d or the fraction)
//! ```
//! Every f32 operation correctly rounded and none contracted (lavapipe:
//! `tests/common/exact.rs`) gives these bits; `tests/gpu_barrier` asserts
//! it for every particle of its cases.

// `!(a > b)` is the shader's NaN-aware test, kept as written.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use hyperpbd_core::barrier::{BarrierLaw, BarrierObstacles, FILTER_SAFETY, SIMPLEX_SLOTS};

use super::ln::ln;

/// The kernel's obstacle and law inputs, as the device holds them.
#[derive(Debug, Clone, PartialEq)]
pub struct BarrierInputs {
    /// Coordinates per point.
    pub dim: usize,
    /// Number of plane obstacles (`bp.planes`).
    pub planes: usize,
    /// `geometry` binding: normals | offsets | simplex vertices (4 slots).
    pub geometry: Vec<f32>,
    /// Vertices per simplex (`arity` binding, without the padding word).
    pub arity: Vec<u32>,
    /// κ (`bp.stiffness`).
    pub stiffness: f32,
    /// d^ (`bp.activation`).
    pub activation: f32,
    /// η (`bp.safety`).
    pub safety: f32,
}

impl BarrierInputs {
    /// The inputs `BarrierKernels` uploads for `law` and `obstacles`
    /// (already in device coordinates), each f64 rounded to f32 once.
    pub fn new(dim: usize, law: &BarrierLaw, obstacles: &BarrierObstacles) -> Self {
        let geometry = obstacles
            .plane_normals
            .iter()
            .chain(&obstacles.plane_offsets)
            .chain(&obstacles.simplex_vertices)
            .map(|&v| v as f32)
            .collect();
        BarrierInputs {
            dim,
            planes: obstacles.plane_count(),
            geometry,
            arity: obstacles.simplex_arity.clone(),
            stiffness: law.stiffness as f32,
            activation: law.activation_distance as f32,
            safety: FILTER_SAFETY as f32,
        }
    }

    /// Planes plus simplices.
    fn obstacles(&self) -> usize {
        self.planes + self.arity.len()
    }

    /// Vertex j, coordinate a of simplex s.
    fn vertex(&self, s: usize, j: usize, a: usize) -> f32 {
        let base = self.planes * self.dim + self.planes;
        self.geometry[base + (s * SIMPLEX_SLOTS + j) * self.dim + a]
    }
}

/// One particle's `evaluate` outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct BarrierTerms {
    /// Σ b (f32::MAX where some d ≤ 0: the shader's stand-in for +∞).
    pub energy: f32,
    /// Σ b' n, `dim`.
    pub gradient: Vec<f32>,
    /// Σ b'' n nᵀ, `dim × dim` row-major.
    pub hessian: Vec<f32>,
    /// Smallest d, capped at d^ (the kernel visits no simplex beyond d^).
    pub min_distance: f32,
}

/// Row s1 < m of the face's Gram system (`gram_row`).
#[allow(clippy::too_many_arguments)] // the shader's signature
fn gram_row(
    inp: &BarrierInputs,
    s: usize,
    s1: usize,
    m: usize,
    members: &[usize; 4],
    g: &mut [[f32; 3]; 3],
    rhs: &mut [f32; 3],
    p: &[f32],
) {
    if s1 >= m {
        return;
    }
    let anchor = members[0];
    let js = members[s1 + 1];
    for t1 in 0..3 {
        if t1 < m {
            let jt = members[t1 + 1];
            let mut acc = 0.0f32;
            for a in 0..inp.dim {
                acc += (inp.vertex(s, js, a) - inp.vertex(s, anchor, a))
                    * (inp.vertex(s, jt, a) - inp.vertex(s, anchor, a));
            }
            g[s1][t1] = acc;
        }
    }
    let mut acc = 0.0f32;
    for a in 0..inp.dim {
        acc +=
            (inp.vertex(s, js, a) - inp.vertex(s, anchor, a)) * (p[a] - inp.vertex(s, anchor, a));
    }
    rhs[s1] = acc;
}

/// Elimination step c < m without pivoting (`eliminate`).
fn eliminate(c: usize, m: usize, ok: &mut bool, g: &mut [[f32; 3]; 3], rhs: &mut [f32; 3]) {
    if c >= m || !*ok {
        return;
    }
    if !(g[c][c] > 0.0) || g[c][c] > f32::MAX {
        *ok = false;
        return;
    }
    for r2 in 1..3 {
        if r2 > c && r2 < m {
            let factor = g[r2][c] / g[c][c];
            for s2 in 0..3 {
                if s2 >= c && s2 < m {
                    g[r2][s2] -= factor * g[c][s2];
                }
            }
            rhs[r2] -= factor * rhs[c];
        }
    }
}

/// Back substitution step k < m: μ[m − 1 − k] (`back_substitute`).
fn back_substitute(k: usize, m: usize, g: &[[f32; 3]; 3], rhs: &[f32; 3], mu: &mut [f32; 3]) {
    if k >= m {
        return;
    }
    let c = m - 1 - k;
    let mut value = rhs[c];
    for s2 in 1..3 {
        if s2 > c && s2 < m {
            value -= g[c][s2] * mu[s2];
        }
    }
    mu[c] = value / g[c][c];
}

/// |p − q|² for q the closest point of simplex s, p − q into `w`
/// (`simplex_offset`).
fn simplex_offset(inp: &BarrierInputs, s: usize, p: &[f32], w: &mut [f32]) -> f32 {
    let count = inp.arity[s] as usize;
    let dim = inp.dim;
    let mut best_squared = f32::MAX;
    let mut found = false;
    let mut rr = vec![0.0f32; dim];
    for face in 1usize..(1 << count) {
        let mut members = [0usize; 4];
        let mut size = 0;
        for j in 0..4 {
            if face & (1 << j) != 0 {
                members[size] = j;
                size += 1;
            }
        }
        let anchor = members[0];
        let m = size - 1;
        let mut lambda = [0.0f32; 4];
        let mut ok = true;
        if m == 0 {
            lambda[anchor] = 1.0;
        } else {
            let mut g = [[0.0f32; 3]; 3];
            let mut rhs = [0.0f32; 3];
            for s1 in 0..3 {
                gram_row(inp, s, s1, m, &members, &mut g, &mut rhs, p);
            }
            for c in 0..3 {
                eliminate(c, m, &mut ok, &mut g, &mut rhs);
            }
            if ok {
                let mut mu = [0.0f32; 3];
                for k in 0..3 {
                    back_substitute(k, m, &g, &rhs, &mut mu);
                }
                let mut sum = 0.0f32;
                for k in 0..3 {
                    if k < m {
                        lambda[members[k + 1]] = mu[k];
                        sum += mu[k];
                    }
                }
                lambda[anchor] = 1.0 - sum;
            }
        }
        if !ok || lambda.iter().any(|&l| l < 0.0) {
            continue;
        }
        rr.copy_from_slice(p);
        for j in 0..4 {
            if j < count && face & (1 << j) != 0 {
                for a in 0..dim {
                    rr[a] -= lambda[j] * inp.vertex(s, j, a);
                }
            }
        }
        let mut squared = 0.0f32;
        for a in 0..dim {
            squared += rr[a] * rr[a];
        }
        if !found || squared < best_squared {
            found = true;
            best_squared = squared;
            w.copy_from_slice(&rr);
        }
    }
    best_squared
}

/// Distance to obstacle o from p (radius r), the unit direction into n
/// (`obstacle_distance`).
pub fn obstacle_distance(inp: &BarrierInputs, o: usize, p: &[f32], r: f32, n: &mut [f32]) -> f32 {
    let dim = inp.dim;
    if o < inp.planes {
        let mut dot = 0.0f32;
        for a in 0..dim {
            n[a] = inp.geometry[o * dim + a];
            dot += n[a] * p[a];
        }
        return dot - inp.geometry[inp.planes * dim + o] - r;
    }
    let best_squared = simplex_offset(inp, o - inp.planes, p, n);
    let distance = best_squared.sqrt();
    if distance > 0.0 {
        for a in 0..dim {
            n[a] /= distance;
        }
    }
    distance - r
}

/// (b, b', b'') of the clamped-log law at d (`barrier_law`).
pub fn barrier_law(inp: &BarrierInputs, d: f32) -> (f32, f32, f32) {
    let dh = inp.activation;
    let k = inp.stiffness;
    let ln = ln(d / dh);
    let e = d - dh;
    let b = -k * e * e * ln;
    let b1 = -k * (2.0 * e * ln + e * e / d);
    let b2 = -k * (2.0 * ln + 4.0 * e / d - e * e / (d * d));
    (b, b1, b2)
}

/// One particle's energy, gradient, Hessian block and smallest distance
/// (`evaluate_particle`), at x = `p` with radius `r`. Every simplex is
/// visited (the exhaustive oracle of the kernel's hierarchy walk: those it
/// skips have d ≥ d^ and add nothing).
pub fn evaluate(inp: &BarrierInputs, p: &[f32], r: f32) -> BarrierTerms {
    let dim = inp.dim;
    let mut g = vec![0.0f32; dim];
    let mut hessian = vec![0.0f32; dim * dim];
    let mut e_sum = 0.0f32;
    let mut smallest = f32::MAX;
    let mut infeasible = false;
    let mut n = vec![0.0f32; dim];
    for o in 0..inp.obstacles() {
        let d = obstacle_distance(inp, o, p, r, &mut n);
        smallest = smallest.min(d);
        if d >= inp.activation {
            continue;
        }
        if !(d > 0.0) {
            infeasible = true;
            continue;
        }
        let law = barrier_law(inp, d);
        e_sum += law.0;
        for a in 0..dim {
            g[a] += law.1 * n[a];
            for c in 0..dim {
                hessian[a * dim + c] += law.2 * n[a] * n[c];
            }
        }
    }
    if infeasible {
        e_sum = f32::MAX;
    }
    BarrierTerms {
        energy: e_sum,
        gradient: g,
        hessian,
        min_distance: smallest.min(inp.activation),
    }
}

/// The certified fraction of the step `step` from x = `p`, radius `r`
/// (`particle_filter_fraction`).
pub fn filter_fraction(inp: &BarrierInputs, p: &[f32], r: f32, step: &[f32]) -> f32 {
    let dim = inp.dim;
    let mut length2 = 0.0f32;
    for a in 0..dim {
        length2 += step[a] * step[a];
    }
    let length = length2.sqrt();
    let mut t = f32::MAX;
    let mut n = vec![0.0f32; dim];
    for o in 0..inp.obstacles() {
        let d0 = obstacle_distance(inp, o, p, r, &mut n);
        if !(d0 > 0.0) {
            return 0.0;
        }
        let mut approach = length;
        if o < inp.planes {
            let mut dot = 0.0f32;
            for a in 0..dim {
                dot += n[a] * step[a];
            }
            approach = -dot;
        }
        if approach > 0.0 {
            t = t.min(d0 / approach);
        }
    }
    (inp.safety * t).min(1.0)
}
