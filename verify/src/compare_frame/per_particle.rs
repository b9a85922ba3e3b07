//! The per-particle count of [`FrameErrorModel`] (module docs of
//! `compare_frame`): plans whose particles move independently, each
//! particle's roundings counted at its own binade on the axes that move.

use hyperpbd_core::{Backend, BackendError, FamilyKind, Kernel, State};

use super::{Contact, Decision, FrameErrorModel, Tally};

/// b(x) = 2^⌊log₂ x⌋ for x ≥ `tiny` (exact: the exponent bits of x), else
/// `tiny`: ½ ulp(y) ≤ u b(x) for every |y| ≤ x.
fn binade(x: f64, tiny: f64) -> f64 {
    if x.is_nan() {
        x
    } else if x <= tiny {
        tiny
    } else {
        f64::from_bits(x.to_bits() & 0xfff0_0000_0000_0000)
    }
}

impl FrameErrorModel {
    /// Raises `mags[i]` to particle i's largest |x_a − o_a| over `axes` in
    /// `positions`.
    fn magnitudes(&self, positions: &[f64], axes: &[bool], mags: &mut [f64]) {
        let n = self.origin.len().max(1);
        for (m, p) in mags.iter_mut().zip(positions.chunks_exact(n)) {
            for ((x, o), _) in p.iter().zip(&self.origin).zip(axes).filter(|(_, a)| **a) {
                *m = m.max((x - o).abs());
            }
        }
    }

    /// The per-particle count (module docs) of a plan whose particles move
    /// independently; the probe is at the frame's start.
    pub(super) fn per_particle_count(
        &mut self,
        states: &[&State],
        speed: f64,
    ) -> Result<(f64, f64), BackendError> {
        let start = states[0];
        let plan = self.probe.plan().clone();
        let (h, u, n) = (plan.h, self.unit_roundoff, plan.dim);
        let root_n = (n as f64).sqrt();
        let scale = self.device_scale(states);
        let mut axes = self.plan_axes.clone();
        for (i, v) in start.velocities.chunks_exact(n.max(1)).enumerate() {
            if plan.inverse_mass[i] > 0.0 {
                for (m, v) in axes.iter_mut().zip(v) {
                    *m |= *v != 0.0;
                }
            }
        }
        // Errors as Euclidean norms per particle when a contact mixes the
        // moved axes: a fresh error vector of m coordinates, each ≤ ρ, is
        // ≤ √m ρ long.
        let moved = axes.iter().filter(|a| **a).count() as f64;
        let spread = if self.planes > 0 && moved > 1.0 {
            moved.sqrt()
        } else {
            1.0
        };
        let q = spread * (u * speed * self.velocity_roundings + 4.0 * u * h * self.acceleration);
        // The uniform count (every particle at X with every contact acting):
        // a margin for what is read before this substep's count is known.
        let worst = spread * (u * scale * self.position_roundings + 2.0 * u * h * speed);
        let flip_rounding = spread * (2.0 * n as f64 + 8.0) * u * scale;
        let mut frame_mags = vec![0.0; plan.particle_count()];
        for s in states {
            self.magnitudes(&s.positions, &axes, &mut frame_mags);
        }
        let (mut ex, mut ev) = (0.0f64, 0.0f64);
        for _ in 0..plan.substeps {
            let error_hi = ex + h * (ev + q) + worst;
            let substep_start = self.probe.read_state()?.positions;
            let mut mags = frame_mags.clone();
            // Predict lands one rounding on every dynamic particle.
            let mut tally = Tally {
                counts: plan
                    .inverse_mass
                    .iter()
                    .map(|w| if *w > 0.0 { 1.0 } else { 0.0 })
                    .collect(),
                c_rounding: vec![0.0; plan.particle_count()],
                unit_roundoff: u,
                origin: &self.origin,
                error_reach: error_hi,
            };
            let mut decisions: Vec<Decision> = Vec::new();
            for &kernel in &plan.substep_kernels {
                let contact = match kernel {
                    Kernel::Project { family, color } => match &plan.families[family].kind {
                        FamilyKind::HyperplaneContact { normal, friction } => Some((
                            family,
                            Contact {
                                plan: &plan,
                                f: &plan.families[family],
                                normal,
                                friction: *friction,
                                color,
                            },
                        )),
                        _ => None,
                    },
                    _ => None,
                };
                if let Some((family, contact)) = contact {
                    let before = self.probe.read_state()?.positions;
                    let lambda_before = self.probe.multipliers(family).unwrap_or(&[]).to_vec();
                    self.probe.run_kernel(kernel)?;
                    // |n·δx| ≤ |δx| (a Euclidean error), and C's own rounding
                    // (2N + 3) u (|n·x| + |r|), both ≤ √N X near C = 0.
                    let reach = error_hi + root_n * (4.0 * n as f64 + 6.0) * u * scale;
                    let lambda = self.probe.multipliers(family).unwrap_or(&[]);
                    contact.count(&before, &lambda_before, lambda, reach, &mut tally);
                    contact.between(
                        &before,
                        &axes,
                        &self.origin,
                        &lambda_before,
                        lambda,
                        &mut mags,
                    );
                    contact.decisions(&before, &substep_start, lambda, &mut decisions);
                } else {
                    self.probe.run_kernel(kernel)?;
                }
                let after = self.probe.read_state()?.positions;
                self.magnitudes(&after, &axes, &mut mags);
            }
            let tiny = self.tiny;
            let margin = |m: f64| binade(m + error_hi, tiny);
            let r = spread
                * ((mags.iter().zip(&tally.counts).zip(&tally.c_rounding))
                    .map(|((m, c), dc)| u * margin(*m) * c + dc)
                    .fold(0.0, f64::max)
                    + 2.0 * u * h * speed);
            let error = ex + h * (ev + q) + r;
            // x − p of an independent particle: h v + this substep's
            // roundings, with one plane; with more, an earlier plane's
            // correction carries its normal error into x − p.
            let error_t = if self.planes > 1 {
                error
            } else {
                h * (ev + q) + r
            };
            let jump = decisions
                .iter()
                .filter(|(t, stick, mu)| (t - stick).abs() <= error_t + mu * error + flip_rounding)
                .map(|(t, stick, _)| t.max(*stick))
                .fold(0.0, f64::max);
            ex = error + jump;
            ev += q + (r + jump) / h;
        }
        Ok((ex, ev))
    }
}
