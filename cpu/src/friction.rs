//! Dynamic Coulomb friction against a hyperplane (velocity response).
//!
//! ```text
//! for each contact with λ > 0 in this substep:
//!   v_n = n·v;  v_t = v − v_n n               (complete tangent vector)
//!   Δv_max = μ · w λ / h                      (μ × normal velocity change)
//!   v −= v_t · min(Δv_max, |v_t|) / |v_t|     (one clamp on the norm)
//! ```

use hyperpbd_core::{Family, FamilyKind};

/// Applies friction of one contact family; returns the first particle whose
/// velocity became non-finite.
pub fn friction(
    dim: usize,
    h: f64,
    inverse_mass: &[f64],
    family: &Family,
    lambda: &[f64],
    v: &mut [f64],
) -> Result<(), usize> {
    let FamilyKind::HyperplaneContact { normal, friction } = &family.kind else {
        return Ok(());
    };
    for (e, &l) in lambda.iter().enumerate() {
        if l <= 0.0 {
            continue;
        }
        let i = family.elements[e] as usize;
        let vi = &mut v[i * dim..(i + 1) * dim];
        let vn = crate::project::dot(normal, vi);
        let mut t2 = 0.0;
        for a in 0..dim {
            let t = vi[a] - vn * normal[a];
            t2 += t * t;
        }
        let vt = t2.sqrt();
        if vt == 0.0 {
            continue;
        }
        let limit = friction * inverse_mass[i] * l / h;
        let scale = limit.min(vt) / vt;
        for a in 0..dim {
            let t = vi[a] - vn * normal[a];
            vi[a] -= t * scale;
        }
        if !vi.iter().all(|c| c.is_finite()) {
            return Err(i);
        }
    }
    Ok(())
}
