//! Round trip: a scene written as JSON and read back is the same scene,
//! bit for bit (random finite values, the built-in scenes, the example,
//! negative zero).

use super::*;

// ---------------------------------------------------------------- round trip

/// Every f64 of a scene, as bits, in a fixed order.
fn bits(s: &Scene) -> Vec<u64> {
    let mut out = vec![s.dt.to_bits()];
    let mut v = |xs: &[f64]| out.extend(xs.iter().map(|x| x.to_bits()));
    v(s.gravity.as_deref().unwrap_or(&[]));
    for p in &s.particles {
        v(&p.position);
        v(p.velocity.as_deref().unwrap_or(&[]));
        v(&[
            p.mass.unwrap_or(f64::NAN),
            p.radius,
            p.gravity_scale,
            f64::from(u8::from(p.fixed)),
        ]);
        v(p.force.as_deref().unwrap_or(&[]));
    }
    for c in &s.constraints {
        v(&[c.compliance]);
        v(c.rest.as_deref().unwrap_or(&[]));
    }
    for o in &s.obstacles {
        let Obstacle::Hyperplane {
            normal,
            offset,
            friction,
            compliance,
            ..
        } = o
        else {
            continue;
        };
        v(normal);
        v(&[*offset, *friction, *compliance]);
    }
    if let Some(d) = &s.damping {
        v(&[d.rate]);
    }
    out
}

fn assert_round_trip(s: &Scene) {
    let text = s.to_json_string();
    let back = Scene::parse_json(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(&back, s);
    assert_eq!(bits(&back), bits(s), "bit patterns differ:\n{text}");
    assert_eq!(
        back.to_json_string(),
        text,
        "serialization is not idempotent"
    );
}

/// Finite f64 values from random bit patterns (xorshift; deterministic).
fn random_finite(state: &mut u64) -> f64 {
    loop {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        let x = f64::from_bits(*state);
        if x.is_finite() {
            return x;
        }
    }
}

#[test]
fn round_trip_is_bit_exact() {
    let awkward = [
        0.1,
        0.1 + 0.2,
        1.0 / 3.0,
        std::f64::consts::PI,
        -std::f64::consts::E,
        5e-324,
        -5e-324,
        f64::MIN_POSITIVE,
        f64::MAX,
        f64::MIN,
        1e308,
        f64::EPSILON,
        1.0 + f64::EPSILON,
        123_456_789.123_456_79,
        -0.0,
        9_007_199_254_740_993.0,
    ];
    let dim = 4;
    let mut s = Scene::new(dim, 0.1 + 0.2, 7, 3);
    s.gravity = Some(vec![1.0 / 3.0, -9.81, 5e-324, -0.0]);
    let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
    for (i, &x) in awkward.iter().enumerate() {
        let mut p = Particle::new(
            vec![x, -x, random_finite(&mut seed), i as f64],
            0.1 + i as f64 / 3.0,
        )
        .with_velocity(vec![random_finite(&mut seed), x, 0.0, -0.0])
        .with_force(vec![x / 7.0, 1e-300, -1e300, random_finite(&mut seed)])
        .with_radius(if x > 0.0 { x } else { 0.5 })
        .with_gravity_scale(-x);
        if i % 5 == 4 {
            p.fixed = true;
            p.velocity = None;
        }
        s.particles.push(p);
    }
    for _ in 0..200 {
        s.particles.push(Particle::new(
            (0..dim).map(|_| random_finite(&mut seed)).collect(),
            random_finite(&mut seed).abs(),
        ));
    }
    s.constraints = vec![
        ConstraintFamily {
            kind: ConstraintKind::Distance,
            compliance: 1e-7 / 3.0,
            elements: vec![vec![0, 1], vec![2, 3]],
            rest: Some(vec![0.1 + 0.2, 5e-324]),
            ..ConstraintFamily::new(ConstraintKind::Distance, 0.0, Vec::new())
        },
        ConstraintFamily::new(ConstraintKind::SimplexMeasure, 0.0, vec![vec![0, 1, 2]]),
        ConstraintFamily {
            kind: ConstraintKind::OrientedMeasure,
            compliance: f64::MIN_POSITIVE,
            elements: vec![vec![4, 3, 2, 1, 0]],
            rest: Some(vec![-1.0 / 3.0]),
            ..ConstraintFamily::new(ConstraintKind::OrientedMeasure, 0.0, Vec::new())
        },
    ];
    s.obstacles = vec![
        Obstacle::Hyperplane {
            normal: vec![0.1, 0.2, 0.3, -0.0],
            offset: -1.0 / 3.0,
            friction: std::f64::consts::FRAC_1_SQRT_2,
            compliance: 1e-9 / 7.0,
            motion: Vec::new(),
        },
        Obstacle::Hyperplane {
            normal: vec![0.0, 0.0, 0.0, 1.0],
            offset: 0.0,
            friction: 0.0,
            compliance: 0.0,
            motion: Vec::new(),
        },
    ];
    s.damping = Some(Damping { rate: 0.1 + 0.7 });
    assert_round_trip(&s);

    // Through the validating loader too (a valid variant of the same data).
    let mut valid = s.clone();
    valid.particles.truncate(awkward.len());
    for p in &mut valid.particles {
        p.position = p.position.iter().map(|x| x.clamp(-1e6, 1e6)).collect();
        p.force = None;
    }
    valid.constraints.truncate(2);
    let text = valid.to_json_string();
    let back = Scene::from_json_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(bits(&back), bits(&valid));
}

#[test]
fn built_in_scenes_round_trip() {
    for name in hyperpbd::scenes::NAMES {
        let s = hyperpbd::scenes::by_name(name).expect("built-in scene");
        assert_round_trip(&s);
        Scene::from_json_str(&s.to_json_string()).expect("valid after the round trip");
    }
}

#[test]
fn example_round_trips() {
    let s = Scene::from_json_str(EXAMPLE).expect("example");
    assert_round_trip(&s);
}

/// `radius` is omitted when it equals 0.0, and −0.0 == 0.0, so a radius of
/// −0.0 comes back as +0.0 (harmless for the physics, but not bit-exact).
#[test]
fn negative_zero_radius_round_trips() {
    let mut s = Scene::new(1, 0.1, 1, 1);
    s.particles
        .push(Particle::new(vec![0.0], 1.0).with_radius(-0.0));
    assert_round_trip(&s);
}
