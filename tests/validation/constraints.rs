//! Constraint families: compliance, indices, arity, rest values.

use super::*;

#[test]
fn negative_constraint_compliance() {
    let e = error(|s| s.constraints[1].compliance = -1e-9);
    assert_eq!(
        e,
        SceneError::NegativeCompliance {
            path: "constraints[1].compliance".into(),
            value: -1e-9
        }
    );
}

#[test]
fn index_out_of_range() {
    let e = error(|s| s.constraints[0].elements[1] = vec![2, 4]);
    assert_eq!(
        e,
        SceneError::IndexOutOfRange {
            path: "constraints[0].elements[1][1]".into(),
            index: 4,
            count: 4
        }
    );
    let e = error(|s| s.constraints[2].elements[0][3] = usize::MAX);
    assert_eq!(
        e,
        SceneError::IndexOutOfRange {
            path: "constraints[2].elements[0][3]".into(),
            index: usize::MAX,
            count: 4
        }
    );
}

#[test]
fn repeated_particle() {
    let e = error(|s| s.constraints[1].elements[0] = vec![0, 2, 0]);
    assert_eq!(
        e,
        SceneError::RepeatedParticle {
            path: "constraints[1].elements[0][2]".into(),
            particle: 0
        }
    );
    let e = error(|s| s.constraints[0].elements[0] = vec![3, 3]);
    assert_eq!(
        e,
        SceneError::RepeatedParticle {
            path: "constraints[0].elements[0][1]".into(),
            particle: 3
        }
    );
}

fn arity(path: &str, kind: &'static str, expected: &str, found: usize) -> SceneError {
    SceneError::WrongArity {
        path: path.into(),
        kind,
        expected: expected.into(),
        found,
    }
}

#[test]
fn tether_arity_and_rest() {
    let e = error(|s| {
        as_tether(s);
        s.constraints[0].elements[1] = vec![2];
    });
    assert_eq!(e, arity("constraints[0].elements[1]", "tether", "2", 1));
    let e = error(|s| {
        as_tether(s);
        s.constraints[0].rest = Some(vec![1.0, -0.5]);
    });
    assert_eq!(
        e,
        SceneError::DegenerateRest {
            path: "constraints[0].rest[1]".into(),
            why: "a rest length must be >= 0".into()
        }
    );
    let mut ok = base();
    as_tether(&mut ok);
    ok.validate()
        .expect("a tether family like the distance family is valid");
}

#[test]
fn distance_arity() {
    let e = error(|s| s.constraints[0].elements[1] = vec![2]);
    assert_eq!(e, arity("constraints[0].elements[1]", "distance", "2", 1));
    let e = error(|s| s.constraints[0].elements[0] = vec![0, 1, 2]);
    assert_eq!(e, arity("constraints[0].elements[0]", "distance", "2", 3));
}

#[test]
fn simplex_measure_arity_outside_range() {
    let expected = "k + 1 with 1 <= k <= 3 (2..=4)";
    let e = error(|s| s.constraints[1].elements[0] = vec![0]);
    assert_eq!(
        e,
        arity("constraints[1].elements[0]", "simplex_measure", expected, 1)
    );
    let e = error(|s| {
        s.particles.push(Particle::new(vec![1.0, 1.0, 1.0], 1.0));
        s.constraints[1].elements[0] = vec![0, 1, 2, 3, 4];
    });
    assert_eq!(
        e,
        arity("constraints[1].elements[0]", "simplex_measure", expected, 5)
    );
}

#[test]
fn simplex_measure_mixed_k_in_one_family() {
    let e = error(|s| s.constraints[1].elements = vec![vec![0, 2, 3], vec![0, 2]]);
    assert_eq!(
        e,
        arity(
            "constraints[1].elements[1]",
            "simplex_measure",
            "3 (one k per family, as in elements[0])",
            2
        )
    );
}

#[test]
fn oriented_measure_arity() {
    let e = error(|s| s.constraints[2].elements[0] = vec![0, 2, 3]);
    assert_eq!(
        e,
        arity(
            "constraints[2].elements[0]",
            "oriented_measure",
            "4 (dim + 1)",
            3
        )
    );
}

#[test]
fn rest_count_mismatch() {
    let e = error(|s| s.constraints[0].rest = Some(vec![1.0]));
    assert_eq!(
        e,
        SceneError::RestCountMismatch {
            path: "constraints[0].rest".into(),
            expected: 2,
            found: 1
        }
    );
    let e = error(|s| s.constraints[1].rest = Some(vec![]));
    assert_eq!(
        e,
        SceneError::RestCountMismatch {
            path: "constraints[1].rest".into(),
            expected: 1,
            found: 0
        }
    );
}

fn degenerate(path: &str, why: &str) -> SceneError {
    SceneError::DegenerateRest {
        path: path.into(),
        why: why.into(),
    }
}

#[test]
fn negative_rest_length() {
    let e = error(|s| s.constraints[0].rest = Some(vec![1.0, -0.5]));
    assert_eq!(
        e,
        degenerate("constraints[0].rest[1]", "a rest length must be >= 0")
    );
}

#[test]
fn negative_simplex_rest() {
    let e = error(|s| s.constraints[1].rest = Some(vec![-1e-12]));
    assert_eq!(
        e,
        degenerate("constraints[1].rest[0]", "a squared measure must be >= 0")
    );
}

#[test]
fn zero_oriented_rest() {
    let e = error(|s| s.constraints[2].rest = Some(vec![0.0]));
    assert_eq!(
        e,
        degenerate(
            "constraints[2].rest[0]",
            "an oriented rest measure of zero has no orientation to preserve"
        )
    );
}

#[test]
fn zero_volume_authored_oriented_simplex() {
    // Particle 3 moved into the plane of 1, 0, 2: volume exactly 0.
    let e = error(|s| s.particles[3].position = vec![0.25, 1.5, 0.0]);
    match &e {
        SceneError::DegenerateRest { path, why } => {
            assert_eq!(path, "constraints[2].elements[0]");
            assert!(
                why.starts_with("the authored simplex has signed volume"),
                "{why}"
            );
            assert!(why.contains("degeneracy floor"), "{why}");
        }
        other => panic!("expected DegenerateRest, got {other:?}"),
    }
    // Nearly flat (relative volume 1e-14 < 1e-12) is degenerate too.
    let e = error(|s| s.particles[3].position = vec![0.25, 1.5, 1e-14]);
    assert!(
        matches!(&e, SceneError::DegenerateRest { path, .. } if path == "constraints[2].elements[0]"),
        "{e:?}"
    );
}
