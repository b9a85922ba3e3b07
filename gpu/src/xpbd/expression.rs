//! Expression families on the device: the WGSL the step module is composed
//! with for a plan, generated from each family's tapes (`hyperpbd_core::
//! expr::emit_wgsl`) around the projection of `hyperpbd_core::kinds::
//! project` — the same operations in the same order, so on lavapipe gpu-f64
//! is the golden path and gpu-f32 the f32 reference bit for bit.
//!
//! ```text
//! per expression family k (plan order; the call's slot_map holds k):
//!   expression{k}_gradient(x, opaque) -> [C, ∇C]   the tape (emit_wgsl)
//!   expression{k}_value(x, opaque)    -> [C]
//!   expression{k}_inputs(e)           the element's coordinates (particle j, axis a at j·DIM + a),
//!                                     then its m per-element constants, read from `rest` at
//!                                     base_k + e·m (Families::constants_base; per world)
//!   expression{k}_project(t)          the XPBD update of element first + t
//!   expression{k}_primal(t)           the update that carries the primal residual
//!                                     (FLAG_PRIMAL; primal.wgsl's Gauss–Newton step)
//!   expression{k}_violation(e)        by the relation: |C|, max(−C, 0), max(C, 0)
//! project_expression_element(t), expression_violation(e)   switch over k
//! ```
//! `opaque` is `call.call == NONE`: false for every call, but only the run
//! knows it (the emitted code passes each arithmetic result through it so
//! the driver can neither regroup nor fuse; shaders/step.wgsl `kept`).

use std::fmt::Write;

use hyperpbd_core::expr::emit_wgsl;
use hyperpbd_core::kinds::{ExpressionKind, Relation};
use hyperpbd_core::{Plan, Precision};

use super::Families;

/// The expression families of `plan`, in plan order: (family index, kind).
pub(crate) fn expression_families(plan: &Plan) -> Vec<(usize, &ExpressionKind)> {
    (plan.families.iter().enumerate())
        .filter_map(|(f, family)| Some((f, family.kind.expression()?)))
        .collect()
}

/// The index k of family `family` among `plan`'s expression families.
pub(crate) fn expression_index(plan: &Plan, family: usize) -> u32 {
    plan.families[..family]
        .iter()
        .filter(|f| f.kind.is_expression())
        .count() as u32
}

/// The generated WGSL of `plan`'s expression families for the step module
/// (their constants where `families` put them in `rest`).
pub(crate) fn generated(plan: &Plan, families: &Families, precision: Precision) -> String {
    let kinds: Vec<(&ExpressionKind, u32)> = (expression_families(plan).into_iter())
        .map(|(f, kind)| (kind, families.constants_base[f]))
        .collect();
    generated_for(&kinds, plan.dim, precision, plan.primal_residual)
}

