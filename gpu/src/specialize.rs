//! Constant arguments folded into their callees, before the driver sees a
//! pipeline's SPIR-V (the spirv shader path, spirv.rs).
//!
//! ```text
//! after process_overrides every override is a constant, but it reaches
//! the code that branches on it as a call argument:
//!   particles → run_slot(OP3, FL3, 3u, …) → run_op(op, …) → switch (op)
//! for each call with a known argument (a literal, a constant, or a
//! comparison of those):
//!   clone the callee, its argument a literal            (once per callee
//!   if (known) / switch (known) → the branch taken       and known args)
//!   the same for the clone's own calls, callees first (naga's order)
//! compact: the generic callees no other call reaches are dropped
//! ```
//!
//! The arithmetic of every branch taken is untouched, so the results are
//! the same bits; what changes is what a driver inlines and optimises
//! before it folds the branches itself. lavapipe inlines every call before
//! folding, so a `particles` pipeline of eight slots compiled eight copies
//! of every per-particle op (2–4 s each with mesh contact, docs/testing.md).

use naga::{
    BinaryOperator, Block, Expression, Function, Handle, Literal, Module, Statement, SwitchValue,
    UnaryOperator,
};

/// A clone made: the callee, the arguments known, the clone's handle.
struct Made {
    callee: Handle<Function>,
    known: Vec<Option<Literal>>,
    clone: Handle<Function>,
}

/// A call to point at a clone: its callee and arguments, the clone.
struct Retarget {
    callee: Handle<Function>,
    arguments: Vec<Handle<Expression>>,
    clone: Handle<Function>,
}

/// `module` (one entry point, no overrides left) with the constant
/// arguments of its calls folded into specialised callees, compacted.
pub(crate) fn constant_arguments(mut module: Module) -> Module {
    let mut made: Vec<Made> = Vec::new();
    for index in 0..module.entry_points.len() {
        let mut function = std::mem::take(&mut module.entry_points[index].function);
        specialise_body(&mut module, &mut made, &mut function);
        module.entry_points[index].function = function;
    }
    naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
    module
}

/// Folds `function`'s known branches, then points each of its calls with
/// known arguments at a specialised clone of the callee (made first).
fn specialise_body(module: &mut Module, made: &mut Vec<Made>, function: &mut Function) {
    fold_block(module, &function.expressions, &mut function.body);
    let mut calls = Vec::new();
    collect_calls(&function.body, &mut calls);
    let mut retarget = Vec::new();
    for (callee, arguments) in calls {
        let known: Vec<Option<Literal>> = arguments
            .iter()
            .map(|&a| evaluate(module, &function.expressions, a))
            .collect();
        if known.iter().all(Option::is_none) {
            continue;
        }
        let clone = match made.iter().find(|m| m.callee == callee && m.known == known) {
            Some(m) => m.clone,
            None => {
                let clone = specialised(module, made, callee, &known);
                made.push(Made {
                    callee,
                    known,
                    clone,
                });
                clone
            }
        };
        retarget.push(Retarget {
            callee,
            arguments,
            clone,
        });
    }
    let mut results = Vec::new();
    retarget_calls(&mut function.body, &retarget, &mut results);
    for (result, clone) in results {
        function.expressions[result] = Expression::CallResult(clone);
    }
}

/// A clone of `callee` whose arguments `known` are literals, its branches
/// and calls specialised, appended after its own callees.
fn specialised(
    module: &mut Module,
    made: &mut Vec<Made>,
    callee: Handle<Function>,
    known: &[Option<Literal>],
) -> Handle<Function> {
    let span = module.functions.get_span(callee);
    let mut function = module.functions[callee].clone();
    for (_, expression) in function.expressions.iter_mut() {
        if let Expression::FunctionArgument(k) = *expression
            && let Some(Some(value)) = known.get(k as usize)
        {
            *expression = Expression::Literal(*value);
        }
    }
    specialise_body(module, made, &mut function);
    module.functions.append(function, span)
}

/// Every call in `block` (nested blocks included): callee and arguments.
fn collect_calls(block: &Block, calls: &mut Vec<(Handle<Function>, Vec<Handle<Expression>>)>) {
    for statement in block.iter() {
        match statement {
            Statement::Call {
                function,
                arguments,
                ..
            } => calls.push((*function, arguments.clone())),
            Statement::Block(inner) => collect_calls(inner, calls),
            Statement::If { accept, reject, .. } => {
                collect_calls(accept, calls);
                collect_calls(reject, calls);
            }
            Statement::Switch { cases, .. } => {
                for case in cases {
                    collect_calls(&case.body, calls);
                }
            }
            Statement::Loop {
                body, continuing, ..
            } => {
                collect_calls(body, calls);
                collect_calls(continuing, calls);
            }
            _ => {}
        }
    }
}

