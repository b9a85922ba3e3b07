//! Partial pivoting with tied pivots, GPU against the golden path.
//!
//! The oriented measure is det(E)/N!, E the edge matrix (column j = x_{j+1} − x_0),
//! and its gradient the adjugate; both eliminate with partial pivoting
//! (`core/src/geometry/linalg.rs`, `shaders/measure.wgsl`). When two rows
//! tie for the largest |entry| of a column, the golden rule takes the first
//! (`|a| > best`, strict); another choice is just as valid mathematically
//! but rounds differently, and no jittered scene ties exactly, so the other
//! GPU tests cannot tell the two rules apart.
//!
//! ```text
//! x_0 = 0, gravity off, v = 0: the first projection sees E exactly
//! E column 0 = ( 0.3, −0.3, 0.1, 0.05 )   rows 0 and 1 tie (|0.3| = |−0.3|)
//! other columns generic, det E > 0, rest 5 % below the measure
//! ```
//! Whole steps (`common::differential::both`): f64 on lavapipe bit for bit
//! from the start, f32 within the per-frame model.

use crate::common;

use common::differential::both;
use hyperpbd::{ConstraintFamily, ConstraintKind, Particle, Scene, SceneBuilder};

/// Edge columns of the simplex in R^dim (dim = 3 or 4): column 0 has a tie
/// between rows 0 and 1 for the largest magnitude.
fn edges(dim: usize) -> Vec<Vec<f64>> {
    let all = [
        [0.3, -0.3, 0.1, 0.05],
        [0.7, 0.2, -0.15, 0.11],
        [0.13, 0.21, 0.6, -0.17],
        [-0.09, 0.14, 0.19, 0.5],
    ];
    all[..dim].iter().map(|c| c[..dim].to_vec()).collect()
}

fn tied_simplex(dim: usize) -> Scene {
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(2)
        .iterations(2);
    let mut simplex = vec![b.particle(Particle::new(vec![0.0; dim], 0.8))];
    for (j, e) in edges(dim).into_iter().enumerate() {
        simplex.push(b.particle(Particle::new(e, 0.5 + 0.25 * j as f64)));
    }
    let mut family = ConstraintFamily::new(ConstraintKind::OrientedMeasure, 0.0, vec![simplex]);
    family.rest = Some(vec![0.95 * measure(&edges(dim))]);
    b.family(family);
    let scene = b.build().expect("valid scene");
    scene.validate().expect("valid scene");
    scene
}

/// det(E)/N! by cofactor expansion along the first column (E given by
/// columns; 3 × 3 or 4 × 4), only to place the rest value.
fn measure(columns: &[Vec<f64>]) -> f64 {
    fn det(m: &[Vec<f64>]) -> f64 {
        if m.len() == 1 {
            return m[0][0];
        }
        (0..m.len())
            .map(|r| {
                let minor: Vec<Vec<f64>> = m[1..]
                    .iter()
                    .map(|c| {
                        c.iter()
                            .enumerate()
                            .filter(|&(k, _)| k != r)
                            .map(|(_, &v)| v)
                            .collect()
                    })
                    .collect();
                let sign = if r % 2 == 0 { 1.0 } else { -1.0 };
                sign * m[0][r] * det(&minor)
            })
            .sum()
    }
    let n = columns.len();
    det(columns) / (1..=n).map(|k| k as f64).product::<f64>()
}

#[test]
fn the_scene_ties_and_is_positively_oriented() {
    for dim in [3, 4] {
        let e = edges(dim);
        assert_eq!(e[0][0].abs(), e[0][1].abs(), "R^{dim}: the tie");
        assert!(
            e[0][2..].iter().all(|v| v.abs() < e[0][0].abs()),
            "R^{dim}: rows 0 and 1 hold the largest magnitude"
        );
        assert!(measure(&e) > 0.0, "R^{dim}: positive orientation");
    }
}

#[test]
fn tied_pivots_follow_the_golden_rule() {
    for dim in [3, 4] {
        both(
            "tied_pivots_follow_the_golden_rule",
            &format!("tied pivots {dim}D"),
            &tied_simplex(dim),
            3,
        );
    }
}
