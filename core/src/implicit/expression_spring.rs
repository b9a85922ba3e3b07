//! Expression families (bending among them) as springs of the implicit
//! objective, with the derived ∇C and ∇²C of their compiled tapes
//! (core/src/expr/; nothing written by hand per expression).
//!
//! ```text
//! c = value − rest,  φ = the relation's active part:  "==" φ = c,  "<=" φ = max(c, 0),  ">=" φ = min(c, 0)
//! E   = φ² / (2α)                                   α = compliance > 0
//! ∇E  = (φ/α) ∇C
//! K   = (1/α) ∇C ∇Cᵀ + (φ/α) ∇²C                   0 where φ = 0 (an inactive one-sided element)
//! K⁺  = project_psd(K)                              dense (arity·N)², once per Newton iteration
//! ```
//! As for the built-ins, an element whose ∇C is undefined (a non-finite
//! entry: `norm` at 0, a collapsed fold) makes no response: ∇E = 0 and
//! K⁺ = 0, its energy still φ²/(2α). Where ∇C is finite but ∇²C is not (a
//! kink of `abs`, `min`, `max`), the second-order part is dropped and K is
//! the Gauss–Newton block. A "<=" element is the tether's one-sided spring
//! (it only pulls back once c > 0), a ">=" one the contact's.
//!
//! Order of operations (the GPU's coupled kernel performs the same): the
//! tapes run in their slot order; K[r][s] = (w ∇C_r) ∇C_s + (φ w) ∇²C_rs
//! with w = 1/α, r, s ascending; products y_r = Σ_s K⁺[r][s] p_s, s
//! ascending.

use super::psd::{PsdScratch, project_psd};
use crate::expr::Columns;
use crate::kinds::{ExpressionKind, Relation};

/// One expression spring evaluated at its points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExpressionSpring {
    /// φ²/(2α).
    pub energy: f64,
    /// φ (0 for an inactive one-sided element).
    pub active: f64,
}

/// Buffers of expression spring evaluations (reused between elements).
#[derive(Debug, Default, Clone)]
pub struct ExpressionScratch {
    columns: Columns<f64>,
    psd: PsdScratch<f64>,
}

/// φ of c under `relation` (module docs).
fn active_part(relation: Relation, c: f64) -> f64 {
    match relation {
        Relation::Equal => c,
        Relation::AtMost => {
            if c > 0.0 {
                c
            } else {
                0.0
            }
        }
        Relation::AtLeast => {
            if c < 0.0 {
                c
            } else {
                0.0
            }
        }
    }
}

/// Evaluates the spring of element `e` of `kind` with compliance α > 0 and
/// rest value `rest` at `points` (arity × N; the tape reads the element's
/// constants after them): ∇E into
/// `energy_gradient` (0 where ∇C is undefined or the element inactive). A
/// non-finite C gives a non-finite energy (the caller's step fails, as
/// every non-finite record).
pub fn expression_spring(
    kind: &ExpressionKind,
    e: usize,
    (compliance, rest): (f64, f64),
    points: &[f64],
    energy_gradient: &mut [f64],
    scratch: &mut ExpressionScratch,
) -> ExpressionSpring {
    let tape = &kind.gradient;
    let columns = &mut scratch.columns;
    kind.eval_at(tape, e, points, columns);
    let c = columns.get(tape.value, 0) - rest;
    let phi = active_part(kind.relation, c);
    let energy = phi * phi / (2.0 * compliance);
    let defined = tape.gradient.iter().all(|&g| columns.get(g, 0).is_finite());
    let force = phi / compliance;
    for (out, &g) in energy_gradient.iter_mut().zip(&tape.gradient) {
        *out = if defined && phi != 0.0 {
            force * columns.get(g, 0)
        } else {
            0.0
        };
    }
    ExpressionSpring {
        energy,
        active: phi,
    }
}

/// K⁺ of the spring of element `e` at `points` into `block` ((arity·N)²,
/// row-major);
/// false when the projection meets a non-finite block (it cannot once C
/// and ∇C are finite; the caller then fails the step).
pub fn expression_curvature(
    kind: &ExpressionKind,
    e: usize,
    (compliance, rest): (f64, f64),
    points: &[f64],
    block: &mut [f64],
    scratch: &mut ExpressionScratch,
) -> bool {
    let tape = kind.hessian();
    let n = tape.inputs;
    let block = &mut block[..n * n];
    let columns = &mut scratch.columns;
    kind.eval_at(tape, e, points, columns);
    let phi = active_part(kind.relation, columns.get(tape.value, 0) - rest);
    let at = |s: usize| columns.get(s, 0);
    let defined = tape.gradient.iter().all(|&g| at(g).is_finite());
    if phi == 0.0 || !defined {
        block.fill(0.0);
        return true;
    }
    let second_order = tape.hessian.iter().all(|&h| at(h).is_finite());
    let weight = 1.0 / compliance;
    let scale = phi * weight;
    for r in 0..n {
        let gr = weight * at(tape.gradient[r]);
        for s in 0..n {
            let mut k = gr * at(tape.gradient[s]);
            if second_order {
                k += scale * at(tape.hessian[tape.hessian_index(r, s)]);
            }
            block[r * n + s] = k;
        }
    }
    project_psd(block, n, &mut scratch.psd).finite
}

/// out = K⁺ p for the dense n × n `block` (s ascending per row), or its
/// diagonal with `p` = None.
pub fn apply_dense(block: &[f64], p: Option<&[f64]>, out: &mut [f64]) {
    let n = out.len();
    for r in 0..n {
        let row = &block[r * n..(r + 1) * n];
        out[r] = match p {
            None => row[r],
            Some(p) => {
                let mut y = 0.0;
                for s in 0..n {
                    y += row[s] * p[s];
                }
                y
            }
        };
    }
}

/// The rounding floor |∂E/∂C| δC of an expression spring of energy
/// `energy` (implicit/resolution.rs's `spring_rounding` with the tape's
/// length in place of the distance's N + 4 operations):
/// δC = (ops + 4) ε (|C| + |rest|).
pub fn expression_rounding(kind: &ExpressionKind, energy: f64, compliance: f64, rest: f64) -> f64 {
    let gamma = (kind.gradient.ops.len() as f64 + 4.0) * f64::EPSILON;
    let c = (2.0 * energy * compliance).sqrt();
    c / compliance * gamma * (c + rest.abs())
}