/// Points the calls of `block` listed in `retarget` (callee, arguments)
/// at their clones; `results` gets each retargeted call's result
/// expression and clone (its `CallResult` names the callee too).
fn retarget_calls(
    block: &mut Block,
    retarget: &[Retarget],
    results: &mut Vec<(Handle<Expression>, Handle<Function>)>,
) {
    for statement in block.iter_mut() {
        match statement {
            Statement::Call {
                function,
                arguments,
                result,
            } => {
                if let Some(r) = retarget
                    .iter()
                    .find(|r| r.callee == *function && r.arguments == *arguments)
                {
                    *function = r.clone;
                    if let Some(result) = result {
                        results.push((*result, r.clone));
                    }
                }
            }
            Statement::Block(inner) => retarget_calls(inner, retarget, results),
            Statement::If { accept, reject, .. } => {
                retarget_calls(accept, retarget, results);
                retarget_calls(reject, retarget, results);
            }
            Statement::Switch { cases, .. } => {
                for case in cases {
                    retarget_calls(&mut case.body, retarget, results);
                }
            }
            Statement::Loop {
                body, continuing, ..
            } => {
                retarget_calls(body, retarget, results);
                retarget_calls(continuing, retarget, results);
            }
            _ => {}
        }
    }
}

/// `block` with every `if` and `switch` on a known value replaced by the
/// branch taken (a `switch` only where the case taken has no `break` of
/// its own, which would leave an enclosing loop once the switch is gone).
fn fold_block(module: &Module, expressions: &naga::Arena<Expression>, block: &mut Block) {
    for statement in block.iter_mut() {
        let taken = match statement {
            Statement::If {
                condition,
                accept,
                reject,
            } => match evaluate(module, expressions, *condition) {
                Some(Literal::Bool(true)) => Some(std::mem::take(accept)),
                Some(Literal::Bool(false)) => Some(std::mem::take(reject)),
                _ => None,
            },
            Statement::Switch { selector, cases } => {
                evaluate(module, expressions, *selector).and_then(|value| case_taken(cases, value))
            }
            _ => None,
        };
        if let Some(taken) = taken {
            *statement = Statement::Block(taken);
        }
        match statement {
            Statement::Block(inner) => fold_block(module, expressions, inner),
            Statement::If { accept, reject, .. } => {
                fold_block(module, expressions, accept);
                fold_block(module, expressions, reject);
            }
            Statement::Switch { cases, .. } => {
                for case in cases {
                    fold_block(module, expressions, &mut case.body);
                }
            }
            Statement::Loop {
                body, continuing, ..
            } => {
                fold_block(module, expressions, body);
                fold_block(module, expressions, continuing);
            }
            _ => {}
        }
    }
}

/// The body `switch (value)` runs: the matching case (else the default),
/// through empty fall-through cases (WGSL's `case A, B:`); `None` where a
/// body falls through or breaks.
fn case_taken(cases: &mut [naga::SwitchCase], value: Literal) -> Option<Block> {
    let matches = |v: &SwitchValue| match (*v, value) {
        (SwitchValue::U32(a), Literal::U32(b)) => a == b,
        (SwitchValue::I32(a), Literal::I32(b)) => a == b,
        _ => false,
    };
    let start = cases
        .iter()
        .position(|c| matches(&c.value))
        .or_else(|| cases.iter().position(|c| c.value == SwitchValue::Default))?;
    let mut k = start;
    while cases[k].fall_through {
        if !cases[k].body.is_empty() || k + 1 == cases.len() {
            return None;
        }
        k += 1;
    }
    if breaks(&cases[k].body) {
        return None;
    }
    Some(std::mem::take(&mut cases[k].body))
}

/// Whether `block` has a `break` that leaves it (not one of a nested loop
/// or switch).
fn breaks(block: &Block) -> bool {
    block.iter().any(|s| match s {
        Statement::Break => true,
        Statement::Block(inner) => breaks(inner),
        Statement::If { accept, reject, .. } => breaks(accept) || breaks(reject),
        _ => false,
    })
}

/// The value of `handle` where it is known before the shader runs: a
/// literal, a constant, and the comparisons, bit and logical operations of
/// known integers and booleans.
fn evaluate(
    module: &Module,
    expressions: &naga::Arena<Expression>,
    handle: Handle<Expression>,
) -> Option<Literal> {
    match expressions[handle] {
        Expression::Literal(value) => Some(value),
        Expression::Constant(c) => match module.global_expressions[module.constants[c].init] {
            Expression::Literal(value) => Some(value),
            _ => None,
        },
        Expression::Unary {
            op: UnaryOperator::LogicalNot,
            expr,
        } => match evaluate(module, expressions, expr)? {
            Literal::Bool(b) => Some(Literal::Bool(!b)),
            _ => None,
        },
        Expression::Binary { op, left, right } => binary(
            op,
            evaluate(module, expressions, left)?,
            evaluate(module, expressions, right)?,
        ),
        _ => None,
    }
}

