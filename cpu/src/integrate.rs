//! Prediction, velocity reconstruction and damping.
//!
//! ```text
//! predict    for dynamic i: v_i += h (s_i g + w_i f_i);  p_i = x_i;  x_i += h v_i
//! velocity   for dynamic i: v_i = (x_i − p_i) / h
//! damping    for dynamic i: v_i *= exp(−rate h)        (factor from the plan)
//! ```
//! Fixed particles (w = 0) never move; p = x holds for them too.
//! Each returns the first particle that became non-finite, if any.

use hyperpbd_core::Plan;

/// Prediction. `p` receives the substep's start positions.
pub fn predict(
    plan: &Plan,
    x: &mut [f64],
    v: &mut [f64],
    p: &mut [f64],
    force: &[f64],
) -> Result<(), usize> {
    let dim = plan.dim;
    let h = plan.h;
    p.copy_from_slice(x);
    for (i, &w) in plan.inverse_mass.iter().enumerate() {
        if w == 0.0 {
            continue;
        }
        let s = plan.gravity_scale[i];
        let range = i * dim..(i + 1) * dim;
        let (vi, xi) = (&mut v[range.clone()], &mut x[range.clone()]);
        for a in 0..dim {
            let mut acc = 0.0;
            if plan.predict.gravity {
                acc += s * plan.gravity[a];
            }
            if plan.predict.force {
                acc += w * force[i * dim + a];
            }
            vi[a] += h * acc;
            xi[a] += h * vi[a];
        }
        if !(vi.iter().all(|c| c.is_finite()) && xi.iter().all(|c| c.is_finite())) {
            return Err(i);
        }
    }
    Ok(())
}

/// Velocity reconstruction.
pub fn velocity(plan: &Plan, x: &[f64], v: &mut [f64], p: &[f64]) -> Result<(), usize> {
    let dim = plan.dim;
    let h = plan.h;
    for (i, &w) in plan.inverse_mass.iter().enumerate() {
        if w == 0.0 {
            continue;
        }
        for a in i * dim..(i + 1) * dim {
            v[a] = (x[a] - p[a]) / h;
            if !v[a].is_finite() {
                return Err(i);
            }
        }
    }
    Ok(())
}

/// Exponential damping with the plan's per-substep factor.
pub fn damping(plan: &Plan, v: &mut [f64]) {
    let Some((_, factor)) = plan.damping else {
        return;
    };
    let dim = plan.dim;
    for (i, &w) in plan.inverse_mass.iter().enumerate() {
        if w > 0.0 {
            for c in &mut v[i * dim..(i + 1) * dim] {
                *c *= factor;
            }
        }
    }
}
