//! The clamped-log barrier, its per-particle evaluation over every
//! obstacle, and the certified step filter.
//!
//! ```text
//! b(d)   = −κ (d − d^)² ln(d/d^)                                0 < d < d^
//! b'(d)  = −κ [2 (d − d^) ln(d/d^) + (d − d^)²/d]               (≤ 0)
//! b''(d) = −κ [2 ln(d/d^) + 4 (d − d^)/d − (d − d^)²/d²]        (> 0)
//! b = b' = b'' = 0 for d ≥ d^;  b = +∞ for d ≤ 0
//!
//! plane  (unit n, offset c):  d = n·x − c − r,  ∇d = n,  ∇²d = 0
//! simplex (closest point q):  d = |x − q| − r,  ∇d = n = (x − q)/|x − q|,
//!                             ∇²d = P/|x − q| with P the projector onto the
//!                             directions normal to both n and the active face
//! per obstacle:  ∇b = b' ∇d,  ∇²b = b'' n nᵀ + b' ∇²d
//! ```
//! b' ∇²d is negative semidefinite (b' ≤ 0, ∇²d ⪰ 0): the PSD projection
//! of one obstacle's block keeps b'' n nᵀ (eigenvalue b'' > 0 along n) and
//! clamps the eigenvalues b'/|x − q| of the remaining normal directions to 0.
//! The per-particle block is the sum of those projected blocks, so it is
//! PSD, and the Newton matrix m I + h² block is SPD.
//!
//! Step filter, per particle and step Δ (every obstacle, active or not):
//! ```text
//! plane:    d(t) = d0 + t n·Δ exactly;  t* = d0 / (−n·Δ) if n·Δ < 0, else ∞
//! simplex:  d(t) ≥ d0 − t |Δ| (distance is 1-Lipschitz);  t* = d0 / |Δ|
//! fraction = min(1, η · min over obstacles of t*),   η = FILTER_SAFETY
//! ```
//! so every trial point keeps d ≥ (1 − η) d0 > 0 — certified, never a
//! collision time. A trial step is cut by this fraction before it is
//! evaluated.
//!
//! Simplices are visited through the mesh hierarchy
//! ([`crate::geometry::simplex_hierarchy`]): per particle, only those whose
//! box overlaps the candidate box, in index order; every plane is visited.
//! ```text
//! candidate box  x ± (r + reach + pad),  pad = M (‖x‖∞ + G + r + reach)
//!                (G: the obstacles' coordinate scale; everything, when not finite)
//! reach, M       evaluation:        d^,               M = 16 N (N + 4) ε
//!                step filter:       |Δ| (1 + γ)/η,    M = 16 N (N + 4) ε    γ = (N + 4) ε
//!                feasibility d ≤ 0: 0,                M = 16 N (N + 4) ε
//!                certified filter:  |Δ| (1 + γ)/η,    M = 4 √(N (N + 4) ε)
//! ```
//! A simplex whose box misses the candidate box lies farther from x than
//! r + reach + pad, less the rounding of the box, in the ∞-norm and so in
//! the Euclidean norm. Its computed distance |x − q̂| − r (q̂ a convex
//! combination up to rounding) is within a few N ε (‖x‖∞ + G) of the
//! exact one; the certified filter's support bound (certified_filter.rs)
//! is within √(2 N (N + 4) ε) (‖x‖∞ + G), since the chosen face's point q̂
//! lies within √(|x − q̂|² − dist²) of the closest point. Both are far
//! below their pad. Such a simplex therefore has d ≥ d^ (no barrier term;
//! the smallest distance is reported capped at d^) and η t* ≥ 1
//! (min(1, η min t*) is unchanged),
//! so skipping it changes no bit of any result.

// Index loops mirror the math (and the WGSL port) line by line.
#![allow(clippy::needless_range_loop)]

use crate::geometry::simplex_hierarchy::{OrderedWalk, WALK_BATCH, push_box};
use crate::geometry::{SimplexHierarchy, closest_point_on_simplex, unit_vector};
use crate::{Obstacle, Scene};