/// The generated WGSL of expression families `kinds` (each with the
/// offset of its per-element constants in `rest`) in R^`dim` (the two
/// dispatchers alone for none: every step module has them); with
/// `primal`, each family's primal-residual update too.
pub(crate) fn generated_for(
    kinds: &[(&ExpressionKind, u32)],
    dim: usize,
    precision: Precision,
    primal: bool,
) -> String {
    let mut s = String::new();
    let mut project_cases = String::new();
    let mut violation_cases = String::new();
    // Writing to a String cannot fail.
    for (k, (kind, base, members)) in classes(kinds, precision).into_iter().enumerate() {
        // The expression indices this code serves, as case selectors.
        let selectors = (members.iter().map(|m| format!("{m}u")))
            .collect::<Vec<_>>()
            .join(", ");
        s.push_str(&emit_wgsl(
            &kind.gradient,
            &format!("expression{k}_gradient"),
            precision,
        ));
        s.push_str(&emit_wgsl(
            &kind.value,
            &format!("expression{k}_value"),
            precision,
        ));
        let arity = kind.arity;
        let n = arity * dim;
        let m = kind.element_constants;
        // The tapes' input array: coordinates, then the constants.
        let inputs = n + m;
        let constants = match m {
            0 => String::new(),
            m => format!(
                "    for (var c = 0u; c < {m}u; c++) {{\n        inputs[{n}u + c] = rest_at({base}u + e * {m}u + c);\n    }}\n"
            ),
        };
        // The emitted tapes name the precision, and naga tells an array of
        // the `real` alias from one of the type it names.
        let t = precision.as_str();
        let clamp = match kind.relation {
            Relation::Equal => "    let next = t_new;\n    let dl = raw;",
            Relation::AtLeast => {
                "    let next = select(t_new, 0.0, t_new < 0.0);\n    let dl = next - l;"
            }
            Relation::AtMost => {
                "    let next = select(0.0, t_new, t_new < 0.0);\n    let dl = next - l;"
            }
        };
        let relation = match kind.relation {
            Relation::Equal => 0,
            Relation::AtLeast => 1,
            Relation::AtMost => 2,
        };
        let violation = match kind.relation {
            Relation::Equal => "abs(c)",
            Relation::AtLeast => "select(0.0, -c, -c > 0.0)",
            Relation::AtMost => "select(0.0, c, c > 0.0)",
        };
        let _ = write!(
            s,
            r#"
fn expression{k}_inputs(e: u32) -> array<{t}, {inputs}> {{
    var inputs: array<{t}, {inputs}>;
{gather}{constants}    return inputs;
}}

fn expression{k}_project(t: u32) {{
    let e = call.first + t;
    let s = call.slot_base + e;
{particles}    var inputs: array<{t}, {inputs}>;
{gather_loaded}{constants}    var out = expression{k}_gradient(inputs, call.call == NONE);
    let value = out[0];
    if (!finite(value)) {{
        fail(e);
        return;
    }}
    var wsum: real = 0.0;
{wsum}    if (!finite(wsum) || wsum == 0.0) {{
        no_response(s);
        return;
    }}
    let l = lambda_before(s);
    let alpha_tilde = call.alpha_tilde;
    let raw = (-(value - rest_at(s)) - alpha_tilde * l) / (wsum + alpha_tilde);
    if (!finite(raw)) {{
        fail(e);
        return;
    }}
    let t_new = l + raw;
{clamp}
    set_lambda(s, next);
{update}}}

fn expression{k}_violation(e: u32) -> real {{
    let inputs = expression{k}_inputs(e);
    let out = expression{k}_value(inputs, call.call == NONE);
    let c = out[0] - rest_at(call.slot_base + e);
    return {violation};
}}
"#,
            gather = unrolled_gather(arity, dim, true),
            particles = unrolled_particles(arity),
            gather_loaded = unrolled_gather(arity, dim, false),
            wsum = unrolled_wsum(arity, dim),
            update = unrolled_update(arity, dim),
        );
        if primal {
            let _ = write!(
                s,
                r#"
fn expression{k}_primal(t: u32) {{
    let e = call.first + t;
    let s = call.slot_base + e;
    let base = call.carried + e * {n}u;
    let inputs = expression{k}_inputs(e);
    var out = expression{k}_gradient(inputs, call.call == NONE);
    let value = out[0];
    var anchor: array<{t}, {n}>;
    var w: array<{t}, {arity}>;
    for (var j = 0u; j < {arity}u; j++) {{
        var r = load_x(elements[call.elem_base + e * {arity}u + j]);
        w[j] = inverse_mass_of(&r);
        for (var a = 0u; a < DIM; a++) {{
            let k = j * DIM + a;
            anchor[k] = inputs[k] - carried[base + k];
        }}
    }}
    if (!finite(value)) {{
        fail(e);
        return;
    }}
    var wsum: real = 0.0;
    var lin: real = value - rest_at(s);
    for (var j = 0u; j < {arity}u; j++) {{
        if (w[j] == 0.0) {{
            continue;
        }}
        for (var a = 0u; a < DIM; a++) {{
            let k = j * DIM + a;
            wsum += w[j] * out[1u + k] * out[1u + k];
            lin += out[1u + k] * (anchor[k] - inputs[k]);
        }}
    }}
    var l: real = 0.0;
    var ok = true;
    var d: array<{t}, {n}>;
    if (wsum != 0.0 && finite(wsum)) {{
        l = primal_clamp(-lin / (wsum + call.alpha_tilde), {relation}u);
        for (var k = 0u; k < {n}u; k++) {{
            d[k] = w[k / DIM] * out[1u + k] * l;
            ok = ok && finite(d[k]);
        }}
    }}
    if (!ok || !finite(l)) {{
        fail(e);
        return;
    }}
    for (var k = 0u; k < {n}u; k++) {{
        carried[base + k] = d[k];
    }}
    store_lambda(s, l);
    for (var j = 0u; j < {arity}u; j++) {{
        if (w[j] == 0.0) {{
            continue;
        }}
        let i = elements[call.elem_base + e * {arity}u + j];
        var r = load_x(i);
        for (var a = 0u; a < DIM; a++) {{
            set_lane(&r, a, anchor[j * DIM + a] + d[j * DIM + a]);
        }}
        store_x(i, r);
    }}
}}
"#
            );
            let _ = writeln!(
                project_cases,
                "        case {selectors}: {{ if ((call.flags & FLAG_PRIMAL) != 0u) {{ expression{k}_primal(t); }} else {{ expression{k}_project(t); }} }}"
            );
        } else {
            let _ = writeln!(
                project_cases,
                "        case {selectors}: {{ expression{k}_project(t); }}"
            );
        }
        let _ = writeln!(
            violation_cases,
            "        case {selectors}: {{ return expression{k}_violation(e); }}"
        );
    }
    let _ = write!(
        s,
        r#"
// Element first + t of the running expression projection (expression
// slot_map of the call); an unknown one fails the step.
fn project_expression_element(t: u32) {{
    switch (call.slot_map) {{
{project_cases}        default: {{ fail(call.first + t); }}
    }}
}}

// The violation of element e of the running expression residual call;
// an unknown expression reads as violated without bound.
fn expression_violation(e: u32) -> real {{
    switch (call.slot_map) {{
{violation_cases}        default: {{ return infinity(); }}
    }}
}}
"#
    );
    s
}

