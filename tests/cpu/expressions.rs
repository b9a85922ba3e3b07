//! Expression families on the CPU: every built-in non-material kind
//! written as an expression follows its built-in over whole runs within a
//! derived bound; the f32 reference runs the same projection code in f32;
//! the golden path gives the same bytes on any thread count; bad
//! expressions are typed scene errors naming the field and position; a
//! value that turns non-finite is a typed step error with the state rolled
//! back; a ∇C that is undefined makes no response.

use crate::common;

use common::expressions::as_expressions;

use hyperpbd::kinds::Relation;
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, CpuBackend, F32Reference, Obstacle,
    Plan, Scene, SceneError, State, StepError, scenes,
};

const U: f64 = f64::EPSILON / 2.0;

fn run(scene: &Scene, frames: usize, threads: usize) -> State {
    let plan = Plan::compile(scene).unwrap_or_else(|e| panic!("compiles: {e}"));
    let mut cpu =
        CpuBackend::with_threads(plan, &State::from_scene(scene), threads).expect("loads");
    if threads > 1 {
        cpu = cpu.with_max_chunk(7);
    }
    for frame in 0..frames {
        cpu.step().unwrap_or_else(|e| panic!("frame {frame}: {e}"));
    }
    cpu.read_state().expect("state")
}

