//! The simplex hierarchy (core/src/geometry/simplex_hierarchy.rs) against
//! its oracle, the exhaustive scan, on random meshes in R^2…R^5 with a
//! fixed seed: the candidate list of every query box is exactly the
//! exhaustive one (identity and order), by `query`, by the allocation-free
//! walk at the GPU's batch size and at batch sizes 1, 2, 3 (many refills),
//! by `gather` (the same set; `None` into a slice one too short), and
//! after a refit; degenerate meshes included (coincident vertices,
//! zero-extent boxes, one simplex). Then the barrier path: every barrier
//! term, filter fraction and certified time computed over the hierarchy's
//! candidates is bit for bit the one over every simplex.

use hyperpbd::core::barrier::{
    BarrierLaw, BarrierObstacles, ParticleBarrier, candidate_box, distance_margin,
    evaluate_particle_barrier, filter_fraction, filter_reach,
};
use hyperpbd::core::geometry::SimplexHierarchy;
use hyperpbd::core::geometry::simplex_hierarchy::{NODE_WORDS, OrderedWalk, overlaps, push_box};
use hyperpbd::core::implicit::certified_filter::{
    TrialMove, fraction, obstacle_time, plane_time, simplex_time,
};
use hyperpbd::{Obstacle, Scene};

/// SplitMix64: a fixed, dependency-free stream.
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

/// A random mesh: `count` simplices of `arity` vertices over a vertex pool
/// that repeats some vertices (coincident vertices) and, with `collapse`,
/// simplices whose vertices all coincide (zero-extent boxes).
fn random_mesh(
    rng: &mut Stream,
    dim: usize,
    count: usize,
    arity: usize,
    collapse: bool,
) -> (Vec<Vec<f64>>, Vec<Vec<usize>>) {
    let pool = 3 + rng.below(3 * count + 3);
    let mut vertices: Vec<Vec<f64>> = Vec::with_capacity(pool);
    for v in 0..pool {
        if v > 0 && rng.below(5) == 0 {
            let copy = vertices[rng.below(v)].clone();
            vertices.push(copy);
        } else {
            vertices.push((0..dim).map(|_| rng.range(-2.0, 2.0)).collect());
        }
    }
    let simplices = (0..count)
        .map(|_| {
            if collapse && rng.below(4) == 0 {
                vec![rng.below(pool); arity]
            } else {
                (0..arity).map(|_| rng.below(pool)).collect()
            }
        })
        .collect();
    (vertices, simplices)
}

/// A random query box: a point, a small or large box, an inverted (empty)
/// one, or the whole space.
fn random_box(rng: &mut Stream, dim: usize) -> (Vec<f64>, Vec<f64>) {
    let centre: Vec<f64> = (0..dim).map(|_| rng.range(-2.5, 2.5)).collect();
    let half = match rng.below(6) {
        0 => 0.0,
        1 => -0.1,
        2 => f64::INFINITY,
        3 => rng.range(0.0, 3.0),
        _ => rng.range(0.0, 0.5),
    };
    let lo = centre.iter().map(|c| c - half).collect();
    let hi = centre.iter().map(|c| c + half).collect();
    (lo, hi)
}

/// Height of the tree below node `n`.
fn height(tree: &SimplexHierarchy, n: usize) -> usize {
    let w = &tree.node_words()[n * NODE_WORDS..(n + 1) * NODE_WORDS];
    if w[1] == w[2] {
        return 0;
    }
    1 + height(tree, n + 1).max(height(tree, w[0] as usize))
}

fn walked<const K: usize>(tree: &SimplexHierarchy, lo: &[f64], hi: &[f64]) -> Vec<u32> {
    OrderedWalk::<K>::new(tree, lo, hi).collect()
}