/// The expression families `kinds` grouped by the code they generate:
/// (kind, constants offset, the indices k of the families it serves), in
/// order of first appearance. Families with the same tapes, arity,
/// relation and per-element constants (the same offset, where they have
/// any) share one set of functions, so the dispatchers' `switch` has one
/// case per distinct code — a software adapter runs every case of a
/// switch under masks (lavapipe), so four families written alike cost
/// four projections per element otherwise.
fn classes<'k>(
    kinds: &[(&'k ExpressionKind, u32)],
    precision: Precision,
) -> Vec<(&'k ExpressionKind, u32, Vec<usize>)> {
    let code = |kind: &ExpressionKind, base: u32| {
        (
            emit_wgsl(&kind.gradient, "f", precision),
            emit_wgsl(&kind.value, "f", precision),
            kind.arity,
            kind.element_constants,
            if kind.element_constants > 0 { base } else { 0 },
            kind.relation,
        )
    };
    let mut out: Vec<(&ExpressionKind, u32, Vec<usize>)> = Vec::new();
    let mut codes = Vec::new();
    for (k, &(kind, base)) in kinds.iter().enumerate() {
        let key = code(kind, base);
        match codes.iter().position(|c| *c == key) {
            Some(c) => out[c].2.push(k),
            None => {
                codes.push(key);
                out.push((kind, base, vec![k]));
            }
        }
    }
    out
}

/// The element's coordinates into `inputs` (particle j, axis a at
/// j·DIM + a), every index a constant: with `load`, each particle's record
/// loaded here (`expression{k}_inputs`), else from the records `r{j}` that
/// [`unrolled_particles`] loaded.
fn unrolled_gather(arity: usize, dim: usize, load: bool) -> String {
    let mut s = String::new();
    for j in 0..arity {
        if load {
            let _ = writeln!(
                s,
                "    var r{j} = load_x(elements[call.elem_base + e * {arity}u + {j}u]);"
            );
        }
        for a in 0..dim {
            let _ = writeln!(s, "    inputs[{}] = lane(&r{j}, {a}u);", j * dim + a);
        }
    }
    s
}

/// The element's particle indices `i{j}` and records `r{j}`.
fn unrolled_particles(arity: usize) -> String {
    let mut s = String::new();
    for j in 0..arity {
        let _ = writeln!(
            s,
            "    let i{j} = elements[call.elem_base + e * {arity}u + {j}u];\n    var r{j} = load_x(i{j});"
        );
    }
    s
}

/// wsum = Σ_j w_j |∇_j C|² over the particles with w_j ≠ 0, in particle
/// order, each |∇_j C|² summed from 0 over the axes in order (the golden
/// path's order: `kinds::project`).
fn unrolled_wsum(arity: usize, dim: usize) -> String {
    let mut s = String::new();
    for j in 0..arity {
        let _ = writeln!(
            s,
            "    let w{j} = inverse_mass_of(&r{j});\n    if (w{j} != 0.0) {{\n        var g2: real = 0.0;"
        );
        for a in 0..dim {
            let g = 1 + j * dim + a;
            let _ = writeln!(s, "        g2 += out[{g}] * out[{g}];");
        }
        let _ = writeln!(s, "        wsum += w{j} * g2;\n    }}");
    }
    s
}

/// x_j += w_j ∇_j C Δλ for the particles with w_j ≠ 0, in particle order,
/// each record loaded again after the previous particle's store.
fn unrolled_update(arity: usize, dim: usize) -> String {
    let mut s = String::new();
    for j in 0..arity {
        let _ = writeln!(
            s,
            "    {{\n        var r = load_x(i{j});\n        let w = inverse_mass_of(&r);\n        if (w != 0.0) {{"
        );
        for a in 0..dim {
            let g = 1 + j * dim + a;
            let _ = writeln!(
                s,
                "            set_lane(&r, {a}u, lane(&r, {a}u) + w * out[{g}] * dl);"
            );
        }
        let _ = writeln!(s, "            store_x(i{j}, r);\n        }}\n    }}");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SceneOrigin;
    use hyperpbd_core::builders::GridSpec;
    use hyperpbd_core::kinds::BendingModel;
    use hyperpbd_core::{ConstraintFamily, ConstraintKind, SceneBuilder};

    /// The per-element constants of a quadratic bending family lie in
    /// `rest` at its `constants_base`, after every slot and the material
    /// data, in the plan's colour order, and the generated WGSL reads them
    /// from there; a cosine family carries none.
    #[test]
    fn quadratic_weights_reach_rest_where_the_generated_code_reads_them() {
        let mut b = SceneBuilder::new(3).gravity_along(1, 9.81);
        let grid = b.grid(&GridSpec::cloth(4, 3, 0.1, 1.0));
        let cosine = b.grid_bending(&grid, 1e-3, BendingModel::Cosine);
        let quadratic = b.grid_bending(&grid, 1e-3, BendingModel::Quadratic);
        let strut = vec![vec![0, grid.index(&[3, 2])]];
        b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, strut));
        let plan = Plan::compile(&b.build().expect("valid")).expect("plan");
        let families = Families::new(&plan, &SceneOrigin::zero(3)).expect("families");
        let (cosine, quadratic) = (cosine.expect("hinges"), quadratic.expect("hinges"));
        let kind =
            (plan.families[quadratic].kind.expression()).expect("bending is an expression family");
        let base = families.constants_base[quadratic] as usize;
        assert!(base >= families.slots);
        assert_eq!(kind.constants.len(), 3 * plan.families[quadratic].len());
        assert_eq!(
            &families.rest[base..base + kind.constants.len()],
            &kind.constants[..]
        );
        assert_eq!(
            families.constants_base[cosine], families.constants_base[quadratic],
            "the cosine family before it carries no constants"
        );
        let source = generated(&plan, &families, Precision::F64);
        let k = expression_index(&plan, quadratic);
        assert!(source.contains(&format!("inputs[12u + c] = rest_at({base}u + e * 3u + c);")));
        assert!(source.contains(&format!(
            "fn expression{k}_inputs(e: u32) -> array<f64, 15>"
        )));
        let c = expression_index(&plan, cosine);
        assert!(source.contains(&format!(
            "fn expression{c}_inputs(e: u32) -> array<f64, 12>"
        )));
    }

    /// Families that generate the same code share one set of functions and
    /// one case of each dispatcher; another expression, or per-element
    /// constants at another offset, get their own.
    #[test]
    fn families_written_alike_share_their_code() {
        let mut b = SceneBuilder::new(3).gravity_along(1, 9.81);
        let grid = b.grid(&GridSpec::cloth(4, 3, 0.1, 1.0));
        let pairs = |k: usize| vec![vec![grid.index(&[k, 0]), grid.index(&[k, 1])]];
        for (k, source) in [
            (0, "norm(x1 - x0)"),
            (1, "dot(x1 - x0, x1 - x0)"),
            (2, "norm(x1 - x0)"),
        ] {
            b.family(ConstraintFamily::expression(source, 0.0, pairs(k)));
        }
        b.grid_bending(&grid, 1e-3, BendingModel::Quadratic);
        b.grid_bending(&grid, 1e-3, BendingModel::Quadratic);
        let plan = Plan::compile(&b.build().expect("valid")).expect("plan");
        let families = Families::new(&plan, &SceneOrigin::zero(3)).expect("families");
        let source = generated(&plan, &families, Precision::F64);
        assert!(source.contains("case 0u, 2u: { expression0_project(t); }"));
        assert!(source.contains("case 1u: { expression1_project(t); }"));
        // The two bending families: the same tapes, their constants at two
        // offsets.
        assert!(source.contains("case 3u: { expression2_project(t); }"));
        assert!(source.contains("case 4u: { expression3_project(t); }"));
        assert!(!source.contains("fn expression4_project"));
        assert_eq!(source.matches("fn expression0_gradient").count(), 1);
    }
}