/// η: the filter admits this fraction of the certified distance, so a
/// trial point keeps at least (1 − η) of each obstacle's distance.
pub const FILTER_SAFETY: f64 = 0.9;

/// κ and d^ of the clamped-log law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarrierLaw {
    /// κ > 0.
    pub stiffness: f64,
    /// d^ > 0.
    pub activation_distance: f64,
}

impl BarrierLaw {
    /// (b, b', b'') at distance d. The ln is [`crate::material::ln`], the
    /// arithmetic one `shaders/ln_f64.wgsl` computes bit for bit, so an f64
    /// kernel reproduces every barrier value (lavapipe's f64 `log` is wrong).
    pub fn evaluate(&self, d: f64) -> (f64, f64, f64) {
        let dh = self.activation_distance;
        if d <= 0.0 {
            return (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
        }
        if d >= dh {
            return (0.0, 0.0, 0.0);
        }
        let k = self.stiffness;
        let ln = crate::material::ln(d / dh);
        let e = d - dh;
        let b = -k * e * e * ln;
        let b1 = -k * (2.0 * e * ln + e * e / d);
        let b2 = -k * (2.0 * ln + 4.0 * e / d - e * e / (d * d));
        (b, b1, b2)
    }
}

/// Static obstacles compiled for the barrier path.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BarrierObstacles {
    /// Unit normals, `planes × dim`.
    pub plane_normals: Vec<f64>,
    /// Offsets along the unit normals.
    pub plane_offsets: Vec<f64>,
    /// Authored obstacle index per plane.
    pub plane_source: Vec<u32>,
    /// Simplex vertices, `SIMPLEX_SLOTS × dim` per simplex (unused slots 0).
    pub simplex_vertices: Vec<f64>,
    /// Vertices per simplex (2, 3 or 4).
    pub simplex_arity: Vec<u32>,
    /// (authored obstacle index, simplex index within it) per simplex.
    pub simplex_source: Vec<(u32, u32)>,
    /// Largest |plane offset| or |simplex vertex coordinate| (0 with none):
    /// the scale of the rounding error of a computed distance.
    pub scale: f64,
    /// The hierarchy over the simplices' boxes (simplex indices as here).
    pub hierarchy: SimplexHierarchy,
}

/// Vertex slots stored per simplex.
pub const SIMPLEX_SLOTS: usize = 4;

impl BarrierObstacles {
    /// Number of planes.
    pub fn plane_count(&self) -> usize {
        self.plane_offsets.len()
    }

    /// Number of simplices.
    pub fn simplex_count(&self) -> usize {
        self.simplex_arity.len()
    }

    /// Planes plus simplices.
    pub fn len(&self) -> usize {
        self.plane_count() + self.simplex_count()
    }

    /// True with no obstacle at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The vertices (flat, arity × dim) of simplex `s`.
    pub fn simplex(&self, s: usize, dim: usize) -> &[f64] {
        let start = s * SIMPLEX_SLOTS * dim;
        &self.simplex_vertices[start..start + self.simplex_arity[s] as usize * dim]
    }

    /// The boxes (lo, hi) of every simplex, in order.
    pub fn simplex_boxes(&self, dim: usize) -> Vec<f64> {
        let mut boxes = Vec::with_capacity(self.simplex_count() * 2 * dim);
        for s in 0..self.simplex_count() {
            push_box(&mut boxes, self.simplex(s, dim), dim);
        }
        boxes
    }

    /// True when `hierarchy` indexes as many simplices as there are (as
    /// [`BarrierObstacles::compile`] builds it). A set assembled or edited
    /// by hand is indexed again by [`BarrierObstacles::reindex`]; until then
    /// [`BarrierObstacles::near`] visits every simplex.
    pub fn is_indexed(&self) -> bool {
        self.hierarchy.simplex_count() == self.simplex_count()
    }

    /// Builds `hierarchy` anew over the current simplices.
    pub fn reindex(&mut self, dim: usize) {
        self.hierarchy = SimplexHierarchy::from_boxes(dim, &self.simplex_boxes(dim));
    }

