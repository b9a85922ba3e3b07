//! JSON mutations: byte-level and structured edits of the shipped scene
//! documents never panic the loader, and the unmutated documents load.

use super::*;

// ---------------------------------------------------------------- JSON mutations

const DOCUMENT: &str = include_str!("../../../scenes/example.json");

/// Every document the mutations start from: the example (constraints,
/// friction, damping), balls with particle contact, the barrier path
/// with a hyperplane and segment / triangle (with friction) / tetrahedron meshes, and
/// bending (both models) with an expression family (ln, exp, a param, a
/// relation), and
/// the conveyor with prescribed motion (a belt, pins on a circle and
/// keyframes).
const DOCUMENTS: [&str; 5] = [
    DOCUMENT,
    include_str!("../../../fuzz/seeds/scene_json/balls.json"),
    include_str!("../../../fuzz/seeds/scene_json/barrier_mesh.json"),
    include_str!("../../../fuzz/seeds/scene_json/bending.json"),
    include_str!("../../../fuzz/seeds/scene_json/motion.json"),
];

/// Replacement tokens: numbers at and beyond the edges of every type, and
/// values of the wrong type.
const TOKENS: &[&str] = &[
    // Hostile expressions: a syntax error, a wrong det, names that are
    // not there, a deep let chain.
    "\"x0 +\"",
    "\"det(x0)\"",
    "\"norm(x9 - y)\"",
    "\"let a = x0[0]; let a = a * a; let a = a * a; let a = a * a; let a = a * a; a\"",
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "0.5",
    "-2.5",
    "1e-320",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e400",
    "-1e400",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999",
    "null",
    "true",
    "false",
    "\"x\"",
    "\"distance\"",
    "\"hyperplane\"",
    "[]",
    "[0]",
    "[0,1,2,3]",
    "[[0,1]]",
    "{}",
    "{\"rate\": 1}",
    "\"tether\"",
    "\"simplex_mesh\"",
    "\"xpbd\"",
    "{\"type\": \"xpbd\", \"iterations\": 20}",
    "\"incremental_potential\"",
    "\"packed_gradient\"",
    "\"max_acceleration_residual\"",
    "{\"friction\": 0.5, \"margin\": 0.1}",
    "[[0,1,2]]",
    "[[0,0,0],[1,0,0]]",
    // Motions: each kind, a plane with equal axes, times out of order.
    "[{\"type\": \"translate\", \"velocity\": [1, 0, 0]}]",
    "[{\"type\": \"rotate\", \"plane\": [0, 0], \"center\": [0, 0, 0], \"rate\": 1}]",
    "[{\"type\": \"rotate\", \"plane\": [1, 9], \"center\": [0, 0, 0], \"rate\": 1e308}]",
    "[{\"type\": \"keyframes\", \"times\": [1, 0], \"translations\": [[0, 0, 0], [1, 0, 0]]}]",
    "[{\"type\": \"keyframes\", \"times\": [], \"translations\": []}]",
    "\"translate\"",
    "\"rotate\"",
    "\"keyframes\"",
];

const KEYS: &[&str] = &[
    "dim",
    "dt",
    "substeps",
    "iterations",
    "gravity",
    "particles",
    "constraints",
    "obstacles",
    "damping",
    "position",
    "velocity",
    "mass",
    "fixed",
    "radius",
    "gravity_scale",
    "force",
    "type",
    "compliance",
    "elements",
    "rest",
    "normal",
    "offset",
    "friction",
    "rate",
    "collisions",
    "margin",
    "solver",
    "barrier_stiffness",
    "activation_distance",
    "convergence",
    "kind",
    "tolerance",
    "max_iterations",
    "vertices",
    "simplices",
    "motion",
    "plane",
    "center",
    "times",
    "translations",
    "bogus",
    "",
];