/// `gather` into a slice of `room`, sorted (it hands out walk order).
fn gathered(tree: &SimplexHierarchy, lo: &[f64], hi: &[f64], room: usize) -> Option<Vec<u32>> {
    let mut out = vec![u32::MAX; room];
    let count = tree.gather(lo, hi, &mut out)?;
    out.truncate(count);
    out.sort_unstable();
    Some(out)
}

#[test]
fn candidates_are_the_exhaustive_list_in_every_dimension() {
    let mut rng = Stream(0x5eed_0031);
    let (mut got, mut expected) = (Vec::new(), Vec::new());
    let mut nonempty = 0;
    let mut queries = 0;
    for dim in 2..=5 {
        for case in 0..40 {
            let count = match case {
                0 => 1,
                1 => 2,
                _ => 1 + rng.below(400),
            };
            let arity = 1 + rng.below(dim + 1);
            let (vertices, simplices) = random_mesh(&mut rng, dim, count, arity, case % 3 == 0);
            let tree = SimplexHierarchy::build(dim, &vertices, &simplices);
            assert_eq!(tree, SimplexHierarchy::build(dim, &vertices, &simplices));
            assert_eq!(tree.node_count(), 2 * count - 1);
            let depth = (count as f64).log2().ceil() as usize;
            assert!(height(&tree, 0) <= depth, "dim {dim} case {case}: too deep");
            for (s, simplex) in simplices.iter().enumerate() {
                let points: Vec<f64> = simplex.iter().flat_map(|&v| vertices[v].clone()).collect();
                let mut b = Vec::new();
                push_box(&mut b, &points, dim);
                assert_eq!(tree.simplex_box(s), &b[..]);
            }
            for _ in 0..30 {
                let (lo, hi) = random_box(&mut rng, dim);
                tree.exhaustive(&lo, &hi, &mut expected);
                let oracle: Vec<u32> = (0..count as u32)
                    .filter(|&s| overlaps(tree.simplex_box(s as usize), &lo, &hi))
                    .collect();
                assert_eq!(expected, oracle);
                let visited = tree.query(&lo, &hi, &mut got);
                assert!(visited <= tree.node_count());
                let at = format!("dim {dim} case {case} box {lo:?}..{hi:?}");
                assert_eq!(got, expected, "query, {at}");
                assert_eq!(
                    tree.walk(&lo, &hi).collect::<Vec<_>>(),
                    expected,
                    "walk, {at}"
                );
                assert_eq!(walked::<1>(&tree, &lo, &hi), expected, "walk 1, {at}");
                assert_eq!(walked::<2>(&tree, &lo, &hi), expected, "walk 2, {at}");
                assert_eq!(walked::<3>(&tree, &lo, &hi), expected, "walk 3, {at}");
                assert_eq!(gathered(&tree, &lo, &hi, count), Some(expected.clone()));
                if !expected.is_empty() {
                    let short = gathered(&tree, &lo, &hi, expected.len() - 1);
                    assert_eq!(short, None, "gather into too short a slice, {at}");
                }
                nonempty += usize::from(!expected.is_empty() && expected.len() < count);
                queries += 1;
            }
            // Refit onto moved boxes: same topology, exact answers.
            let moved: Vec<Vec<f64>> = vertices
                .iter()
                .map(|v| v.iter().map(|c| 1.5 * c + rng.range(-0.3, 0.3)).collect())
                .collect();
            let mut boxes = Vec::new();
            for simplex in &simplices {
                let points: Vec<f64> = simplex.iter().flat_map(|&v| moved[v].clone()).collect();
                push_box(&mut boxes, &points, dim);
            }
            let refit = tree.refit(&boxes);
            assert_eq!(refit.node_words(), tree.node_words());
            for _ in 0..10 {
                let (lo, hi) = random_box(&mut rng, dim);
                refit.exhaustive(&lo, &hi, &mut expected);
                refit.query(&lo, &hi, &mut got);
                assert_eq!(got, expected, "refit query, dim {dim} case {case}");
                assert_eq!(refit.walk(&lo, &hi).collect::<Vec<_>>(), expected);
            }
        }
    }
    assert!(
        nonempty > queries / 4,
        "{nonempty} of {queries} queries selected a proper subset"
    );
}

