//! Obstacles and damping: friction, normals, compliance, rate.

use super::*;

#[test]
fn negative_friction() {
    let e = error(|s| *hyperplane(s).2 = -0.1);
    assert_eq!(
        e,
        SceneError::NegativeFriction {
            path: "obstacles[0].friction".into(),
            value: -0.1
        }
    );
}

#[test]
fn zero_normal() {
    let e = error(|s| *hyperplane(s).0 = vec![0.0, -0.0, 0.0]);
    assert_eq!(
        e,
        SceneError::ZeroNormal {
            path: "obstacles[0].normal".into()
        }
    );
}

#[test]
fn negative_obstacle_compliance() {
    let e = error(|s| *hyperplane(s).3 = -1.0);
    assert_eq!(
        e,
        SceneError::NegativeCompliance {
            path: "obstacles[0].compliance".into(),
            value: -1.0
        }
    );
}

#[test]
fn negative_damping_rate() {
    let e = error(|s| s.damping = Some(Damping { rate: -0.5 }));
    assert_eq!(
        e,
        SceneError::Negative {
            path: "damping.rate".into(),
            value: -0.5
        }
    );
}

#[test]
fn second_obstacle_is_named_by_its_index() {
    let e = error(|s| s.obstacles.push(plane(vec![0.0, 0.0])));
    assert_eq!(e, wrong_length("obstacles[1].normal", 2));
}
