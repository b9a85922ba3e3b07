//! The built-in kinds written as expressions agree with core's geometry
//! (`geometry::distance`, `simplex_squared_measure`, `oriented_measure`)
//! on random points in 2–4 D, value and gradient.
//!
//! ```text
//! distance          norm(x1 − x0)
//! simplex measure   k = 1: dot(e1, e1);  k ≥ 2: det(Gram entries dot(ei, ej), row by row) / (k!)²
//! oriented measure  det(x1 − x0, …, xN − x0) / N!
//! ```
//! Bound: both sides sum the same ≤ k! products of k factors in different
//! orders (Laplace vs LU, adjugate vs reverse mode), so each is within
//! γ·Σ|products| of the exact value with γ ≈ (k + 3)ε; Σ|products| ≤ the
//! permanent of |matrix| ≤ Π_i ‖row_i‖₁ (per unit of the scale factor).
//! The test holds |Δ| ≤ 2(k + 3 + g)ε·Π_i ‖row_i‖₁·scale for values (g = N
//! more roundings per Gram entry, 0 for the oriented measure); gradients
//! are cofactors times ∂entry/∂x, held to 2(2k + 6 + g)ε·scale·
//! Σ_r Π_{i≠r} ‖row_i‖₁·(chain factor) (derived below).

use super::random::Rng;
use super::{compiled, eval_one};
use crate::expr::Outputs;
use crate::geometry::{Scratch, distance, oriented_measure, simplex_squared_measure};

fn factorial(k: usize) -> f64 {
    (1..=k).fold(1.0, |a, i| a * i as f64)
}

/// The simplex measure expression of a k-simplex (k + 1 particles).
pub(crate) fn simplex_source(k: usize) -> String {
    let mut s = String::new();
    for j in 1..=k {
        s += &format!("let e{j} = x{j} - x0; ");
    }
    if k == 1 {
        return s + "dot(e1, e1)";
    }
    let entries: Vec<String> = (1..=k)
        .flat_map(|i| (1..=k).map(move |j| format!("dot(e{i}, e{j})")))
        .collect();
    let f = factorial(k);
    s + &format!("det({}) / {}", entries.join(", "), f * f)
}

/// The oriented measure expression in R^dim.
pub(crate) fn oriented_source(dim: usize) -> String {
    let cols: Vec<String> = (1..=dim).map(|j| format!("x{j} - x0")).collect();
    format!("det({}) / {}", cols.join(", "), factorial(dim))
}

/// Π_i ‖row_i‖₁ of the matrix `rows` (k rows of k).
fn row_norm_product(rows: &[Vec<f64>]) -> f64 {
    rows.iter()
        .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
        .product()
}

#[test]
fn distance_is_the_builtin_value_bit_for_bit_and_its_gradient_within_rounding() {
    let mut rng = Rng(11);
    let mut compared = 0;
    for dim in 2..=4 {
        let tape = compiled("norm(x1 - x0)", &[], 2, dim)
            .tape(Outputs::ValueGradient)
            .expect("tape");
        for _ in 0..500 {
            let x: Vec<f64> = (0..2 * dim).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let mut g = vec![0.0; 2 * dim];
            let d = distance(&x, dim, &mut g);
            let out = eval_one(&tape, &x);
            assert_eq!(
                out[0].to_bits(),
                d.to_bits(),
                "same operations in the same order"
            );
            for j in 0..2 * dim {
                // Each side: a quotient and a sum of dim products (≤ (dim + 3)ε relative to 1).
                let bound = 2.0 * (dim as f64 + 3.0) * f64::EPSILON;
                assert!(
                    (out[1 + j] - g[j]).abs() <= bound,
                    "{} vs {} (bound {bound:e})",
                    out[1 + j],
                    g[j]
                );
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 500 * (4 + 6 + 8));
}

#[test]
fn simplex_and_oriented_measures_agree_with_the_builtins() {
    let mut rng = Rng(13);
    let mut scratch = Scratch::new();
    let mut compared = 0;
    for dim in 2..=4usize {
        for k in 1..=dim {
            let oriented = k == dim;
            let sources = if oriented {
                vec![(simplex_source(k), false), (oriented_source(dim), true)]
            } else {
                vec![(simplex_source(k), false)]
            };
            for (src, is_oriented) in sources {
                let arity = k + 1;
                let tape = compiled(&src, &[], arity, dim)
                    .tape(Outputs::ValueGradient)
                    .expect("tape");
                for _ in 0..200 {
                    let x: Vec<f64> = (0..arity * dim).map(|_| rng.uniform(-1.0, 1.0)).collect();
                    let mut g = vec![0.0; arity * dim];
                    let (value, rows, scale) = if is_oriented {
                        let v = oriented_measure(&x, dim, &mut g, &mut scratch);
                        let rows: Vec<Vec<f64>> = (0..dim)
                            .map(|a| (1..=dim).map(|j| x[j * dim + a] - x[a]).collect())
                            .collect();
                        (v, rows, 1.0 / factorial(dim))
                    } else {
                        let v = simplex_squared_measure(&x, dim, &mut g, &mut scratch);
                        let e = |j: usize, a: usize| x[j * dim + a] - x[a];
                        let rows: Vec<Vec<f64>> = (1..=k)
                            .map(|i| {
                                (1..=k)
                                    .map(|j| (0..dim).map(|a| e(i, a) * e(j, a)).sum())
                                    .collect()
                            })
                            .collect();
                        (v, rows, 1.0 / (factorial(k) * factorial(k)))
                    };
                    let out = eval_one(&tape, &x);
                    let size = row_norm_product(&rows) * scale;
                    let kk = if is_oriented { dim } else { k } as f64;
                    // The Gram entries carry dim more roundings each.
                    let extra = if is_oriented { 0.0 } else { dim as f64 };
                    let bound = 2.0 * (kk + 3.0 + extra) * f64::EPSILON * size;
                    assert!(
                        (out[0] - value).abs() <= bound,
                        "{src} dim {dim}: {} vs {value} (bound {bound:e})",
                        out[0]
                    );
                    // Gradient entries: cofactors (products with one
                    // factor fewer: Σ_r Π_{i≠r} ‖row_i‖₁ bounds them all)
                    // times the chain factor ∂entry/∂x — 1 per column, N
                    // columns summed for x0 (oriented); 2|e|·k, k ≤ N Gram
                    // entries with |e_a| ≤ 2 (simplex).
                    let norms: Vec<f64> = rows
                        .iter()
                        .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
                        .collect();
                    let cofactors: f64 = (0..norms.len())
                        .map(|r| {
                            (0..norms.len())
                                .filter(|&i| i != r)
                                .map(|i| norms[i])
                                .product::<f64>()
                        })
                        .sum();
                    let chain = if is_oriented {
                        kk
                    } else {
                        2.0 * 2.0 * 2.0 * kk
                    };
                    let gbound =
                        2.0 * (2.0 * kk + 6.0 + extra) * f64::EPSILON * scale * cofactors * chain;
                    for j in 0..arity * dim {
                        assert!(
                            (out[1 + j] - g[j]).abs() <= gbound,
                            "{src} dim {dim} ∂{j}: {} vs {} (bound {gbound:e})",
                            out[1 + j],
                            g[j]
                        );
                        compared += 1;
                    }
                }
            }
        }
    }
    assert!(compared > 20_000, "{compared}");
}