fn largest_difference(a: &State, b: &State) -> f64 {
    a.positions
        .iter()
        .zip(&b.positions)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The built-in and its expression differ only in the rounding of C and
/// ∇C (a few ulps of each: the expression's √ and its derived 1/(2√s)·2d
/// against the built-in's d/ℓ). Each projection moves a particle by at most
/// its correction |Δx| ≤ L (the scene's extent), so one projection's
/// difference is ≤ k·u·L with k ≈ 8 operations rounded; over
/// frames × substeps × iterations projections per element, each touching a
/// particle at most `degree` times, the difference is bounded by
/// k·u·L·frames·substeps·iterations·degree when the motion does not
/// amplify it (a damped, settling cloth or chain: the measured ratio is
/// printed beside the bound).
fn bound(scene: &Scene, frames: usize, degree: usize) -> f64 {
    let extent = scene.extent();
    8.0 * U
        * extent
        * (frames * scene.substeps as usize * scene.iterations as usize * degree) as f64
}

#[test]
fn distance_and_tether_as_expressions_follow_the_built_ins() {
    let frames = 40;
    let cloth = scenes::cloth(16);
    let expressed = as_expressions(
        &cloth,
        ConstraintKind::Distance,
        "norm(x1 - x0)",
        Relation::Equal,
    );
    let (a, b) = (run(&cloth, frames, 1), run(&expressed, frames, 1));
    let (measured, limit) = (largest_difference(&a, &b), bound(&cloth, frames, 4));
    common::bound::print_bound(
        "expression distance vs distance, cloth 16²",
        measured,
        limit,
        "rounding of C and ∇C",
    );
    assert!(measured <= limit, "{measured} > {limit}");
    assert!(measured > 0.0 || a.hash() == b.hash());

    let mut chain = scenes::chain2d();
    for family in &mut chain.constraints {
        if family.kind == ConstraintKind::Distance {
            family.kind = ConstraintKind::Tether;
        }
    }
    let tethered = as_expressions(
        &chain,
        ConstraintKind::Tether,
        "norm(x1 - x0)",
        Relation::AtMost,
    );
    let (a, b) = (run(&chain, frames, 1), run(&tethered, frames, 1));
    let (measured, limit) = (largest_difference(&a, &b), bound(&chain, frames, 2));
    common::bound::print_bound(
        "expression <= vs tether, chain2d",
        measured,
        limit,
        "rounding of C and ∇C",
    );
    assert!(measured <= limit, "{measured} > {limit}");
}

#[test]
fn measures_and_a_plane_as_expressions_follow_the_built_ins() {
    let frames = 30;
    // The tesseract's oriented 4-simplices: det(x1−x0, …, x4−x0)/4!.
    let tesseract = scenes::tesseract();
    assert_eq!(tesseract.dim, 4);
    let oriented = as_expressions(
        &tesseract,
        ConstraintKind::OrientedMeasure,
        "det(x1 - x0, x2 - x0, x3 - x0, x4 - x0) / 24",
        Relation::Equal,
    );
    let (a, b) = (run(&tesseract, frames, 1), run(&oriented, frames, 1));
    let (measured, limit) = (largest_difference(&a, &b), bound(&tesseract, frames, 24));
    common::bound::print_bound(
        "expression det vs oriented_measure, tesseract",
        measured,
        limit,
        "rounding of C and ∇C",
    );
    assert!(measured <= limit, "{measured} > {limit}");

    // Triangles' squared area det(EᵀE)/(2!)² by the Gram expansion, and the
    // hyperplane y ≥ 0 as dot(n, x0) ≥ offset + radius per particle (the
    // plane without friction: an expression carries no friction).
    let mut sheet = scenes::cloth(8);
    for obstacle in &mut sheet.obstacles {
        if let Obstacle::Hyperplane { friction, .. } = obstacle {
            *friction = 0.0;
        }
    }
    let triangles: Vec<Vec<usize>> = (0..7)
        .flat_map(|r| (0..7).map(move |c| vec![r * 8 + c, r * 8 + c + 1, (r + 1) * 8 + c]))
        .collect();
    sheet.constraints.push(ConstraintFamily::new(
        ConstraintKind::SimplexMeasure,
        1e-7,
        triangles,
    ));
    let squared_area = "let a = x1 - x0; let b = x2 - x0; \
                        (dot(a, a) * dot(b, b) - dot(a, b) * dot(a, b)) / 4";
    let mut expressed = as_expressions(
        &sheet,
        ConstraintKind::SimplexMeasure,
        squared_area,
        Relation::Equal,
    );
    let Some(Obstacle::Hyperplane { normal, offset, .. }) = sheet.obstacles.first().cloned() else {
        panic!("the cloth has a ground plane")
    };
    let dynamic: Vec<Vec<usize>> = (0..sheet.particles.len())
        .filter(|&i| !sheet.particles[i].fixed)
        .map(|i| vec![i])
        .collect();
    let rest: Vec<f64> = dynamic
        .iter()
        .map(|e| offset + sheet.particles[e[0]].radius)
        .collect();
    let mut plane =
        ConstraintFamily::expression("dot(n, x0)", 0.0, dynamic).with_relation(Relation::AtLeast);
    let norm = normal.iter().map(|v| v * v).sum::<f64>().sqrt();
    let unit: Vec<serde_json::Value> = normal.iter().map(|v| (v / norm).into()).collect();
    plane.params = Some(serde_json::Map::from_iter([("n".to_string(), unit.into())]));
    plane.rest = Some(rest);
    expressed.obstacles.clear();
    expressed.constraints.push(plane);
    let (a, b) = (run(&sheet, frames, 1), run(&expressed, frames, 1));
    let (measured, limit) = (largest_difference(&a, &b), bound(&sheet, frames, 10));
    common::bound::print_bound(
        "expression Gram det and plane vs built-ins, cloth 8²",
        measured,
        limit,
        "rounding of C and ∇C",
    );
    assert!(measured <= limit, "{measured} > {limit}");
}

#[test]
fn an_expression_family_gives_the_same_bytes_on_any_thread_count() {
    // 48² cloth: colours of ~1,100 elements, split in chunks of 7 on two threads.
    let cloth = as_expressions(
        &scenes::cloth(48),
        ConstraintKind::Distance,
        "let d = x1 - x0; sqrt(dot(d, d))",
        Relation::Equal,
    );
    let one = run(&cloth, 12, 1);
    let two = run(&cloth, 12, 2);
    common::check_byte_identical(
        "expression cloth, 1 vs 2 threads",
        &one,
        &two,
        "disjoint colour chunks",
    );
}

#[test]
fn the_f32_reference_runs_expression_families_within_f32_rounding() {
    let frames = 30;
    let chain = as_expressions(
        &scenes::chain2d(),
        ConstraintKind::Distance,
        "norm(x1 - x0)",
        Relation::Equal,
    );
    let golden = run(&chain, frames, 1);
    let plan = Plan::compile(&chain).expect("compiles");
    let origin = vec![0.0; chain.dim];
    let mut reference =
        F32Reference::new(plan, &State::from_scene(&chain), &origin).expect("loads");
    for _ in 0..frames {
        reference.step().expect("f32 step");
    }
    let f32_state = reference.read_state();
    let measured = largest_difference(&golden, &f32_state);
    // f32 rounding of the same dynamics: u₃₂·L per projection, the chain's
    // stiff links keep it from growing (tests/cpu/f32_reference.rs measures the
    // built-in chain at 1.2e-5 m over 60 frames).
    let limit = 1e-3 * chain.extent();
    common::bound::print_bound(
        "f32 reference vs golden, expression chain",
        measured,
        limit,
        "f32 rounding",
    );
    assert!(measured > 0.0 && measured <= limit, "{measured}");
    // And a shifted origin is refused by name: an expression need not be
    // translation-invariant.
    let plan = Plan::compile(&chain).expect("compiles");
    let shifted = vec![1024.0; chain.dim];
    let refusal = F32Reference::new(plan, &State::from_scene(&chain), &shifted).err();
    assert!(format!("{refusal:?}").contains("expression"), "{refusal:?}");
}

fn chain_with(value: &str, params: Option<serde_json::Value>) -> Scene {
    let mut scene = scenes::chain2d();
    let elements = scene.constraints[0].elements.clone();
    let mut family = ConstraintFamily::expression(value, 0.0, elements);
    family.params = params.map(|p| p.as_object().expect("object").clone());
    scene.constraints.push(family);
    scene
}

#[test]
fn bad_expressions_are_scene_errors_naming_the_field_and_position() {
    let index = scenes::chain2d().constraints.len();
    let path = format!("constraints[{index}].value");
    let cases: [(&str, Option<serde_json::Value>, &str); 7] = [
        ("norm(x1 - x0", None, "at 1:13: syntax error"),
        ("norm(x1 - y)", None, "at 1:11: unknown name `y`"),
        ("norm(x2 - x0)", None, "at 1:6: particle x2 does not exist"),
        ("x1 - x0", None, "expected a scalar, found a vector"),
        ("det(x1, x0, x1)", None, "det"),
        (
            "dot(c, x0)",
            Some(serde_json::json!({"c": [1.0, 2.0, 3.0]})),
            "c",
        ),
        ("sqrt(x0)", None, "expected a scalar, found a vector"),
    ];
    for (value, params, expected) in cases {
        let error = chain_with(value, params).validate().expect_err(value);
        let message = error.to_string();
        assert!(
            matches!(error, SceneError::Expression { .. }),
            "{value}: {error:?}"
        );
        assert!(message.starts_with(&path), "{value}: {message}");
        assert!(
            message.contains(expected),
            "{value}: `{message}` lacks `{expected}`"
        );
    }
    // Keys that belong to other kinds, a missing value, a non-number param.
    let mut scene = scenes::chain2d();
    scene.constraints[0].value = Some("norm(x1 - x0)".into());
    assert!(
        scene
            .validate()
            .unwrap_err()
            .to_string()
            .contains("constraints[0].value: not used by distance")
    );
    let mut scene = chain_with("norm(x1 - x0)", None);
    scene.constraints[index].value = None;
    assert!(
        scene
            .validate()
            .unwrap_err()
            .to_string()
            .contains(&format!("{path}: expression families need this key"))
    );
    let scene = chain_with("norm(x1 - x0)", Some(serde_json::json!({"c": "up"})));
    assert!(
        scene
            .validate()
            .unwrap_err()
            .to_string()
            .contains(&format!("constraints[{index}].params.c"))
    );
}

#[test]
fn the_implicit_path_takes_expression_families() {
    // Their springs' ∇²C is derived at load (tests/implicit/expressions.rs
    // runs them).
    let mut scene = chain_with("norm(x1 - x0)", None);
    for family in &mut scene.constraints {
        family.compliance = 1e-6;
    }
    scene.damping = None;
    scene.solver = serde_json::from_str(
        r#"{"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 0.1,
            "convergence": {"kind": "packed_gradient", "tolerance": 1e-9}, "max_iterations": 20}"#,
    )
    .expect("solver");
    scene.validate().expect("valid on the implicit path");
}

