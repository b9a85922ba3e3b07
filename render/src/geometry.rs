//! What is drawn, taken from the scene: edges, hyperplanes, per-element
//! residuals; and the convex clipping the hyperplane drawings need.
//!
//! ```text
//! edges        distance element (i, j)            → edge i–j
//!              simplex / oriented element x0 … xk → all k(k+1)/2 edges
//!              (deduplicated, sorted by (i, j))
//! residual     r = |C(x) − rest| / scale           (relative violation)
//!              scale = |rest|, or where rest = 0: L, L^(2k), L^N for distance,
//!              squared k-measure, oriented N-measure (L: scene extent)
//!              contact: r = max(0, offset + radius − n·x) / L
//! particle r   max over the elements and contacts touching it
//! edge r       max over the elements containing it
//! edge weight  (ℓ_min / ℓ_e)^1.5 clamped to [0.3, 1], ℓ: authored length,
//!              ℓ_min: the shortest nonzero edge: lattice edges strong,
//!              diagonals of triangulated cells (√2, √3, 2 × longer: 0.59,
//!              0.44, 0.35) fainter, so a Kuhn block still reads as a grid
//! clipping     Sutherland–Hodgman against one half-space at a time:
//!              keep n·p ≤ k; an edge crossing it gets the crossing point
//! ```

use glam::{DVec2, DVec3};
use hyperpbd_core::expr::Columns;
use hyperpbd_core::geometry::Scratch;
use hyperpbd_core::kinds::{self, ExpressionKind};
use hyperpbd_core::motion::{Motion, rigid_at};
use hyperpbd_core::{ConstraintKind, Obstacle, Scene, State};

/// A hyperplane n·x = offset with unit n; n·x < offset + r is excluded.
/// With a motion it is drawn where the physics has it at the snapshot's
/// time ([`Plane::at`]).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Plane {
    pub normal: Vec<f64>,
    pub offset: f64,
    pub motion: Vec<Motion>,
}

impl Plane {
    /// (n(t), offset(t)) at time `t`, by core's motion evaluation (the
    /// function every backend takes its planes from):
    /// n(t) = R(t) n̂,  offset(t) = offset + n(t)·b(t).
    pub fn at(&self, t: f64) -> (Vec<f64>, f64) {
        if self.motion.is_empty() {
            return (self.normal.clone(), self.offset);
        }
        let m = rigid_at(&self.motion, self.normal.len(), t);
        let normal = m.rotate(&self.normal);
        let shift: f64 = normal.iter().zip(&m.translation).map(|(n, b)| n * b).sum();
        (normal, self.offset + shift)
    }
}

/// The elements of one constraint family, for residuals.
#[derive(Debug, Clone)]
struct Elements {
    kind: ConstraintKind,
    /// An expression family's compiled value.
    expression: Option<ExpressionKind>,
    arity: usize,
    /// Particle indices, `arity` per element.
    particles: Vec<usize>,
    rest: Vec<f64>,
    scale: Vec<f64>,
    /// Edge indices, `arity (arity − 1) / 2` per element.
    edges: Vec<usize>,
}

/// Everything the drawing needs from the scene.
#[derive(Debug, Clone)]
pub(crate) struct SceneGeometry {
    pub dim: usize,
    pub radius: Vec<f64>,
    pub fixed: Vec<bool>,
    /// Edges (i < j), sorted.
    pub edges: Vec<(usize, usize)>,
    /// Opacity weight per edge in [0.3, 1] (see the module docs).
    pub edge_weight: Vec<f64>,
    pub planes: Vec<Plane>,
    /// Scene length scale L.
    pub length: f64,
    families: Vec<Elements>,
}

fn pairs(element: &[usize]) -> impl Iterator<Item = (usize, usize)> + '_ {
    element
        .iter()
        .enumerate()
        .flat_map(move |(a, &i)| element[a + 1..].iter().map(move |&j| (i.min(j), i.max(j))))
}