#[test]
fn an_empty_mesh_has_no_candidates() {
    let tree = SimplexHierarchy::build(3, &[], &[]);
    let (lo, hi) = (vec![-f64::MAX; 3], vec![f64::MAX; 3]);
    let mut out = vec![7];
    assert_eq!(tree.query(&lo, &hi, &mut out), 0);
    assert!(out.is_empty());
    assert_eq!(tree.walk(&lo, &hi).count(), 0);
    assert_eq!(tree.gather(&lo, &hi, &mut []), Some(0));
}

/// A scene with one plane and one random mesh of non-degenerate
/// k-simplices (k = arity − 1 ≤ min(3, N)) in R^dim.
fn barrier_scene(rng: &mut Stream, dim: usize, count: usize) -> Scene {
    let arity = 2 + rng.below(dim.min(3));
    let mut vertices = Vec::new();
    let mut simplices = Vec::new();
    for _ in 0..count {
        let base: Vec<f64> = (0..dim).map(|_| rng.range(-1.5, 1.5)).collect();
        let mut simplex = Vec::new();
        for _ in 0..arity {
            simplex.push(vertices.len());
            vertices.push(base.iter().map(|c| c + rng.range(-0.3, 0.3)).collect());
        }
        simplices.push(simplex);
    }
    let mut scene = Scene::new(dim, 0.01, 1, 1);
    let mut normal = vec![0.0; dim];
    normal[dim - 1] = 1.0;
    scene.obstacles.push(Obstacle::Hyperplane {
        normal,
        offset: -2.0,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: 0.0,
        motion: Vec::new(),
    });
    scene
}