#[derive(Debug, Clone)]
enum Mutation {
    /// Replace the byte at (position mod len) with `byte`.
    SetByte(usize, u8),
    /// Delete the byte at (position mod len).
    DeleteByte(usize),
    /// Insert `byte` before (position mod len).
    InsertByte(usize, u8),
    /// Truncate to (position mod len) bytes.
    Truncate(usize),
    /// Insert `"key": token,` after the (k mod count)-th `{`.
    InsertKey(usize, usize, usize),
    /// Replace the (k mod count)-th number with a token.
    SwapNumber(usize, usize),
    /// Replace the (k mod count)-th value after a colon with a token.
    SwapValue(usize, usize),
    /// Duplicate the bytes in [a, b) (mod len) at b.
    Duplicate(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let byte = prop_oneof![
        prop::sample::select(b"{}[],:\"0123456789.-+eE ntfx\\".to_vec()),
        any::<u8>(),
    ];
    prop_oneof![
        (any::<usize>(), byte.clone()).prop_map(|(p, b)| Mutation::SetByte(p, b)),
        any::<usize>().prop_map(Mutation::DeleteByte),
        (any::<usize>(), byte).prop_map(|(p, b)| Mutation::InsertByte(p, b)),
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), 0..KEYS.len(), 0..TOKENS.len())
            .prop_map(|(k, key, token)| Mutation::InsertKey(k, key, token)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(k, t)| Mutation::SwapNumber(k, t)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(k, t)| Mutation::SwapValue(k, t)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::Duplicate(a, b)),
    ]
}