impl SceneGeometry {
    /// Reads a validated scene.
    pub fn new(scene: &Scene) -> SceneGeometry {
        let dim = scene.dim;
        let length = scene.extent();
        let mut edges: Vec<(usize, usize)> = scene
            .constraints
            .iter()
            .flat_map(|f| f.elements.iter())
            .flat_map(|e| pairs(e).collect::<Vec<_>>())
            .filter(|(i, j)| i != j)
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let edge_index = |pair: (usize, usize)| edges.binary_search(&pair).ok();
        let mut scratch = Scratch::new();
        let mut families = Vec::new();
        let mut columns = Columns::new();
        for (f, family) in scene.constraints.iter().enumerate() {
            let Some(arity) = family.elements.first().map(Vec::len) else {
                continue;
            };
            // The scene is validated: its expressions compile.
            let position = |i: usize| scene.particles[i].position.as_slice();
            let Ok(expression) = kinds::expression_of(f, family, arity, dim, position) else {
                continue;
            };
            let particles: Vec<usize> = family.elements.iter().flatten().copied().collect();
            let mut points = vec![0.0; arity * dim];
            let mut grad = vec![0.0; arity * dim];
            let rest: Vec<f64> = match &family.rest {
                Some(rest) => rest.clone(),
                None => particles
                    .chunks_exact(arity)
                    .enumerate()
                    .map(|(e, element)| {
                        for (j, &i) in element.iter().enumerate() {
                            points[j * dim..(j + 1) * dim]
                                .copy_from_slice(&scene.particles[i].position);
                        }
                        match &expression {
                            Some(kind) => kind.default_rest(e, &points, &mut columns),
                            None => {
                                kinds::value(family.kind, &points, dim, &mut grad, &mut scratch)
                            }
                        }
                    })
                    .collect(),
            };
            let power = match family.kind {
                ConstraintKind::Distance | ConstraintKind::Tether => 1,
                ConstraintKind::SimplexMeasure => 2 * (arity - 1),
                ConstraintKind::OrientedMeasure => dim,
                // No geometric value (rest 0, value 0): drawn unstrained.
                ConstraintKind::Stvk | ConstraintKind::NeoHookean => 1,
                // Units unknown: relative to the rest value, or to length.
                ConstraintKind::Expression | ConstraintKind::Bending => 1,
            };
            let fallback = length.powi(power as i32);
            let scale = rest
                .iter()
                .map(|r| if *r != 0.0 { r.abs() } else { fallback })
                .collect();
            let element_edges = particles
                .chunks_exact(arity)
                .flat_map(|element| {
                    pairs(element)
                        .filter(|(i, j)| i != j)
                        .filter_map(edge_index)
                        .collect::<Vec<_>>()
                })
                .collect();
            families.push(Elements {
                kind: family.kind,
                expression,
                arity,
                particles,
                rest,
                scale,
                edges: element_edges,
            });
        }
        let planes = scene
            .obstacles
            .iter()
            .filter_map(|o| {
                let Obstacle::Hyperplane {
                    normal,
                    offset,
                    motion,
                    ..
                } = o
                else {
                    return None;
                };
                let length = normal.iter().map(|x| x * x).sum::<f64>().sqrt();
                Some(Plane {
                    normal: normal.iter().map(|x| x / length).collect(),
                    offset: *offset,
                    motion: motion.clone(),
                })
            })
            .collect();
        let lengths: Vec<f64> = edges
            .iter()
            .map(|&(i, j)| {
                let (a, b) = (&scene.particles[i].position, &scene.particles[j].position);
                a.iter()
                    .zip(b)
                    .map(|(x, y)| (x - y) * (x - y))
                    .sum::<f64>()
                    .sqrt()
            })
            .collect();
        let shortest = lengths
            .iter()
            .copied()
            .filter(|&l| l > 0.0)
            .fold(f64::INFINITY, f64::min);
        let edge_weight = lengths
            .iter()
            .map(|&l| {
                if l > 0.0 && shortest.is_finite() {
                    (shortest / l).powf(1.5).clamp(0.3, 1.0)
                } else {
                    1.0
                }
            })
            .collect();
        SceneGeometry {
            dim,
            edge_weight,
            radius: scene.particles.iter().map(|p| p.radius).collect(),
            fixed: scene.particles.iter().map(|p| p.fixed).collect(),
            edges,
            planes,
            length,
            families,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.radius.len()
    }

    /// Relative residual per particle and per edge (see the module docs),
    /// the planes where they are at `time`.
    pub fn residuals(&self, state: &State, time: f64) -> (Vec<f64>, Vec<f64>) {
        let dim = self.dim;
        let mut particle = vec![0.0f64; self.len()];
        let mut edge = vec![0.0f64; self.edges.len()];
        let mut columns = Columns::new();
        let mut scratch = Scratch::new();
        for f in &self.families {
            let per_element_edges = f.arity * (f.arity - 1) / 2;
            let mut points = vec![0.0; f.arity * dim];
            let mut grad = vec![0.0; f.arity * dim];
            for (e, element) in f.particles.chunks_exact(f.arity).enumerate() {
                for (j, &i) in element.iter().enumerate() {
                    points[j * dim..(j + 1) * dim].copy_from_slice(state.position(i));
                }
                let c = match &f.expression {
                    Some(kind) => kind.value_at(e, &points, &mut columns),
                    None => kinds::value(f.kind, &points, dim, &mut grad, &mut scratch),
                };
                let r = ((c - f.rest[e]) / f.scale[e]).abs();
                let r = if r.is_nan() { f64::INFINITY } else { r };
                for &i in element {
                    particle[i] = particle[i].max(r);
                }
                let edges = f
                    .edges
                    .get(e * per_element_edges..(e + 1) * per_element_edges);
                for &k in edges.unwrap_or(&[]) {
                    edge[k] = edge[k].max(r);
                }
            }
        }
        for plane in &self.planes {
            let (normal, offset) = plane.at(time);
            for (i, r) in particle.iter_mut().enumerate() {
                if self.fixed[i] {
                    continue;
                }
                let d: f64 = normal
                    .iter()
                    .zip(state.position(i))
                    .map(|(n, x)| n * x)
                    .sum();
                let penetration = (offset + self.radius[i] - d).max(0.0) / self.length;
                *r = r.max(penetration);
            }
        }
        (particle, edge)
    }
}

/// A point of the picture plane or of the 3D view: what clipping needs.
pub(crate) trait Point: Copy {
    /// Dot product.
    fn dot(self, other: Self) -> f64;
    /// a + t (b − a) (not glam's `lerp`, which rounds as (1 − t) a + t b).
    fn towards(self, b: Self, t: f64) -> Self;
}

impl Point for DVec2 {
    fn dot(self, other: Self) -> f64 {
        DVec2::dot(self, other)
    }
    fn towards(self, b: Self, t: f64) -> Self {
        self + (b - self) * t
    }
}

impl Point for DVec3 {
    fn dot(self, other: Self) -> f64 {
        DVec3::dot(self, other)
    }
    fn towards(self, b: Self, t: f64) -> Self {
        self + (b - self) * t
    }
}

/// The part of the convex polygon `poly` with n·p ≤ k.
pub(crate) fn clip_polygon<P: Point>(poly: &[P], n: P, k: f64) -> Vec<P> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (fa, fb) = (n.dot(a) - k, n.dot(b) - k);
        if fa <= 0.0 {
            out.push(a);
        }
        if (fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0) {
            out.push(a.towards(b, fa / (fa - fb)));
        }
    }
    out
}

