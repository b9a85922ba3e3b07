//! The Newton loop of the coupled step on the device (docs/implicit.md §7,
//! cpu/src/coupled/mod.rs `minimise`, decision for decision): the start
//! and warm start, the gradient pass and residual, PCG on the device
//! (pcg.rs), the pairs and the certified filter, Armijo trials, the
//! rounding floor.

use hyperpbd_core::barrier::BarrierObstacles;
use hyperpbd_core::implicit::line_search::{
    MAX_HALVINGS, after_failed_search, armijo, before_search,
};
use hyperpbd_core::implicit::resolution::{
    ball_rounding, ball_rounding_at, change_resolution_at, particle_sums, spring_rounding,
    spring_rounding_at,
};
use hyperpbd_core::implicit::{PcgSettings, certified_filter, newton_cg_tolerance, pair_lags};
use hyperpbd_core::{
    BackendError, Convergence, GpuError, MinimisationReport, MinimisationStatus, Refusal, WarmStart,
};

use super::device::Reduction;
use super::entries::status::{INFEASIBLE, MOVED, NON_FINITE_ELEMENT, NON_FINITE_PARTICLE};
use super::entries::{Entry, region};
use super::material;
use super::pcg::{Direction, PcgProbe, PcgStart};
use super::step::CoupledStep;
use crate::Precision;
use crate::barrier::{NONE, infeasible_start};
use crate::resident_backend::Resident;

/// How a Newton iteration's gradient pass ended.
enum Evaluated {
    /// The residual in the authored criterion.
    Residual(f64),
    /// An element's record is not finite (its index).
    Element(usize),
    /// A particle's gradient or energy is not finite.
    Particle(usize),
}

/// The coupled step at work on the resident state: the loop reads the
/// step's own data through `Deref` and the plan, device and state through
/// `on`.
pub(super) struct Newton<'a> {
    pub on: &'a mut Resident,
    pub step: &'a mut CoupledStep,
}

impl std::ops::Deref for Newton<'_> {
    type Target = CoupledStep;
    fn deref(&self) -> &CoupledStep {
        self.step
    }
}

impl std::ops::DerefMut for Newton<'_> {
    fn deref_mut(&mut self) -> &mut CoupledStep {
        self.step
    }
}

