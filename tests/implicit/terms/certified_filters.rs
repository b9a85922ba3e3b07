//! The certified step filters against exact rational arithmetic: ball
//! pairs, planes and simplices (near touching, far from the origin).

use super::*;

fn q(x: f64) -> BigRational {
    BigRational::from_float(x).expect("finite")
}

/// Exact |y_j − y_i|² − (r_i + r_j)².
fn exact_pair_gap(yi: &[f64], yj: &[f64], radii: (f64, f64)) -> BigRational {
    let mut s = q(0.0);
    for a in 0..yi.len() {
        let e = q(yj[a]) - q(yi[a]);
        s += &e * &e;
    }
    let r = q(radii.0) + q(radii.1);
    s - &r * &r
}

/// fl(x + fl(t Δ)), the trial point of the documented formula.
fn trial(x: &[f64], delta: &[f64], t: f64) -> Vec<f64> {
    x.iter().zip(delta).map(|(x, d)| x + t * d).collect()
}

/// Trial fractions a line search may use from the filter fraction `t`.
fn trial_fractions(t: f64, rng: &mut Lcg) -> Vec<f64> {
    let mut ts = vec![t, t * (1.0 - EPS), t * 0.5, t * 0.25];
    ts.push(t * 0.5 * (1.0 + rng.next()));
    ts
}

