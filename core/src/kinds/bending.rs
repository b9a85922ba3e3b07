//! Bending (`"type": "bending"`): elements of 4 particles [x0, x1, x2, x3],
//! the triangles (x0, x1, x2) and (x0, x1, x3) sharing the edge x0x1, in
//! any R^N with N ≥ 3. Two models (`"model"`), both written once as
//! expressions: ∇C (and ∇²C) are derived, and every backend runs them as
//! expression families (kinds/expression.rs), gpu-f64 = golden and gpu-f32
//! = f32 reference bit for bit by construction.
//!
//! **`"cosine"`** (default), the seed's fold:
//! ```text
//! e = x1 − x0,  a = x2 − x0,  b = x3 − x0
//! p_A = a − (a·e / e·e) e,  p_B = b − (b·e / e·e) e    the conormals of the two triangles
//! c = −(p_A·p_B) / √((p_A·p_A)(p_B·p_B))               −u_A·u_B: 1 flat, −1 folded shut
//! C = c − c_rest,  c_rest = c at the authored positions (or `rest`)
//! ```
//! Orientation-neutral (never a signed dihedral), so it means the same in
//! every R^N; smooth through the flat fold, where its force vanishes
//! (dc/dθ = sin θ = 0 at θ = π): C ≈ −φ²/2 for a fold φ from flat, so
//! the energy C²/(2α) is quartic in φ and not mesh-convergent.
//!
//! **`"quadratic"`**: the isometric quadratic bending model of Bergou,
//! Wardetzky, Harmon, Zorin and Grinspun (2006), which lives in any R^N:
//! ```text
//! per hinge, from the authored triangles (their edge lengths only):
//!   |e| = √(e·e),  h_A = |p_A|,  h_B = |p_B|          heights of x2, x3 over the edge
//!   cot at x0 in A: (e·a)/(|e| h_A),  at x1 in A: (e·e − e·a)/(|e| h_A)   (B: b, h_B)
//!   K = (c03 + c04, c01 + c02, −c01 − c03, −c02 − c04)     (paper: c0j = cot, j = 1 A/x0,
//!                                                            2 B/x0, 3 A/x1, 4 B/x1)
//!     K2 = −(c01 + c03) = −|e|/h_A,  K3 = −|e|/h_B,  K0 = −(K1 + K2 + K3)
//!   s = √(3/(A_A + A_B)) = √(6/(|e| (h_A + h_B)))           the paper's area factor
//!   k_j = s K_j                                             per-element constants k1 k2 k3
//! v = k1 (x1 − x0) + k2 (x2 − x0) + k3 (x3 − x0)  (= Σ_j k_j x_j, translation-free by form)
//! C = |v| − rest,  rest 0:  C²/(2α) = ½ k |v|²,  k = 1/α
//! ```
//! v is linear in x, so the energy ½k|v|² = ½ xᵀ(k s² K Kᵀ ⊗ I)x has a
//! constant Hessian (the paper's Q = 3/(A_A + A_B) KᵀK). Σ_j K_j x_j = 0
//! for every flat placement of the authored triangles (x2, x3 on opposite
//! sides of the edge: the cotangent weights reproduce linear functions),
//! so the rest is flat and an authored fold is a load, not a rest shape;
//! folded by φ from flat, |v| = 2 s |e| sin(φ/2) whatever the wings' shape
//! (|v| = s |K3| · 2 h_B sin(φ/2)), so
//! ```text
//! E_hinge = ½ k |v|² = 12 k |e| sin²(φ/2) / (h_A + h_B) ≈ ½ k · 3|e|²/(A_A + A_B) · φ²
//! ```
//! — the discrete-shells hinge energy, quadratic in φ: a surface bent to
//! curvature κ stores O(1) energy per unit area however fine the mesh
//! (docs/bending.md measures it). Rigid motions carry no force: Σ_j ∇_j C
//! = (Σ_j K_j) v̂ s = 0 and Σ_j x_j ∇_j Cᵀ − ∇_j C x_jᵀ = v v̂ᵀ − v̂ vᵀ = 0.
//! C = |v| is XPBD's zero-rest-length spring: C²/(2α) is exactly the
//! quadratic energy, the projection moves v along v̂ towards 0 and never
//! past it (|v'| = α~(|v| − W λ)/(W + α~) ≥ 0 with λ ≤ 0, W = Σ w_j k_j²),
//! and at v = 0 (flat) ∇C = v/|v| is undefined: no response, the
//! built-ins' rule. The weights are computed once at load from the
//! authored positions (dot products and a square root: no cross product,
//! any N) and carried per element ([`super::ExpressionKind::constants`]).
//!
//! A degenerate hinge (zero edge, a triangle collapsed onto the edge) is
//! refused as authored rest geometry: the cosine's c is NaN there, the
//! quadratic weights divide by a zero height.