/// The part of segment a–b inside every half-space n·p ≤ k (Liang–Barsky).
pub(crate) fn clip_segment<P: Point>(a: P, b: P, halfspaces: &[(P, f64)]) -> Option<(P, P)> {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for &(n, k) in halfspaces {
        let fa = n.dot(a) - k;
        let fb = n.dot(b) - k;
        if fa > 0.0 && fb > 0.0 {
            return None;
        }
        if fa > 0.0 {
            t0 = t0.max(fa / (fa - fb));
        } else if fb > 0.0 {
            t1 = t1.min(fa / (fa - fb));
        }
    }
    (t0 < t1).then(|| (a.towards(b, t0), a.towards(b, t1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clips_square_by_half_plane() {
        let square = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ];
        let lower = clip_polygon(&square, DVec2::Y, 0.25);
        assert_eq!(lower.len(), 4);
        assert!(lower.iter().all(|p| p.y <= 0.25));
        assert!(clip_polygon(&square, DVec2::Y, -1.0).is_empty());
        assert_eq!(clip_polygon(&square, DVec2::ZERO, 1.0).len(), 4);
    }

    #[test]
    fn clips_segment_to_box() {
        let unit = [
            (DVec2::X, 1.0),
            (-DVec2::X, 0.0),
            (DVec2::Y, 1.0),
            (-DVec2::Y, 0.0),
        ];
        let (p, q) = clip_segment(DVec2::new(-1.0, 0.5), DVec2::new(2.0, 0.5), &unit).unwrap();
        assert!((p.x - 0.0).abs() < 1e-12 && (q.x - 1.0).abs() < 1e-12);
        assert!(clip_segment(DVec2::new(-1.0, 2.0), DVec2::new(2.0, 2.0), &unit).is_none());
    }
}