#[test]
fn pair_filter_never_admits_contact_in_exact_arithmetic() {
    let mut rng = Lcg(1608);
    let (mut trials, mut admitted, mut violations, mut uncertified_violations) =
        (0u32, 0u32, 0u32, 0u32);
    let (mut worst_tightness, mut tightness_cases) = (0.0f64, 0u32);
    for case in 0..4000 {
        let dim = DIMS[case % DIMS.len()];
        let far = 10f64.powi([0, 3, 6, 9, 12][(case / 5) % 5]);
        let n = unit(dim, &mut rng);
        let center: Vec<f64> = (0..dim).map(|_| far * rng.next()).collect();
        let radii = (0.5 + 0.4 * rng.next(), 0.5 + 0.4 * rng.next());
        let rounding = (dim as f64 + 4.0) * EPS * (far + 2.0) * 4.0;
        let gap = rounding * 10f64.powf(6.0 * rng.next());
        let xi = center.clone();
        let xj: Vec<f64> = (0..dim)
            .map(|a| xi[a] + (radii.0 + radii.1 + gap) * n[a])
            .collect();
        if exact_pair_gap(&xi, &xj, radii) <= q(0.0) {
            continue;
        }
        let speed = gap * 10f64.powf(3.0 * rng.next());
        let mut steps = Vec::new();
        for side in [1.0, -1.0] {
            let tangent = unit(dim, &mut rng);
            steps.extend((0..dim).map(|a| speed * (side * 0.5 * n[a] + 0.5 * tangent[a])));
        }
        let mut points = xi.clone();
        points.extend(&xj);
        let t = fraction(pair_time(&points, radii, &steps, dim, EPS));
        // Uncertified control: the computed distance and approach alone.
        let length = (0..dim)
            .map(|a| (xj[a] - xi[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        let d0 = length - radii.0 - radii.1;
        let closing: f64 = (0..dim)
            .map(|a| -(xj[a] - xi[a]) / length * (steps[dim + a] - steps[a]))
            .sum();
        let naive = if closing > 0.0 {
            (0.9 * d0 / closing).min(1.0)
        } else {
            1.0
        };
        let yi = trial(&xi, &steps[..dim], naive);
        let yj = trial(&xj, &steps[dim..], naive);
        if exact_pair_gap(&yi, &yj, radii) <= q(0.0) {
            uncertified_violations += 1;
        }
        if t > 0.0 {
            admitted += 1;
            if d0 > 1e3 * rounding && closing > 0.0 && naive < 1.0 {
                // The certified cut costs the stated rounding and no more:
                // 1 − t/t_naive ≤ δd/d0 + γ|δ|/closing (first order).
                let gamma = (dim as f64 + 4.0) * EPS;
                let norm = |v: &[f64]| max_abs(v);
                let delta_d = gamma * (length + radii.0 + radii.1)
                    + dim as f64
                        * EPS
                        * (norm(&xi)
                            + norm(&xj)
                            + 2.0 * norm(&steps[..dim])
                            + 2.0 * norm(&steps[dim..]));
                let relative: f64 = (0..dim)
                    .map(|a| (steps[dim + a] - steps[a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let predicted = delta_d / d0 + gamma * relative / closing;
                tightness_cases += 1;
                worst_tightness = worst_tightness.max((1.0 - t / naive) / predicted);
            }
        }
        for s in trial_fractions(t, &mut rng) {
            trials += 1;
            let yi = trial(&xi, &steps[..dim], s);
            let yj = trial(&xj, &steps[dim..], s);
            if exact_pair_gap(&yi, &yj, radii) <= q(0.0) {
                violations += 1;
            }
        }
    }
    println!(
        "pair filter: {trials} trials, {admitted} cases admitted motion, {tightness_cases} far from contact; uncertified control violated {uncertified_violations}"
    );
    assert!(
        admitted > 1000 && tightness_cases > 100,
        "the certificate must not be vacuous"
    );
    assert!(
        uncertified_violations > 0,
        "the cases must be hard enough to defeat an uncertified filter"
    );
    bound(
        "pair filter: trials with exact d ≤ 0",
        violations as f64,
        0.0,
        "certified in floating point",
    );
    bound(
        "pair filter: (1 − t/t_uncertified) / (δd/d0 + γ|δ|/closing)",
        worst_tightness,
        1.01,
        "the cut is the stated rounding",
    );
}

/// Exact squared distance from p to the simplex `vertices` (rational
/// enumeration of faces: Gram solve, λ ≥ 0, minimum).
fn exact_simplex_distance_squared(p: &[f64], vertices: &[f64], dim: usize) -> BigRational {
    let count = vertices.len() / dim;
    let v = |j: usize, a: usize| q(vertices[j * dim + a]);
    let mut best: Option<BigRational> = None;
    for face in 1u32..(1 << count) {
        let members: Vec<usize> = (0..count).filter(|j| face & (1 << j) != 0).collect();
        let anchor = members[0];
        let rest = &members[1..];
        let m = rest.len();
        let mut g = vec![vec![q(0.0); m + 1]; m];
        for (s, &js) in rest.iter().enumerate() {
            for (t, &jt) in rest.iter().enumerate() {
                g[s][t] = (0..dim)
                    .map(|a| (v(js, a) - v(anchor, a)) * (v(jt, a) - v(anchor, a)))
                    .sum();
            }
            g[s][m] = (0..dim)
                .map(|a| (v(js, a) - v(anchor, a)) * (q(p[a]) - v(anchor, a)))
                .sum();
        }
        let mut singular = false;
        for c in 0..m {
            let Some(pivot_row) = (c..m).find(|&r| g[r][c] != q(0.0)) else {
                singular = true;
                break;
            };
            g.swap(c, pivot_row);
            for r in 0..m {
                if r != c {
                    let factor = g[r][c].clone() / g[c][c].clone();
                    for col in c..=m {
                        let sub = factor.clone() * g[c][col].clone();
                        g[r][col] -= sub;
                    }
                }
            }
        }
        if singular {
            continue;
        }
        let mu: Vec<BigRational> = (0..m).map(|s| g[s][m].clone() / g[s][s].clone()).collect();
        let anchor_weight = q(1.0) - mu.iter().cloned().sum::<BigRational>();
        if anchor_weight < q(0.0) || mu.iter().any(|x| *x < q(0.0)) {
            continue;
        }
        let mut d2 = q(0.0);
        for a in 0..dim {
            let mut r = q(p[a]) - anchor_weight.clone() * v(anchor, a);
            for (s, &js) in rest.iter().enumerate() {
                r -= mu[s].clone() * v(js, a);
            }
            d2 += &r * &r;
        }
        if best.as_ref().is_none_or(|b| d2 < *b) {
            best = Some(d2);
        }
    }
    best.expect("the closest vertex is always a candidate")
}

#[test]
fn obstacle_filters_are_certified_for_planes_and_simplices() {
    let mut rng = Lcg(1609);
    let (mut trials, mut admitted, mut violations, mut uncertified_violations) =
        (0u32, 0u32, 0u32, 0u32);
    for case in 0..1500 {
        let dim = [1, 2, 3, 4][case % 4];
        let far = 10f64.powi([0, 3, 6, 9][(case / 4) % 4]);
        let radius = 0.3 + 0.2 * rng.next();
        let normal = unit(dim, &mut rng);
        let mut obstacles = BarrierObstacles {
            plane_normals: normal.clone(),
            plane_offsets: vec![far * rng.next()],
            plane_source: vec![0],
            ..BarrierObstacles::default()
        };
        // A simplex (segment / triangle / tetrahedron, arity ≤ dim + 1) near the plane.
        let arity = (2 + case % 3).min(dim + 1);
        let base: Vec<f64> = (0..dim)
            .map(|a| normal[a] * obstacles.plane_offsets[0] + far * 1e-3 * rng.next())
            .collect();
        let mut vertices = Vec::new();
        for slot in 0..SIMPLEX_SLOTS {
            if slot < arity {
                vertices.extend(
                    (0..dim).map(|a| base[a] + rng.next() + if a + 1 == slot { 1.0 } else { 0.0 }),
                );
            } else {
                vertices.extend(std::iter::repeat_n(0.0, dim));
            }
        }
        obstacles.simplex_vertices = vertices;
        obstacles.simplex_arity = vec![arity as u32];
        obstacles.simplex_source = vec![(1, 0)];
        let rounding = (dim as f64 + 4.0) * EPS * (far + 4.0) * 8.0;
        let gap = rounding * 10f64.powf(3.0 * rng.next());
        // A particle just off the plane, or just off the simplex.
        let mut offset = vec![0.0; dim];
        let x: Vec<f64> = if case % 2 == 0 {
            (0..dim)
                .map(|a| base[a] + normal[a] * (radius + gap) + 0.0)
                .collect()
        } else {
            let simplex = obstacles.simplex(0, dim).to_vec();
            let centroid: Vec<f64> = (0..dim)
                .map(|a| (0..arity).map(|j| simplex[j * dim + a]).sum::<f64>() / arity as f64)
                .collect();
            let away = unit(dim, &mut rng);
            let mut x: Vec<f64> = (0..dim).map(|a| centroid[a] + 2.0 * away[a]).collect();
            let d = hyperpbd::geometry::closest_point_on_simplex(&x, &simplex, dim, &mut offset)
                .distance;
            for a in 0..dim {
                x[a] -= offset[a] / d * (d - radius - gap);
            }
            x
        };
        let side = (0..dim)
            .map(|a| q(normal[a]) * q(x[a]))
            .sum::<BigRational>()
            - q(obstacles.plane_offsets[0])
            - q(radius);
        if side <= q(0.0) {
            obstacles.plane_normals.iter_mut().for_each(|c| *c = -*c);
            obstacles.plane_offsets[0] = -obstacles.plane_offsets[0] - 1e3 * far.max(1.0);
        }
        let normal = obstacles.plane_normals.clone();
        let simplex_gap = |y: &[f64]| -> BigRational {
            exact_simplex_distance_squared(y, obstacles.simplex(0, dim), dim)
                - q(radius) * q(radius)
        };
        let plane_gap = |y: &[f64]| -> BigRational {
            (0..dim)
                .map(|a| q(normal[a]) * q(y[a]))
                .sum::<BigRational>()
                - q(obstacles.plane_offsets[0])
                - q(radius)
        };
        if plane_gap(&x) <= q(0.0) || simplex_gap(&x) <= q(0.0) {
            continue;
        }
        let speed = gap * 10f64.powf(3.0 * rng.next());
        let toward = unit(dim, &mut rng);
        let delta: Vec<f64> = (0..dim)
            .map(|a| speed * (toward[a] - 0.7 * normal[a]))
            .collect();
        let uncertified = filter_fraction(&obstacles, &x, radius, &delta);
        let y = trial(&x, &delta, uncertified);
        if plane_gap(&y) <= q(0.0) || simplex_gap(&y) <= q(0.0) {
            uncertified_violations += 1;
        }
        let trial_move = TrialMove {
            x: &x,
            radius,
            delta: &delta,
        };
        let t = fraction(obstacle_time(&obstacles, trial_move, EPS));
        let single = plane_time(&obstacles, 0, trial_move, EPS).min(simplex_time(
            &obstacles,
            0,
            trial_move,
            EPS,
            &mut offset,
        ));
        assert_eq!(fraction(single), t);
        if t > 0.0 {
            admitted += 1;
        }
        for s in trial_fractions(t, &mut rng) {
            trials += 1;
            let y = trial(&x, &delta, s);
            if plane_gap(&y) <= q(0.0) || simplex_gap(&y) <= q(0.0) {
                violations += 1;
            }
        }
    }
    println!(
        "obstacle filter: {trials} trials, {admitted} cases admitted motion; barrier::filter_fraction violated {uncertified_violations}"
    );
    assert!(admitted > 300, "the certificate must not be vacuous");
    assert!(
        uncertified_violations > 0,
        "the cases must be hard enough to defeat the uncertified filter"
    );
    bound(
        "obstacle filter: trials with exact d ≤ 0",
        violations as f64,
        0.0,
        "certified in floating point",
    );
}