impl Newton<'_> {
    /// Particles, elements and material elements.
    fn items(&self) -> (usize, usize, usize) {
        let (n, e) = self.step.counts(self.on);
        (n, e, self.materials.len())
    }

    /// The Newton direction by PCG on the device (pcg.rs).
    fn solve(
        &mut self,
        settings: PcgSettings,
        started: Option<PcgStart>,
    ) -> Result<Direction, GpuError> {
        let items = self.items();
        let step = &mut *self.step;
        let on = (&mut step.device, &*self.on);
        step.pcg.solve(on, items, settings, started)
    }

    /// Armijo's trials of `steps` in one batch (trials.rs).
    fn trials(&mut self, steps: &[f64]) -> Result<Vec<(f64, bool)>, GpuError> {
        let items = self.items();
        let on = (&self.step.device, &*self.on);
        self.step.trial_probe.trials(on, items, steps)
    }

    /// The certified fraction of R_DIRECTION from R_X over every plane of
    /// every free particle and every ball pair (setup.rs `filter`).
    fn filter(&mut self) -> Result<f64, GpuError> {
        let (n, _) = self.step.counts(self.on);
        let pairs = self.pairs.len();
        let (values, _) = self.step.run(
            self.on,
            &[(Entry::FilterParticles, n), (Entry::FilterPairs, pairs)],
            &[Reduction::MinT],
        )?;
        Ok(certified_filter::fraction(values[0]))
    }

    /// The certified fraction (as [`Self::filter`]), then the elements at
    /// R_X and the slope g·Δ (cpu `slope`), with the status words, in one
    /// submission and one read.
    fn filter_and_slope(&mut self) -> Result<(f64, f64, [u32; 5]), GpuError> {
        let (n, e) = self.step.counts(self.on);
        let (pairs, m) = (self.pairs.len(), self.materials.len());
        self.device.write_params(&self.on.ctx);
        self.device.reset_status(&self.on.ctx);
        let mut encoder = self.on.encoder();
        let filter = {
            let mut pass = self.device.begin(&mut encoder);
            self.device.dispatch(&mut pass, Entry::FilterParticles, n);
            self.device.dispatch(&mut pass, Entry::FilterPairs, pairs);
            self.device.reduce_in(&mut pass, Reduction::MinT)
        };
        self.device
            .load_point(&mut encoder, &self.on.state, region::X);
        let slope = {
            let mut pass = self.device.begin(&mut encoder);
            self.device.dispatch(&mut pass, Entry::Elements, e);
            self.device.dispatch(&mut pass, Entry::MaterialElements, m);
            self.device.dispatch(&mut pass, Entry::Slope, n);
            self.device.reduce_in(&mut pass, Reduction::SumA)
        };
        let (values, status) = self.device.read(&self.on.ctx, encoder, &[filter, slope])?;
        Ok((certified_filter::fraction(values[0]), values[1], status))
    }

    /// Elements and gradient at R_X; the residual (cpu `residual`).
    ///
    /// Without material elements PCG's start at x_k (which needs nothing
    /// from the host: pcg.rs) is recorded in the same submission and read
    /// with the residual (one wait for both); its values are returned for
    /// [`GpuCoupledBackend::device_pcg`]. Its kernels write no status word
    /// there (only cp_material_frames would), so the words are the
    /// gradient's; when Newton stops here its writes (the CG vectors,
    /// R_DIRECTION = 0) are never read.
    fn gradient(&mut self) -> Result<(Evaluated, Option<PcgStart>), GpuError> {
        let (n, e) = self.step.counts(self.on);
        let reduction = match self.ip.convergence {
            Convergence::PackedGradient { .. } => Reduction::SumA,
            Convergence::MaxAccelerationResidual { .. } => Reduction::MaxA,
        };
        let m = self.materials.len();
        let with_start = m == 0;
        if with_start {
            PcgProbe::prepare_start(&mut self.step.device, self.on);
        }
        self.device.write_params(&self.on.ctx);
        self.device.reset_status(&self.on.ctx);
        let mut encoder = self.on.encoder();
        self.device
            .load_point(&mut encoder, &self.on.state, region::X);
        let residual = {
            let mut pass = self.device.begin(&mut encoder);
            self.device.dispatch(&mut pass, Entry::Elements, e);
            self.device.dispatch(&mut pass, Entry::MaterialElements, m);
            self.device.dispatch(&mut pass, Entry::Gradient, n);
            self.device.reduce_in(&mut pass, reduction)
        };
        // Copied out before PCG's r·r reuses the residual's channel.
        self.device.copy_result(&mut encoder, residual, 0);
        let mut results = vec![residual];
        if with_start {
            let start = {
                let mut pass = self.device.begin(&mut encoder);
                PcgProbe::record_start(&self.device, &mut pass, (n, e, m))
            };
            for (k, &result) in start.iter().enumerate() {
                self.device.copy_result(&mut encoder, result, k + 1);
            }
            results.extend(start);
        }
        let (values, status) = self.device.read_copied(&self.on.ctx, encoder, &results)?;
        let started = with_start.then(|| PcgStart {
            values: [values[1], values[2]],
            status,
        });
        if status[NON_FINITE_ELEMENT] != NONE {
            return Ok((
                Evaluated::Element(status[NON_FINITE_ELEMENT] as usize),
                None,
            ));
        }
        if status[NON_FINITE_PARTICLE] != NONE {
            return Ok((
                Evaluated::Particle(status[NON_FINITE_PARTICLE] as usize),
                None,
            ));
        }
        let residual = match reduction {
            Reduction::SumA => values[0].sqrt(),
            _ => values[0],
        };
        Ok((Evaluated::Residual(residual), started))
    }

    /// The rounding floor of F's change over R_DIRECTION from R_X
    /// (core's `implicit::resolution`, on the device's values read back):
    /// in f64 the golden path's terms, in f32 the `_at` forms at ε₃₂ with
    /// their second-order terms (f32.rs).
    fn resolution(&self) -> Result<f64, GpuError> {
        let dim = self.on.plan.dim;
        let epsilon = self.on.precision.epsilon();
        let single = self.on.precision == Precision::F32;
        let law = &self.ip.law;
        let spring = |value: f64, compliance: f64, rest: f64| {
            if single {
                spring_rounding_at(value, compliance, rest, dim, epsilon)
            } else {
                spring_rounding(value, compliance, rest, dim)
            }
        };
        let ball = |points: &[f64], radii: (f64, f64)| {
            if single {
                ball_rounding_at(law, points, radii, dim, epsilon)
            } else {
                ball_rounding(law, points, radii, dim)
            }
        };
        let v = self.device.read_regions(
            &self.on.ctx,
            &[
                region::X,
                region::DIRECTION,
                region::PREDICTION,
                region::LOAD,
            ],
        )?;
        let (terms, records) = self.device.read_terms_and_records(&self.on.ctx)?;
        let sums = particle_sums(
            dim,
            &self.mass,
            &v[0],
            &v[2],
            &v[3],
            &v[1],
            &terms,
            dim * dim + 2,
        );
        let (mut energy, mut force) = (0.0, 0.0);
        let up = &self.elements;
        let stride = self.device.record_len;
        let mut points = vec![0.0; up.lists.arity_max * dim];
        for e in 0..up.lists.len() {
            let value = records[e * stride];
            energy += value.abs();
            if let Some(block) = self.materials.of_element(e) {
                let arity = gather_points(up.lists.members(e), &v[0], dim, &mut points);
                force += material::rounding(&self.on.plan, block, &points[..arity * dim], value);
            } else if e < up.first_ball {
                let reals = &up.reals[e * (dim + 1)..];
                force += spring(value, reals[0], reals[1]);
            } else if e < up.first_ball + self.pairs.len() {
                let members = up.lists.members(e);
                gather_points(members, &v[0], dim, &mut points);
                let radii = (
                    self.on.plan.radius[members[0] as usize],
                    self.on.plan.radius[members[1] as usize],
                );
                force += ball(&points[..2 * dim], radii);
            }
        }
        Ok(change_resolution_at(
            dim,
            self.on.plan.h,
            sums,
            energy,
            force,
            epsilon,
        ))
    }

    /// Steps 1–4: x^t, x~, the lags and d ≤ 0 at x^t, the pairs at x^t,
    /// the warm start and its pairs. A refusal, if the start is refused.
    fn start(&mut self) -> Result<Option<Refusal>, BackendError> {
        let (n, _) = self.step.counts(self.on);
        let inertial = self.coupled.warm_start == WarmStart::Inertial;
        // Without collisions the inertial warm start's filter needs nothing
        // from the host: it runs in the start's submission (one read; the
        // filter writes no status word and is ignored on a refused start).
        let early_filter = inertial && !self.coupled.collisions;
        let (values, status) = if early_filter {
            let pairs = self.pairs.len();
            let entries = [
                (Entry::Start, n),
                (Entry::FilterParticles, n),
                (Entry::FilterPairs, pairs),
            ];
            self.step.run(self.on, &entries, &[Reduction::MinT])?
        } else {
            self.step.run(self.on, &[(Entry::Start, n)], &[])?
        };
        if status[INFEASIBLE] != NONE {
            let particle = status[INFEASIBLE] as usize;
            let state = self.on.state.read(&self.on.ctx)?;
            let obstacles: &BarrierObstacles = &self.ip.obstacles;
            return Ok(Some(infeasible_start(
                &self.on.plan,
                obstacles,
                state.position(particle),
                particle,
            )));
        }
        let dim = self.on.plan.dim;
        if self.coupled.collisions {
            // x^t (and x~ for the inertial warm start) in one read-back.
            let wanted: &[usize] = if inertial {
                &[region::START, region::PREDICTION]
            } else {
                &[region::START]
            };
            let v = self.device.read_regions(&self.on.ctx, wanted)?;
            let start = &v[0];
            let at_start = self.step.sweep(self.on, start, start);
            let (law, friction) = (&self.ip.law, self.coupled.pair_friction);
            let radius = &self.on.plan.radius;
            let lags = match pair_lags(law, friction, start, radius, dim, &at_start) {
                Ok(lags) => lags,
                Err(refusal) => return Ok(Some(refusal)),
            };
            let changed = lags != self.lags;
            self.lags = lags;
            // P_0: the pairs at x^t, or over the segment to x~ (§7 step 4).
            let pairs = if inertial {
                self.step.sweep(self.on, start, &v[1])
            } else {
                at_start
            };
            self.step.upload_elements(self.on, pairs, changed)?;
        }
        if !inertial {
            return Ok(None);
        }
        let tau = if early_filter {
            certified_filter::fraction(values[0])
        } else {
            self.filter()?
        };
        self.device.params.step = tau;
        self.device.params.mode = 0;
        self.step.submit(self.on, &[(Entry::SetX, n)])?;
        Ok(None)
    }

    /// Why element e could not be evaluated at R_X (cpu `element_refusal`):
    /// a material element's law refusal (x_k read back), else a non-finite
    /// value at its first particle.
    fn element_refusal(&self, e: usize) -> Result<Refusal, GpuError> {
        let members = self.elements.lists.members(e);
        if let Some(block) = self.materials.of_element(e) {
            let dim = self.on.plan.dim;
            let x = self.device.read_regions(&self.on.ctx, &[region::X])?;
            let mut points = vec![0.0; members.len() * dim];
            gather_points(members, &x[0], dim, &mut points);
            if let Some(refusal) = material::refusal(&self.on.plan, block, &points) {
                return Ok(refusal);
            }
        }
        Ok(Refusal::NonFinite {
            particle: members[0] as usize,
        })
    }

    /// One coupled minimisation (cpu/src/coupled/mod.rs `minimise`).
    pub(super) fn minimise(&mut self) -> Result<MinimisationReport, BackendError> {
        let mut report = MinimisationReport::before_first_iteration(self.ip.convergence);
        if let Some(refusal) = self.start()? {
            report.status = MinimisationStatus::Refused(refusal);
            return Ok(report);
        }
        let (n, _) = self.step.counts(self.on);
        let mut iteration = 0;
        let mut first_residual = None;
        let mut fell_back = false;
        loop {
            // 5: gradient and residual.
            let (evaluated, started) = self.gradient()?;
            let residual = match evaluated {
                Evaluated::Residual(r) => r,
                Evaluated::Element(e) => {
                    if iteration == 0 && !fell_back && self.warm_start_moved()? {
                        // 3: a warm start the elements refuse falls back to x^t.
                        fell_back = true;
                        self.device.params.mode = 1;
                        self.step.submit(self.on, &[(Entry::SetX, n)])?;
                        continue;
                    }
                    report.status = MinimisationStatus::Refused(self.element_refusal(e)?);
                    break;
                }
                Evaluated::Particle(particle) => {
                    report.status = MinimisationStatus::Refused(Refusal::NonFinite { particle });
                    break;
                }
            };
            let r0 = *first_residual.get_or_insert(residual);
            if report.record_residual(residual, iteration, self.ip.max_iterations) {
                break;
            }
            iteration += 1;
            // 6–7: H_F⁺ of every material element at x_k (cpu `curvatures`),
            // then the Newton direction by preconditioned CG (pcg.rs).
            let settings = PcgSettings {
                max_iterations: self.coupled.cg_iterations,
                relative_tolerance: 0.0,
                absolute_tolerance: newton_cg_tolerance(
                    self.ip.convergence,
                    residual,
                    r0,
                    &self.mass,
                    self.on.plan.h,
                ),
            };
            let cg = match self.solve(settings, started)? {
                Direction::Solved(cg) => cg,
                Direction::FrameRefused(e) => {
                    // Refused by the law or not finite at x_k.
                    report.status = MinimisationStatus::Refused(self.element_refusal(e)?);
                    break;
                }
            };
            report.cg_iterations.push(cg.iterations);
            if let Some(refusal) = cg.breakdown(iteration) {
                report.iterations = iteration;
                report.status = MinimisationStatus::Refused(refusal);
                break;
            }
            // 8–9: the pairs any trial can reach, and the certified fraction.
            if self.coupled.collisions {
                let v = self
                    .device
                    .read_regions(&self.on.ctx, &[region::X, region::DIRECTION])?;
                let reach: Vec<f64> = v[0].iter().zip(&v[1]).map(|(x, d)| x + d).collect();
                let pairs = self.step.sweep(self.on, &v[0], &reach);
                self.step.upload_elements(self.on, pairs, false)?;
            }
            // 10–11: Armijo on the difference form of F's change; the
            // filter and the slope in one submission (one read): the filter
            // writes no status word, and its minimum lands on its own channel.
            let (fraction, values, status) = self.filter_and_slope()?;
            if status[NON_FINITE_ELEMENT] != NONE {
                report.iterations = iteration;
                let refusal = self.element_refusal(status[NON_FINITE_ELEMENT] as usize)?;
                report.status = MinimisationStatus::Refused(refusal);
                break;
            }
            let slope = values;
            let moved = status[MOVED] != 0;
            if let Some(status) = before_search(moved, slope) {
                report.iterations = iteration;
                report.status = status;
                break;
            }
            let accepted = self.search(fraction, slope)?;
            if accepted.is_none() {
                report.iterations = iteration;
                let resolution = self.resolution()?;
                report.status = after_failed_search(slope, resolution, residual);
                break;
            }
            self.device.params.mode = 2;
            self.step.submit(self.on, &[(Entry::SetX, n)])?;
        }
        if !matches!(report.status, MinimisationStatus::Refused(_)) {
            self.step.submit(self.on, &[(Entry::Finish, n)])?;
        }
        Ok(report)
    }

    /// Whether x_0 differs from x^t (read back: only when the warm start
    /// is refused).
    fn warm_start_moved(&self) -> Result<bool, GpuError> {
        let v = self
            .device
            .read_regions(&self.on.ctx, &[region::X, region::START])?;
        Ok(v[0] != v[1])
    }

    /// core's `armijo` from `fraction` over trials evaluated in batches
    /// (trials.rs); R_TRIAL holds the accepted trial when there is one.
    fn search(&mut self, fraction: f64, slope: f64) -> Result<Option<f64>, GpuError> {
        let mut known: Vec<(f64, bool)> = Vec::new();
        // 1, 2, 4, … trials per batch: at most as many trials run in all
        // as the search asked for, doubled (the host-driven search's work),
        // and ⌈log₂⌉ reads instead of one per trial.
        let mut batch = 1;
        let mut asked = 0;
        let accepted = armijo(fraction, slope, |t| {
            if asked == known.len() {
                // t and its halvings, exactly as armijo halves it.
                let room = (MAX_HALVINGS as usize + 1 - asked).max(1);
                let mut steps = vec![t];
                while steps.len() < batch.min(room) {
                    steps.push(steps[steps.len() - 1] * 0.5);
                }
                known.extend(self.trials(&steps)?);
                batch = batch.saturating_mul(2);
            }
            asked += 1;
            Ok::<_, GpuError>(known[asked - 1])
        })?;
        if let Some(t) = accepted
            && asked < known.len()
        {
            // A later trial of the batch left R_TRIAL: the accepted one again.
            self.device.params.step = t;
            self.device.write_params(&self.on.ctx);
            let mut encoder = self.on.encoder();
            self.device
                .pass(&mut encoder, Entry::Trial, self.on.plan.particle_count());
            self.on.ctx.submit(encoder)?;
        }
        Ok(accepted)
    }
}

/// The points of an element with `members` at `x` into `points`
/// (arity × N); the arity.
fn gather_points(members: &[u32], x: &[f64], dim: usize, points: &mut [f64]) -> usize {
    for (j, &i) in members.iter().enumerate() {
        let i = i as usize;
        points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
    }
    members.len()
}
