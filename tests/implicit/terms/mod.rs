//! The terms of the coupled implicit step (`hyperpbd::core::implicit`),
//! checked on their own (no backend): finite-difference gradients and
//! Hessians of springs, materials, the ball–ball barrier and lagged
//! friction in N = 1..4 and 8; PSD projection; the block reduction tree;
//! preconditioned CG on known SPD systems; the certified step filters
//! against exact rational arithmetic (near touching, far from the origin);
//! friction regimes; the closed forms. Every bound prints as
//! `BOUND | name | measured | bound | rationale`.
//!
//! ```text
//! central differences of a vector function f, step h, coordinate i:
//!   D_h = (f(x + h e_i) − f(x − h e_i)) / 2h,  D_2h likewise
//!   truncation of D_h ≈ (D_2h − D_h)/3 (Richardson), taken ×4;  rounding 1.5 δf/h, taken ×2
//!   tolerance = (4/3)|D_2h − D_h| + 3 δf/h
//! δf (rounding of one evaluation): 64 n ε (|f|∞ + |∇f|∞ |x|∞), n the coordinate count
//! ```

// Index loops mirror the math they check.
#![allow(clippy::needless_range_loop)]

use crate::common;

mod ball_barrier;
mod certified_filters;
mod closed_forms;
mod expression_springs;
mod friction;
mod materials;
mod pcg;
mod psd_projection;
mod reduction_tree;
mod springs;

use common::Lcg;
use hyperpbd::ConstraintKind;
use hyperpbd::core::barrier::{BarrierLaw, BarrierObstacles, SIMPLEX_SLOTS, filter_fraction};
use hyperpbd::core::implicit::certified_filter::{
    TrialMove, fraction, obstacle_time, pair_time, plane_time, simplex_time,
};
use hyperpbd::core::implicit::closed_forms::{
    backward_euler_slide, barrier_gap_under_load, hanging_chain_stretch, incline_acceleration,
    stacked_ball_heights, sticking_creep_speed,
};
use hyperpbd::core::implicit::{
    FrictionRegime, MaterialHessianScratch, PcgSettings, PcgStatus, PcgWorkspace, PsdScratch,
    RadialCurvature, SpringCurvature, ball_pair_barrier, block_tree_max, block_tree_sum,
    evaluate_spring, material_curvature_diagonal, material_hessian_block, material_term, mollifier,
    normal_force, obstacle_friction, pair_friction, pcg, project_psd, tree_dot,
};
use hyperpbd::core::material::{
    Law, Material, MaterialElement, MaterialScratch, RestView, rest_element,
};
use hyperpbd::geometry::Scratch;
use num_rational::BigRational;

const EPS: f64 = f64::EPSILON;
const DIMS: [usize; 5] = [1, 2, 3, 4, 8];

use common::bound::check_bound as bound;

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Worst |D_h − J| / tolerance over every entry of the Jacobian `jac`
/// (rows = outputs of f, columns = coordinates of x; module docs).
fn jacobian_worst(f: &dyn Fn(&[f64]) -> Vec<f64>, x: &[f64], jac: &[f64], h: f64) -> f64 {
    let n = x.len();
    let f0 = f(x);
    let m = f0.len();
    let delta_f = 64.0 * n as f64 * EPS * (max_abs(&f0) + max_abs(jac) * max_abs(x).max(1.0));
    let mut y = x.to_vec();
    let mut at = |i: usize, step: f64| {
        y[i] = x[i] + step;
        let v = f(&y);
        y[i] = x[i];
        v
    };
    let mut worst: f64 = 0.0;
    for i in 0..n {
        let (p1, m1, p2, m2) = (at(i, h), at(i, -h), at(i, 2.0 * h), at(i, -2.0 * h));
        for r in 0..m {
            let d1 = (p1[r] - m1[r]) / (2.0 * h);
            let d2 = (p2[r] - m2[r]) / (4.0 * h);
            let tolerance = 4.0 / 3.0 * (d2 - d1).abs() + 3.0 * delta_f / h;
            worst = worst.max((d1 - jac[r * n + i]).abs() / tolerance);
        }
    }
    worst
}

/// Eigenvalues (ascending) of the symmetric row-major n × n `a` (nalgebra).
fn eigenvalues(a: &[f64], n: usize) -> Vec<f64> {
    let m = nalgebra::DMatrix::from_row_slice(n, n, a);
    let mut w: Vec<f64> = nalgebra::SymmetricEigen::new(m)
        .eigenvalues
        .iter()
        .copied()
        .collect();
    w.sort_by(f64::total_cmp);
    w
}

/// y = A x, A row-major with `x.len()` columns.
fn mat_vec(a: &[f64], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    a.chunks(n)
        .map(|row| row.iter().zip(x).map(|(p, q)| p * q).sum())
        .collect()
}

/// A random orthogonal n × n matrix (the Q of a QR factorisation), row-major.
fn rotation(n: usize, rng: &mut Lcg) -> Vec<f64> {
    let m = nalgebra::DMatrix::from_fn(n, n, |_, _| rng.next())
        + nalgebra::DMatrix::identity(n, n) * 2.0;
    let q = m.qr().q();
    (0..n * n).map(|i| q[(i / n, i % n)]).collect()
}

fn unit(dim: usize, rng: &mut Lcg) -> Vec<f64> {
    loop {
        let v: Vec<f64> = (0..dim).map(|_| rng.next()).collect();
        let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if len > 0.1 {
            return v.iter().map(|x| x / len).collect();
        }
    }
}

/// A well-shaped k-simplex in R^dim around a random origin: vertex j is
/// origin + Q (e_j + jitter) (e_0 = 0) for a random rotation Q.
fn simplex(dim: usize, k: usize, rng: &mut Lcg) -> Vec<f64> {
    let rotate = rotation(dim, rng);
    let origin: Vec<f64> = (0..dim).map(|_| 0.5 * rng.next()).collect();
    (0..=k)
        .flat_map(|j| {
            let local: Vec<f64> = (0..dim)
                .map(|a| {
                    if a < k {
                        0.2 * rng.next() + f64::from(u8::from(j == a + 1))
                    } else {
                        0.0
                    }
                })
                .collect();
            let rotated = mat_vec(&rotate, &local);
            rotated
                .iter()
                .zip(&origin)
                .map(|(x, o)| x + o)
                .collect::<Vec<f64>>()
        })
        .collect()
}
