//! The coupled step in f32 (docs/implicit.md §12): what changes against
//! f64, and why a step still never brings a ball to d ≤ 0.
//!
//! ```text
//! storage      x, v, x~, Δ … in f32, relative to the scene origin o (gpu/src/origin.rs:
//!              x_world = x_stored + o exactly in f64); the host reads them back as f64
//! filter       cp_filter_particles / cp_filter_pairs take ε = ε₃₂ from the params
//!              (γ = (N + 4) ε₃₂, ρ = N ε₃₂ (‖x‖∞ + 2‖Δ‖∞)) on the stored f32 values
//!              and device coordinates, so §5's certificate holds in f32: every trial
//!              y = fl₃₂(x + fl₃₂(tΔ)) has exact d(y) ≥ (1 − η)(d0 − δd) > 0 for the
//!              stored geometry (t = min(1, η t*) read back in f64 and rounded to f32 for
//!              the kernel: one relative u₃₂, inside η = 0.9)
//! radii        stored rounded outward (r̂ ≥ r, `outward_radii`): ℓ − r_i − r_j ≥
//!              ℓ − r̂_i − r̂_j, so a pair gap certified > 0 in f32 is > 0 with the
//!              authored radii too; ball pairs and planes against r, likewise
//! floor        change_resolution_at / spring_rounding_at / ball_rounding_at with ε₃₂
//!              (the per-particle force terms are formed by the kernel with its ε)
//! convergence  the authored criterion and tolerance, evaluated on the device in f32;
//!              the f32 iterate usually cannot reach an f64 tolerance, so its step ends
//!              at RoundingFloor (no trial decreases F beyond ε₃₂'s resolution) or
//!              BudgetExhausted (both keep the iterate); NoDescent is still a refusal
//! trust        none: the device's f32 residual is not used as evidence; the host
//!              recomputes ∇F in f64 at the returned iterate (hyperpbd_verify::compare_coupled)
//! ```
//! The plane's stored f32 normal and offset are the authored ones rounded
//! once (relative u₃₂, the offset after the exact origin shift); the
//! certificate is for that stored plane, and the tests check every gap
//! against the authored one in f64.

/// `radii` as f32 bytes, each rounded toward +∞ (r̂ ≥ r, r̂ − r ≤ ulp₃₂(r)).
pub(super) fn outward_radii(radii: &[f64]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(radii.len() * 4);
    for &r in radii {
        let mut stored = r as f32;
        if f64::from(stored) < r {
            stored = stored.next_up();
        }
        bytes.extend_from_slice(&stored.to_le_bytes());
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::outward_radii;

    #[test]
    fn radii_round_outward() {
        let radii = [0.0, 0.1, 0.05, 0.02, 1.0 / 3.0, 1e-30];
        let bytes = outward_radii(&radii);
        for (k, &r) in radii.iter().enumerate() {
            let stored = f32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().expect("4"));
            assert!(f64::from(stored) >= r, "{r}");
            assert!(
                f64::from(stored) - r <= f64::from(f32::EPSILON) * r.max(1e-38),
                "{r}"
            );
        }
    }
}
