//! Bending, the cosine fold (`"type": "bending"`): elements of 4
//! particles [x0, x1, x2, x3], the triangles (x0, x1, x2) and (x0, x1, x3)
//! sharing the edge x0x1, in any R^N with N ≥ 3.
//!
//! ```text
//! e = x1 − x0,  a = x2 − x0,  b = x3 − x0
//! p_A = a − (a·e / e·e) e,  p_B = b − (b·e / e·e) e    the conormals of the two triangles
//! c = −(p_A·p_B) / √((p_A·p_A)(p_B·p_B))               −u_A·u_B: 1 flat, −1 folded shut
//! C = c − c_rest,  c_rest = c at the authored positions (or `rest`)
//! ```
//! Orientation-neutral (never a signed dihedral), so it means the same in
//! every R^N; smooth through the flat fold, where its force vanishes
//! (dc/dθ = sin θ = 0 at θ = π). Written once as an expression: ∇C (and
//! ∇²C) are derived, and every backend runs it as an expression family
//! (kinds/expression.rs), gpu-f64 = golden and gpu-f32 = f32 reference bit
//! for bit by construction. A degenerate hinge (zero edge, a triangle
//! collapsed onto the edge) has c = NaN: refused as authored rest geometry,
//! and during a step it makes no response when only ∇C is undefined, or is
//! a typed step error when C itself is.

use super::Arity;

pub(super) const ARITY: Arity = Arity::Exactly(4);

/// The smallest dimension a fold has a meaning in.
pub(super) const MIN_DIM: usize = 3;

/// The cosine fold as an expression of the element's four particles.
pub(super) const COSINE: &str = "let e = x1 - x0; let a = x2 - x0; let b = x3 - x0; \
     let ee = dot(e, e); \
     let pa = a - (dot(a, e) / ee) * e; let pb = b - (dot(b, e) / ee) * e; \
     -dot(pa, pb) / sqrt(dot(pa, pa) * dot(pb, pb))";

pub(super) fn rest_problem(rest: f64) -> Option<&'static str> {
    (!(-1.0..=1.0).contains(&rest)).then_some("a fold's rest cosine must be in [-1, 1]")
}