use serde::{Deserialize, Serialize};

use super::Arity;

pub(super) const ARITY: Arity = Arity::Exactly(4);

/// The smallest dimension a fold has a meaning in.
pub(super) const MIN_DIM: usize = 3;

/// Which bending energy a family uses (the `"model"` key).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BendingModel {
    /// The seed's cosine fold, C = −u_A·u_B − c_rest (quartic in the fold).
    #[default]
    Cosine,
    /// Bergou et al. 2006: C = |Σ_j k_j x_j| with rest 0 (½k|v|², quadratic
    /// in the fold, constant Hessian, convergent under refinement).
    Quadratic,
}

impl BendingModel {
    /// As written in a scene.
    pub fn as_str(self) -> &'static str {
        match self {
            BendingModel::Cosine => "cosine",
            BendingModel::Quadratic => "quadratic",
        }
    }
}

/// The cosine fold as an expression of the element's four particles.
pub(super) const COSINE: &str = "let e = x1 - x0; let a = x2 - x0; let b = x3 - x0; \
     let ee = dot(e, e); \
     let pa = a - (dot(a, e) / ee) * e; let pb = b - (dot(b, e) / ee) * e; \
     -dot(pa, pb) / sqrt(dot(pa, pa) * dot(pb, pb))";

/// The quadratic model's |v| over the per-element weights k1, k2, k3.
pub(super) const QUADRATIC: &str =
    "let v = k1 * (x1 - x0) + k2 * (x2 - x0) + k3 * (x3 - x0); norm(v)";

/// The quadratic model's per-element constants, in tape order.
pub(super) const QUADRATIC_CONSTANTS: [&str; 3] = ["k1", "k2", "k3"];

/// The quadratic weights (k1, k2, k3) of the hinge whose authored
/// positions are `points` (4 × `dim`), or why it has none.
pub fn quadratic_weights(points: &[f64], dim: usize) -> Result<[f64; 3], &'static str> {
    let at = |j: usize, a: usize| points[j * dim + a] - points[a];
    let dot = |j: usize, k: usize| (0..dim).map(|a| at(j, a) * at(k, a)).sum::<f64>();
    let ee = dot(1, 1);
    let length = ee.sqrt();
    // Height of x_j over the edge: |p| with p = (x_j − x0) − (·e / e·e) e.
    let height = |j: usize| {
        let t = dot(j, 1) / ee;
        (0..dim)
            .map(|a| {
                let p = at(j, a) - t * at(1, a);
                p * p
            })
            .sum::<f64>()
            .sqrt()
    };
    let (ha, hb) = (height(2), height(3));
    let (ea, eb) = (dot(2, 1), dot(3, 1));
    let s = (6.0 / (length * (ha + hb))).sqrt();
    let k1 = s * (ea / (length * ha) + eb / (length * hb));
    let k2 = -s * (length / ha);
    let k3 = -s * (length / hb);
    let weights = [k1, k2, k3];
    if ee == 0.0 || ha == 0.0 || hb == 0.0 || !weights.iter().all(|k| k.is_finite()) {
        return Err(
            "a hinge's edge and both triangles need a nonzero size (the quadratic weights are \
             their rest cotangents)",
        );
    }
    Ok(weights)
}

pub(super) fn rest_problem(model: BendingModel, rest: f64) -> Option<&'static str> {
    match model {
        BendingModel::Cosine => {
            (!(-1.0..=1.0).contains(&rest)).then_some("a fold's rest cosine must be in [-1, 1]")
        }
        BendingModel::Quadratic => {
            (rest < 0.0).then_some("a quadratic hinge's rest is a norm (of v): it must be >= 0")
        }
    }
}