#[test]
fn barrier_terms_over_the_candidates_are_the_exhaustive_ones_bit_for_bit() {
    let mut rng = Stream(0xba55_0031);
    let law = BarrierLaw {
        stiffness: 10.0,
        activation_distance: 0.05,
    };
    let mut n = [0.0; 8];
    let mut offset = [0.0; 8];
    let (mut active, mut cut, mut skipped) = (0, 0, 0);
    for dim in 2..=5 {
        for _ in 0..6 {
            let count = 1 + rng.below(120);
            let scene = barrier_scene(&mut rng, dim, count);
            let obstacles = BarrierObstacles::compile(&scene);
            let mut terms = ParticleBarrier::new(dim);
            for _ in 0..200 {
                let x: Vec<f64> = (0..dim).map(|_| rng.range(-2.0, 2.0)).collect();
                let r = rng.range(0.0, 0.02);
                let length = [0.0, 0.01, 0.1, 1.0][rng.below(4)];
                let delta: Vec<f64> = (0..dim).map(|_| length * rng.range(-1.0, 1.0)).collect();
                let trial_move = TrialMove {
                    x: &x,
                    radius: r,
                    delta: &delta,
                };
                // The exhaustive sums, in slot order.
                let mut energy = 0.0;
                let mut gradient = vec![0.0; dim];
                let mut hessian = vec![0.0; dim * dim];
                let mut smallest = f64::INFINITY;
                let mut force = 0.0;
                let mut feasible = true;
                let step = delta.iter().map(|c| c * c).sum::<f64>().sqrt();
                let mut t_old = f64::INFINITY;
                let mut t_certified = f64::INFINITY;
                for o in 0..obstacles.len() {
                    let d = obstacles.distance(o, &x, r, &mut n[..dim]);
                    smallest = smallest.min(d);
                    feasible &= d > 0.0;
                    let approach = if o < obstacles.plane_count() {
                        -(0..dim).map(|a| n[a] * delta[a]).sum::<f64>()
                    } else {
                        step
                    };
                    if approach > 0.0 {
                        t_old = t_old.min(d / approach);
                    }
                    t_certified = t_certified.min(if o < obstacles.plane_count() {
                        plane_time(&obstacles, o, trial_move, f64::EPSILON)
                    } else {
                        let s = o - obstacles.plane_count();
                        simplex_time(&obstacles, s, trial_move, f64::EPSILON, &mut offset[..dim])
                    });
                    if d >= law.activation_distance {
                        continue;
                    }
                    let (b, b1, b2) = law.evaluate(d);
                    energy += b;
                    force += b1.abs();
                    for a in 0..dim {
                        gradient[a] += b1 * n[a];
                        for c in 0..dim {
                            hessian[a * dim + c] += b2 * n[a] * n[c];
                        }
                    }
                    active += usize::from(o >= obstacles.plane_count());
                }
                evaluate_particle_barrier(&law, &obstacles, &x, r, &mut terms);
                let at = format!("dim {dim} x {x:?}");
                assert_eq!(terms.energy.to_bits(), energy.to_bits(), "energy, {at}");
                assert_eq!(terms.force_sum.to_bits(), force.to_bits(), "force, {at}");
                let bits = |v: &[f64]| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&terms.gradient), bits(&gradient), "gradient, {at}");
                assert_eq!(bits(&terms.hessian), bits(&hessian), "hessian, {at}");
                let capped = smallest.min(law.activation_distance);
                assert_eq!(
                    terms.min_distance.to_bits(),
                    capped.to_bits(),
                    "distance, {at}"
                );
                let old = if feasible {
                    (0.9 * t_old).min(1.0)
                } else {
                    0.0
                };
                let got = filter_fraction(&obstacles, &x, r, &delta);
                assert_eq!(got.to_bits(), old.to_bits(), "filter, {at}");
                let certified = obstacle_time(&obstacles, trial_move, f64::EPSILON);
                assert_eq!(
                    fraction(certified).to_bits(),
                    fraction(t_certified).to_bits(),
                    "certified filter, {at}"
                );
                cut += usize::from(old < 1.0 && old > 0.0);
                // How much the hierarchy skipped at the evaluation's reach.
                let (mut lo, mut hi) = (vec![0.0; dim], vec![0.0; dim]);
                let reach = law
                    .activation_distance
                    .max(filter_reach(step, dim, f64::EPSILON));
                candidate_box(
                    &x,
                    r,
                    reach,
                    obstacles.scale,
                    distance_margin(dim, f64::EPSILON),
                    &mut lo,
                    &mut hi,
                );
                skipped += obstacles.simplex_count() - obstacles.hierarchy.walk(&lo, &hi).count();
            }
        }
    }
    eprintln!("{active} active simplex terms, {cut} filters cut, {skipped} simplices skipped");
    assert!(
        active > 100 && cut > 100 && skipped > 10_000,
        "{active} {cut} {skipped}"
    );
}

/// A set assembled by hand (no hierarchy over its simplices) visits every
/// simplex until `reindex`, then the walk's candidates.
#[test]
fn an_unindexed_set_visits_every_simplex_until_reindexed() {
    let mut obstacles = BarrierObstacles {
        plane_normals: vec![0.0, 1.0],
        plane_offsets: vec![-5.0],
        plane_source: vec![0],
        ..BarrierObstacles::default()
    };
    for s in 0..3 {
        let x = 10.0 * s as f64;
        obstacles
            .simplex_vertices
            .extend([x, 0.0, x + 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        obstacles.simplex_arity.push(2);
        obstacles.simplex_source.push((1, s));
    }
    let (lo, hi) = ([-0.5, -0.5], [0.5, 0.5]);
    assert!(!obstacles.is_indexed());
    assert_eq!(obstacles.near(&lo, &hi).collect::<Vec<_>>(), [0, 1, 2, 3]);
    obstacles.reindex(2);
    assert!(obstacles.is_indexed());
    assert_eq!(obstacles.near(&lo, &hi).collect::<Vec<_>>(), [0, 1]);
}