    /// The obstacle slots to visit for the candidate box `[lo, hi]`
    /// ([`candidate_box`]): every plane, then the simplices whose boxes
    /// overlap it, in index order (every simplex when the set is not
    /// indexed: [`BarrierObstacles::is_indexed`]).
    pub fn near<'a>(&'a self, lo: &'a [f64], hi: &'a [f64]) -> Near<'a> {
        let indexed = self.is_indexed();
        Near {
            planes: 0..self.plane_count(),
            simplices: indexed.then(|| self.hierarchy.walk(lo, hi)),
            every: 0..if indexed { 0 } else { self.simplex_count() },
        }
    }

    /// The first obstacle slot (planes, then simplices) at distance d ≤ 0
    /// or NaN from a particle at `x` with radius `radius`, with d: only
    /// simplices within reach 0 of the candidate box can be one.
    pub fn first_infeasible(&self, x: &[f64], radius: f64) -> Option<(usize, f64)> {
        let dim = x.len();
        let mut normal = [0.0f64; crate::MAX_DIM];
        let (mut lo, mut hi) = ([0.0f64; crate::MAX_DIM], [0.0f64; crate::MAX_DIM]);
        let (lo, hi) = (&mut lo[..dim], &mut hi[..dim]);
        let margin = distance_margin(dim, f64::EPSILON);
        candidate_box(x, radius, 0.0, self.scale, margin, lo, hi);
        self.near(lo, hi).find_map(|o| {
            let distance = self.distance(o, x, radius, &mut normal[..dim]);
            (distance.is_nan() || distance <= 0.0).then_some((o, distance))
        })
    }

    /// Authored obstacle index of obstacle slot `o` (planes first).
    pub fn source(&self, o: usize) -> u32 {
        if o < self.plane_count() {
            self.plane_source[o]
        } else {
            self.simplex_source[o - self.plane_count()].0
        }
    }

    /// Signed distance d = dist − radius from `x` to obstacle slot `o`
    /// (planes first, then simplices); writes ∇d into `normal`.
    pub fn distance(&self, o: usize, x: &[f64], radius: f64, normal: &mut [f64]) -> f64 {
        let dim = x.len();
        if o < self.plane_count() {
            let n = &self.plane_normals[o * dim..(o + 1) * dim];
            normal.copy_from_slice(n);
            let mut dot = 0.0;
            for a in 0..dim {
                dot += n[a] * x[a];
            }
            dot - self.plane_offsets[o] - radius
        } else {
            let s = o - self.plane_count();
            let closest = closest_point_on_simplex(x, self.simplex(s, dim), dim, normal);
            if closest.distance > 0.0 {
                for c in normal.iter_mut() {
                    *c /= closest.distance;
                }
            }
            closest.distance - radius
        }
    }
}

/// The obstacle slots of [`BarrierObstacles::near`].
#[derive(Debug, Clone)]
pub struct Near<'a> {
    planes: std::ops::Range<usize>,
    simplices: Option<OrderedWalk<'a, WALK_BATCH>>,
    every: std::ops::Range<usize>,
}

impl Iterator for Near<'_> {
    type Item = usize;

    fn next(&mut self) -> Option<usize> {
        let planes = self.planes.end;
        if let Some(o) = self.planes.next() {
            return Some(o);
        }
        match self.simplices.as_mut() {
            Some(walk) => walk.next().map(|s| planes + s as usize),
            None => self.every.next().map(|s| planes + s),
        }
    }
}

/// M = 16 N (N + 4) ε: the candidate box's relative pad where computed
/// distances decide (evaluation, the step filter, feasibility; module docs).
pub fn distance_margin(dim: usize, epsilon: f64) -> f64 {
    16.0 * dim as f64 * (dim as f64 + 4.0) * epsilon
}

/// M = 4 √(N (N + 4) ε): the relative pad where the certified filter's
/// support bound decides (module docs).
pub fn support_margin(dim: usize, epsilon: f64) -> f64 {
    4.0 * (dim as f64 * (dim as f64 + 4.0) * epsilon).sqrt()
}