/// `a op b` for u32, i32 and bool operands.
fn binary(op: BinaryOperator, a: Literal, b: Literal) -> Option<Literal> {
    use BinaryOperator as B;
    let compare = |ordering: std::cmp::Ordering| match op {
        B::Equal => Some(ordering.is_eq()),
        B::NotEqual => Some(ordering.is_ne()),
        B::Less => Some(ordering.is_lt()),
        B::LessEqual => Some(ordering.is_le()),
        B::Greater => Some(ordering.is_gt()),
        B::GreaterEqual => Some(ordering.is_ge()),
        _ => None,
    };
    match (a, b) {
        (Literal::U32(x), Literal::U32(y)) => match op {
            B::And => Some(Literal::U32(x & y)),
            B::InclusiveOr => Some(Literal::U32(x | y)),
            B::ExclusiveOr => Some(Literal::U32(x ^ y)),
            _ => compare(x.cmp(&y)).map(Literal::Bool),
        },
        (Literal::I32(x), Literal::I32(y)) => match op {
            B::And => Some(Literal::I32(x & y)),
            B::InclusiveOr => Some(Literal::I32(x | y)),
            B::ExclusiveOr => Some(Literal::I32(x ^ y)),
            _ => compare(x.cmp(&y)).map(Literal::Bool),
        },
        (Literal::Bool(x), Literal::Bool(y)) => match op {
            B::LogicalAnd => Some(Literal::Bool(x && y)),
            B::LogicalOr => Some(Literal::Bool(x || y)),
            B::Equal => Some(Literal::Bool(x == y)),
            B::NotEqual => Some(Literal::Bool(x != y)),
            _ => None,
        },
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOURCE: &str = "
override OP: u32 = 0u;
@group(0) @binding(0) var<storage, read_write> out: array<f32>;
fn heavy(i: u32) -> f32 { return f32(i) * 3.0 + 1.0; }
fn light(i: u32) -> f32 { return f32(i) * 0.5; }
fn run(op: u32, flags: u32, i: u32) -> f32 {
    var r = 0.0;
    switch (op) {
        case 1u, 2u: { r = heavy(i); }
        case 3u: {
            if ((flags & 4u) != 0u) { r = light(i); } else { r = -light(i); }
        }
        default: { r = 7.0; }
    }
    return r;
}
@compute @workgroup_size(1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    out[gid.x] = run(OP, 4u, gid.x) + run(OP, 0u, gid.x);
}
@compute @workgroup_size(1)
fn other(@builtin(global_invocation_id) gid: vec3<u32>) {
    out[gid.x] = run(gid.y, gid.z, gid.x);
}
";

    /// The module of entry `entry` with `OP` = `op`, specialised and
    /// validated: its function names.
    fn specialised_names(entry: &str, op: u32) -> Vec<String> {
        let module = naga::front::wgsl::parse_str(SOURCE).expect("parses");
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .expect("valid");
        let mut constants = naga::back::PipelineConstants::default();
        constants.insert("OP".into(), f64::from(op));
        let (module, _) = naga::back::pipeline_constants::process_overrides(
            &module,
            &info,
            Some((naga::ShaderStage::Compute, entry)),
            &constants,
        )
        .expect("overrides");
        let module = constant_arguments(module.into_owned());
        let info = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .expect("the specialised module validates");
        naga::back::spv::write_vec(&module, &info, &Default::default(), None).expect("SPIR-V");
        let mut names: Vec<String> = module
            .functions
            .iter()
            .filter_map(|(_, f)| f.name.clone())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn only_the_branches_a_constant_selects_reach_the_driver() {
        // OP = 1: the fall-through case `1u, 2u` runs heavy; light is gone.
        assert_eq!(specialised_names("main", 1), ["heavy", "run", "run"]);
        // OP = 3: both flag values of `light`'s branch, no heavy.
        assert_eq!(specialised_names("main", 3), ["light", "run", "run"]);
        // OP = 9: the default, no callee left.
        assert_eq!(specialised_names("main", 9), ["run", "run"]);
    }

    #[test]
    fn arguments_known_only_when_the_shader_runs_keep_every_branch() {
        assert_eq!(specialised_names("other", 1), ["heavy", "light", "run"]);
    }

    #[test]
    fn a_case_that_breaks_is_not_folded() {
        let mut cases = vec![
            naga::SwitchCase {
                value: SwitchValue::U32(1),
                body: Block::from_vec(vec![Statement::Break]),
                fall_through: false,
            },
            naga::SwitchCase {
                value: SwitchValue::Default,
                body: Block::new(),
                fall_through: false,
            },
        ];
        assert!(case_taken(&mut cases, Literal::U32(1)).is_none());
        assert!(case_taken(&mut cases, Literal::U32(2)).is_some());
    }
}
