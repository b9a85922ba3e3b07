//! Expression families in the coupled step on the device: the WGSL the
//! coupled module is composed with for a plan, generated from each family's
//! tapes (`hyperpbd_core::expr::emit_wgsl`) around the spring of
//! `hyperpbd_core::implicit::expression_spring` — the same operations in
//! the same order, so on lavapipe gpu-f64 is the golden path bit for bit.
//!
//! ```text
//! per expression family k (plan order; a block's material word holds k):
//!   coupled_expression{k}_inputs(pts)         the coordinates, then the element's
//!                                             constants (material_rest at block_constants)
//!   coupled_expression{k}_gradient(x, opaque) -> [C, ∇C]          the tape
//!   coupled_expression{k}_hessian(x, opaque)  -> [C, ∇C, ∇²C]     the tape
//!   coupled_expression{k}_energy(α, rest, pts, grad) -> E          ∇E into grad
//!   coupled_expression{k}_block(α, rest, pts, h) -> finite         K⁺ into h (n × n)
//! coupled_expression_energy(k, …), coupled_expression_block(k, …)   switch over k;
//!   an unknown k: E = REAL_MAX / false, so the step fails (never another family's code)
//! ```

use std::fmt::Write;

use hyperpbd_core::expr::emit_wgsl;
use hyperpbd_core::kinds::{ExpressionKind, Relation};
use hyperpbd_core::{Plan, Precision};

use crate::xpbd::expression::expression_families;

/// The generated WGSL of `plan`'s expression families for the coupled
/// module (`None` when it has none: the module's stand-ins serve).
pub(crate) fn generated(plan: &Plan, precision: Precision) -> Option<String> {
    let kinds: Vec<&ExpressionKind> = (expression_families(plan).into_iter())
        .map(|(_, kind)| kind)
        .collect();
    (!kinds.is_empty()).then(|| generated_for(&kinds, plan.dim, precision))
}

/// The relation's active part φ of `c` (expression_spring.rs `active_part`).
fn active_part(relation: Relation) -> &'static str {
    match relation {
        Relation::Equal => "c",
        Relation::AtMost => "select(0.0, c, c > 0.0)",
        Relation::AtLeast => "select(0.0, c, c < 0.0)",
    }
}

/// The generated WGSL of expression families `kinds` in R^`dim` (the two
/// dispatchers alone for none).
pub(crate) fn generated_for(kinds: &[&ExpressionKind], dim: usize, precision: Precision) -> String {
    let mut s = String::new();
    let mut energy_cases = String::new();
    let mut block_cases = String::new();
    let t = precision.as_str();
    // Writing to a String cannot fail.
    for (k, kind) in kinds.iter().enumerate() {
        s.push_str(&emit_wgsl(
            &kind.gradient,
            &format!("coupled_expression{k}_gradient"),
            precision,
        ));
        s.push_str(&emit_wgsl(
            kind.hessian(),
            &format!("coupled_expression{k}_hessian"),
            precision,
        ));
        let n = kind.arity * dim;
        let m = kind.element_constants;
        let width = (n + m).max(1);
        let phi = active_part(kind.relation);
        let _ = write!(
            s,
            r#"
fn coupled_expression{k}_inputs(pts: ptr<function, array<real, POINTS>>) -> array<{t}, {width}> {{
    var inputs: array<{t}, {width}>;
    for (var c = 0u; c < {n}u; c++) {{
        inputs[c] = (*pts)[c];
    }}
    for (var c = 0u; c < {m}u; c++) {{
        inputs[{n}u + c] = material_rest[block_constants + c];
    }}
    return inputs;
}}

fn coupled_expression{k}_energy(compliance: real, rest: real, pts: ptr<function, array<real, POINTS>>,
                               grad: ptr<function, array<real, POINTS>>) -> real {{
    var out = coupled_expression{k}_gradient(coupled_expression{k}_inputs(pts), coupled_opaque());
    let c = out[0] - rest;
    let phi = {phi};
    let energy = phi * phi / (2.0 * compliance);
    var defined = true;
    for (var j = 0u; j < {n}u; j++) {{
        defined = defined && finite(out[1u + j]);
    }}
    let force = phi / compliance;
    for (var j = 0u; j < {n}u; j++) {{
        var g: real = 0.0;
        if (defined && phi != 0.0) {{
            g = force * out[1u + j];
        }}
        (*grad)[j] = g;
    }}
    return energy;
}}

fn coupled_expression{k}_block(compliance: real, rest: real, pts: ptr<function, array<real, POINTS>>,
                              h: ptr<function, array<real, HESS>>) -> bool {{
    var out = coupled_expression{k}_hessian(coupled_expression{k}_inputs(pts), coupled_opaque());
    let c = out[0] - rest;
    let phi = {phi};
    var defined = true;
    for (var j = 0u; j < {n}u; j++) {{
        defined = defined && finite(out[1u + j]);
    }}
    if (phi == 0.0 || !defined) {{
        for (var q = 0u; q < {n}u * {n}u; q++) {{
            (*h)[q] = 0.0;
        }}
        return true;
    }}
    var second = true;
    for (var q = 0u; q < {pairs}u; q++) {{
        second = second && finite(out[{first_hessian}u + q]);
    }}
    let weight = 1.0 / compliance;
    let scale = phi * weight;
    for (var r = 0u; r < {n}u; r++) {{
        let gr = weight * out[1u + r];
        for (var q = 0u; q < {n}u; q++) {{
            var kk = gr * out[1u + q];
            if (second) {{
                let lo = min(r, q);
                let hi = max(r, q);
                let index = lo * {n}u - (lo * (lo - 1u)) / 2u + (hi - lo);
                kk += scale * out[{first_hessian}u + index];
            }}
            (*h)[r * {n}u + q] = kk;
        }}
    }}
    return project_psd(h, {n}u);
}}
"#,
            pairs = n * (n + 1) / 2,
            first_hessian = 1 + n,
        );
        let _ = writeln!(
            energy_cases,
            "        case {k}u: {{ return coupled_expression{k}_energy(compliance, rest, pts, grad); }}"
        );
        let _ = writeln!(
            block_cases,
            "        case {k}u: {{ return coupled_expression{k}_block(compliance, rest, pts, h); }}"
        );
    }
    let _ = write!(
        s,
        r#"
// E and ∇E of expression family k's element at `pts` (REAL_MAX for an
// unknown k: the step fails).
fn coupled_expression_energy(k: u32, compliance: real, rest: real, pts: ptr<function, array<real, POINTS>>,
                             grad: ptr<function, array<real, POINTS>>) -> real {{
    switch (k) {{
{energy_cases}        default: {{ return REAL_MAX; }}
    }}
}}

// K⁺ of expression family k's element at `pts` into `h`; false for an
// unknown k (the step fails) or a non-finite block.
fn coupled_expression_block(k: u32, compliance: real, rest: real, pts: ptr<function, array<real, POINTS>>,
                            h: ptr<function, array<real, HESS>>) -> bool {{
    switch (k) {{
{block_cases}        default: {{ return false; }}
    }}
}}
"#
    );
    s
}