/// The filters' reach |Δ| (1 + γ)/η, γ = (N + 4) ε, from |Δ| = `length`.
pub fn filter_reach(length: f64, dim: usize, epsilon: f64) -> f64 {
    length * (1.0 + (dim as f64 + 4.0) * epsilon) / FILTER_SAFETY
}

/// The candidate box x ± (r + reach + pad) of a particle at `x` with
/// radius `radius` into `lo`, `hi`, with pad = `margin` (‖x‖∞ + G + r +
/// reach) and G = `scale` (module docs); ±f64::MAX on every axis when some
/// bound is not finite (every simplex is then visited).
pub fn candidate_box(
    x: &[f64],
    radius: f64,
    reach: f64,
    scale: f64,
    margin: f64,
    lo: &mut [f64],
    hi: &mut [f64],
) {
    let dim = x.len();
    let mut largest: f64 = 0.0;
    for a in 0..dim {
        largest = largest.max(x[a].abs());
    }
    let extent = radius + reach;
    let half = extent + margin * (largest + scale + extent);
    let mut finite = half <= f64::MAX;
    for a in 0..dim {
        lo[a] = x[a] - half;
        hi[a] = x[a] + half;
        finite &= lo[a].abs() <= f64::MAX && hi[a].abs() <= f64::MAX;
    }
    if !finite {
        lo[..dim].fill(-f64::MAX);
        hi[..dim].fill(f64::MAX);
    }
}

/// Barrier energy, gradient and PSD-projected Hessian block of one particle.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleBarrier {
    /// Σ b over obstacles (+∞ if some d ≤ 0).
    pub energy: f64,
    /// Σ b' ∇d (length dim).
    pub gradient: Vec<f64>,
    /// Σ b'' n nᵀ (dim × dim, row-major).
    pub hessian: Vec<f64>,
    /// Smallest d over all obstacles, capped at d^ (min(d, d^): simplices
    /// beyond d^ are not visited).
    pub min_distance: f64,
    /// Σ |b'| over the active obstacles: how fast the energy moves with
    /// distance (the rounding floor of an energy difference scales with it).
    pub force_sum: f64,
}

impl ParticleBarrier {
    /// Zeroed storage for dimension `dim`.
    pub fn new(dim: usize) -> Self {
        ParticleBarrier {
            energy: 0.0,
            gradient: vec![0.0; dim],
            hessian: vec![0.0; dim * dim],
            min_distance: f64::INFINITY,
            force_sum: 0.0,
        }
    }
}

/// Evaluates every obstacle's barrier at `x` (particle radius `radius`)
/// and sums them in obstacle order (planes, then simplices).
pub fn evaluate_particle_barrier(
    law: &BarrierLaw,
    obstacles: &BarrierObstacles,
    x: &[f64],
    radius: f64,
    out: &mut ParticleBarrier,
) {
    let dim = x.len();
    out.energy = 0.0;
    out.gradient.fill(0.0);
    out.hessian.fill(0.0);
    out.min_distance = f64::INFINITY;
    out.force_sum = 0.0;
    let mut n = [0.0f64; crate::MAX_DIM];
    let n = &mut n[..dim];
    let (mut lo, mut hi) = ([0.0f64; crate::MAX_DIM], [0.0f64; crate::MAX_DIM]);
    let (lo, hi) = (&mut lo[..dim], &mut hi[..dim]);
    let reach = law.activation_distance;
    let margin = distance_margin(dim, f64::EPSILON);
    candidate_box(x, radius, reach, obstacles.scale, margin, lo, hi);
    for o in obstacles.near(lo, hi) {
        let d = obstacles.distance(o, x, radius, n);
        out.min_distance = out.min_distance.min(d);
        if d >= law.activation_distance {
            continue;
        }
        let (b, b1, b2) = law.evaluate(d);
        out.energy += b;
        out.force_sum += b1.abs();
        for a in 0..dim {
            out.gradient[a] += b1 * n[a];
            for c in 0..dim {
                out.hessian[a * dim + c] += b2 * n[a] * n[c];
            }
        }
    }
    out.min_distance = out.min_distance.min(law.activation_distance);
}