#[test]
fn a_value_that_turns_non_finite_fails_the_step_and_rolls_it_back() {
    // sqrt(ℓ² − 4) of a 0.1 m link is the square root of a negative number
    // once the rest value no longer hides it: rest 0 set by hand.
    let mut scene = chain_with("sqrt(dot(x1 - x0, x1 - x0) - 1)", None);
    let index = scene.constraints.len() - 1;
    let count = scene.constraints[index].elements.len();
    scene.constraints[index].rest = Some(vec![0.0; count]);
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut cpu = CpuBackend::new(plan, &state).expect("loads");
    let error = cpu.step().expect_err("a NaN value");
    match &error {
        BackendError::Step(StepError::NonFiniteConstraint {
            family_label,
            element,
            ..
        }) => {
            assert_eq!(family_label, &format!("constraints[{index}]"));
            assert_eq!(*element, 0);
        }
        other => panic!("unexpected error {other:?}"),
    }
    let after = cpu.read_state().expect("state");
    common::check_byte_identical(
        "state after a refused expression step",
        &state,
        &after,
        "rollback",
    );
}

#[test]
fn an_undefined_gradient_makes_no_response() {
    // Two coincident particles: norm's gradient is 0/0 there. The element
    // is skipped (no response), as the built-in distance skips it.
    let mut scene = chain_with("norm(x1 - x0)", None);
    let index = scene.constraints.len() - 1;
    let [a, b] = scene.constraints[index].elements[3][..] else {
        panic!("pairs")
    };
    scene.particles[b].position = scene.particles[a].position.clone();
    scene.constraints[index].rest = Some(vec![0.0; scene.constraints[index].elements.len()]);
    let state = run(&scene, 3, 1);
    assert!(state.positions.iter().all(|x| x.is_finite()));
}

#[test]
fn the_plan_prints_an_expression_family_as_compiled() {
    let scene = chain_with("let d = x1 - x0; norm(d)", None);
    let plan = Plan::compile(&scene).expect("compiles");
    let family = plan
        .families
        .iter()
        .find(|f| f.kind.is_expression())
        .expect("expression");
    let hyperpbd::FamilyKind::Expression(kind) = &family.kind else {
        unreachable!()
    };
    let stats = kind.stats();
    assert_eq!(stats.inputs, 4);
    assert!(stats.value_ops > 0 && stats.gradient_ops > stats.value_ops);
    assert_eq!(kind.relation, Relation::Equal);
}