/// Byte ranges of the numbers in `text`.
fn numbers(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        let starts = c.is_ascii_digit() || (c == b'-' && i + 1 < text.len());
        let in_string = text[..i].iter().filter(|&&b| b == b'"').count() % 2 == 1;
        if starts && !in_string {
            let start = i;
            i += 1;
            while i < text.len() && (text[i].is_ascii_digit() || b".eE+-".contains(&text[i])) {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

/// Byte ranges of the values that follow a `:` (up to the next `,` `}` or
/// `]` at the same nesting level).
fn values(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (colon, _) in text.iter().enumerate().filter(|(_, b)| **b == b':') {
        let start = colon + 1;
        let mut depth = 0i32;
        let mut end = start;
        let mut in_string = false;
        while end < text.len() {
            let c = text[end];
            if in_string {
                if c == b'"' {
                    in_string = false;
                }
            } else {
                match c {
                    b'"' => in_string = true,
                    b'[' | b'{' => depth += 1,
                    b']' | b'}' if depth == 0 => break,
                    b']' | b'}' => depth -= 1,
                    b',' if depth == 0 => break,
                    _ => {}
                }
            }
            end += 1;
        }
        out.push((start, end));
    }
    out
}

fn splice(text: &mut Vec<u8>, (start, end): (usize, usize), with: &[u8]) {
    text.splice(start..end, with.iter().copied());
}

fn apply(text: &mut Vec<u8>, m: &Mutation) {
    let len = text.len().max(1);
    match *m {
        Mutation::SetByte(p, b) => {
            if !text.is_empty() {
                text[p % len] = b;
            }
        }
        Mutation::DeleteByte(p) => {
            if !text.is_empty() {
                text.remove(p % len);
            }
        }
        Mutation::InsertByte(p, b) => text.insert(p % len, b),
        Mutation::Truncate(p) => text.truncate(p % len),
        Mutation::InsertKey(k, key, token) => {
            let braces: Vec<usize> = (0..text.len()).filter(|&i| text[i] == b'{').collect();
            if !braces.is_empty() {
                let at = braces[k % braces.len()] + 1;
                let insert = format!("\"{}\": {}, ", KEYS[key], TOKENS[token]);
                splice(text, (at, at), insert.as_bytes());
            }
        }
        Mutation::SwapNumber(k, token) => {
            let spans = numbers(text);
            if !spans.is_empty() {
                splice(text, spans[k % spans.len()], TOKENS[token].as_bytes());
            }
        }
        Mutation::SwapValue(k, token) => {
            let spans = values(text);
            if !spans.is_empty() {
                let with = format!(" {}", TOKENS[token]);
                splice(text, spans[k % spans.len()], with.as_bytes());
            }
        }
        Mutation::Duplicate(a, b) => {
            let (a, b) = (a % len, b % len);
            let (a, b) = (a.min(b), a.max(b).min(text.len()));
            let copy: Vec<u8> = text[a..b].to_vec();
            splice(text, (b, b), &copy);
        }
    }
}

/// Loads `text` and checks the answer; for scenes that load, also compiles
/// and steps them (small dimensions only: a huge `dim` with no vectors is a
/// known Plan::compile allocation panic, see tests/validation/known_gaps.rs;
/// and small substep × iteration counts only, so every case is quick).
fn check_document(text: &str) -> Result<(), TestCaseError> {
    match Scene::from_json_str(text) {
        Ok(scene) => {
            prop_assert!(scene.validate().is_ok());
            // Stepping is bounded work only for modest settings (a swapped
            // number may ask for 4294967295 substeps).
            let newton = match &scene.solver {
                hyperpbd::Solver::IncrementalPotential(ip) => u64::from(ip.max_iterations),
                _ => 1,
            };
            let work = u64::from(scene.substeps)
                .saturating_mul(u64::from(scene.iterations))
                .saturating_mul(newton);
            if scene.dim <= 16 && scene.particles.len() <= 64 && work <= 10_000 {
                run_checked(&scene, 2)?;
            }
        }
        Err(SceneError::Json { path, message }) => {
            prop_assert!(!path.is_empty(), "empty path: {}", message);
            prop_assert!(!message.is_empty(), "empty message at {}", path);
        }
        Err(e) => {
            let shown = e.to_string();
            prop_assert!(!shown.is_empty());
            // Every validation message starts with the field it names.
            prop_assert!(
                shown.contains(": "),
                "validation message without a path: {}",
                shown
            );
            let is_io = matches!(e, SceneError::Io { .. });
            prop_assert!(!is_io, "an I/O error from a string: {}", shown);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 1500,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_documents_never_panic(
        document in 0..DOCUMENTS.len(),
        mutations in proptest::collection::vec(mutation(), 1..=4),
    ) {
        let mut text = DOCUMENTS[document].as_bytes().to_vec();
        for m in &mutations {
            apply(&mut text, m);
        }
        let text = String::from_utf8_lossy(&text).into_owned();
        check_document(&text)?;
    }

    #[test]
    fn structured_edits_never_panic(
        document in 0..DOCUMENTS.len(),
        swaps in proptest::collection::vec((any::<usize>(), 0..TOKENS.len(), any::<bool>()), 1..=3),
        key in proptest::option::of((any::<usize>(), 0..KEYS.len(), 0..TOKENS.len())),
    ) {
        // Only edits that keep the document well-formed JSON, so nearly
        // every case reaches the schema and validation checks.
        let mut text = DOCUMENTS[document].as_bytes().to_vec();
        for (k, token, number) in swaps {
            let m = if number {
                Mutation::SwapNumber(k, token)
            } else {
                Mutation::SwapValue(k, token)
            };
            apply(&mut text, &m);
        }
        if let Some((k, key, token)) = key {
            apply(&mut text, &Mutation::InsertKey(k, key, token));
        }
        let text = String::from_utf8(text).expect("ASCII edits keep UTF-8");
        check_document(&text)?;
    }
}

#[test]
fn every_unmutated_document_loads_and_steps() {
    for text in DOCUMENTS {
        let scene = Scene::from_json_str(text).expect("valid");
        run_checked(&scene, 2).expect("steps");
    }
}

#[test]
fn the_unmutated_document_loads() {
    let scene = Scene::from_json_str(DOCUMENT).expect("valid");
    assert_eq!(scene.particles.len(), 4);
    assert!(!numbers(DOCUMENT.as_bytes()).is_empty());
    assert_eq!(
        values(DOCUMENT.as_bytes()).len(),
        DOCUMENT.matches(':').count()
    );
}

/// A fixed particle (w = 0) still receives `x += w·∇C·Δλ = ±0.0` from the
/// projection, and −0.0 + 0.0 = +0.0: a fixed coordinate authored as −0.0
/// changes its bit pattern after one step although nothing moved.
#[test]
fn fixed_negative_zero_keeps_its_sign() {
    let mut scene = Scene::new(1, 0.01, 1, 1);
    scene.particles = vec![Particle::fixed(vec![-0.0]), Particle::new(vec![1.0], 1.0)];
    scene.constraints = vec![ConstraintFamily {
        kind: ConstraintKind::Distance,
        compliance: 0.0,
        elements: vec![vec![0, 1]],
        rest: Some(vec![0.5]),
        ..ConstraintFamily::new(ConstraintKind::Distance, 0.0, Vec::new())
    }];
    let mut backend = hyperpbd::cpu_backend(&scene).expect("valid");
    backend.step().expect("step");
    let state = backend.read_state().expect("read");
    assert_eq!(state.positions[0].to_bits(), (-0.0f64).to_bits());
}