/// Certified admissible fraction of the step `delta` from `x`: see the
/// module docs. 1 when nothing limits it; 0 if `x` is not feasible.
pub fn filter_fraction(obstacles: &BarrierObstacles, x: &[f64], radius: f64, delta: &[f64]) -> f64 {
    let dim = x.len();
    let mut n = [0.0f64; crate::MAX_DIM];
    let n = &mut n[..dim];
    let length = delta.iter().map(|c| c * c).sum::<f64>().sqrt();
    let (mut lo, mut hi) = ([0.0f64; crate::MAX_DIM], [0.0f64; crate::MAX_DIM]);
    let (lo, hi) = (&mut lo[..dim], &mut hi[..dim]);
    let reach = filter_reach(length, dim, f64::EPSILON);
    let margin = distance_margin(dim, f64::EPSILON);
    candidate_box(x, radius, reach, obstacles.scale, margin, lo, hi);
    let mut t = f64::INFINITY;
    for o in obstacles.near(lo, hi) {
        let d0 = obstacles.distance(o, x, radius, n);
        if d0 <= 0.0 {
            return 0.0;
        }
        let approach = if o < obstacles.plane_count() {
            -(0..dim).map(|a| n[a] * delta[a]).sum::<f64>()
        } else {
            length
        };
        if approach > 0.0 {
            t = t.min(d0 / approach);
        }
    }
    (FILTER_SAFETY * t).min(1.0)
}

impl BarrierObstacles {
    /// Every obstacle of `scene` in barrier form: hyperplanes with unit
    /// normals (planes first, in authored order), then every simplex of
    /// every simplex mesh (authored order). This is the one place obstacle
    /// geometry is laid out for the barrier path; backends upload it as is.
    pub fn compile(scene: &Scene) -> BarrierObstacles {
        let dim = scene.dim;
        let mut out = BarrierObstacles::default();
        let mut scale: f64 = 0.0;
        for (o, obstacle) in scene.obstacles.iter().enumerate() {
            match obstacle {
                Obstacle::Hyperplane { normal, offset, .. } => {
                    out.plane_normals.extend(unit_vector(normal));
                    out.plane_offsets.push(*offset);
                    scale = scale.max(offset.abs());
                    out.plane_source.push(o as u32);
                }
                Obstacle::SimplexMesh {
                    vertices,
                    simplices,
                    ..
                } => scale = scale.max(out.push_mesh(dim, o, vertices, simplices)),
            }
        }
        out.scale = scale;
        out.reindex(dim);
        out
    }

    /// The simplices of one mesh, authored obstacle `o`, alone (the XPBD
    /// path's mesh contact: `kinds::mesh_contact`), indexed.
    pub fn mesh(dim: usize, o: usize, vertices: &[Vec<f64>], simplices: &[Vec<usize>]) -> Self {
        let mut out = BarrierObstacles::default();
        out.scale = out.push_mesh(dim, o, vertices, simplices);
        out.reindex(dim);
        out
    }

    /// Appends the simplices of mesh `o`; returns their largest |coordinate|.
    fn push_mesh(
        &mut self,
        dim: usize,
        o: usize,
        vertices: &[Vec<f64>],
        simplices: &[Vec<usize>],
    ) -> f64 {
        let mut scale: f64 = 0.0;
        for (s, simplex) in simplices.iter().enumerate() {
            for slot in 0..SIMPLEX_SLOTS {
                match simplex.get(slot) {
                    Some(&v) => self.simplex_vertices.extend(&vertices[v]),
                    None => self.simplex_vertices.extend(std::iter::repeat_n(0.0, dim)),
                }
            }
            for &v in simplex {
                scale = vertices[v].iter().fold(scale, |m, c| m.max(c.abs()));
            }
            self.simplex_arity.push(simplex.len() as u32);
            self.simplex_source.push((o as u32, s as u32));
        }
        scale
    }
}
