//! Contact forces of the XPBD step on the device: the golden path's own
//! recorder (core's `impulse_recorder.rs`) replayed over the device's
//! states, copied out around the kernels it measures.
//!
//! ```text
//! request   the events of a step, in the exact schedule's order (one
//!           dispatch per call):
//!             before a measured call    x or v           (what `before` reads)
//!             after it                  x or v, λ, p     (`after`; λ of a mesh,
//!                                                        p of a moving obstacle)
//!             at each substep's end     λ, x, p          (`end_substep`; x with a
//!                                                        mesh, p with motion)
//!           and one mappable tape that holds every copy of a step
//! step      the exact schedule, a compute pass between copies, one wait;
//!           then the tape is mapped and the recorder replays the events
//!           in order, with each substep's motion (core's, the values the
//!           Motion kernel's blocks hold)
//! ```
//! gpu-f64 stores positions without an origin, so where its states are the
//! golden path's bit for bit (lavapipe) its forces are too. gpu-f32's
//! states are widened (x + o in f64) and the recorder runs in f64 over
//! them. Cost, only when asked: the copies (`ForceTape::bytes` per step),
//! the exact schedule instead of the chosen one, one more mapping per
//! step.

use hyperpbd_core::impulse_recorder::{ImpulseRecorder, Measured, measured};
use hyperpbd_core::motion::{SubstepMotion, substep_time};
use hyperpbd_core::{ContactForces, FamilyKind, GpuError, Kernel, Plan};

use crate::Precision;
use crate::context::GpuContext;
use crate::params::{read_reals, real_size};
use crate::resident::ResidentState;
use crate::resident_backend::Resident;

use super::program::Program;

/// A buffer the recorder reads.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Snap {
    X,
    V,
    Lambda,
    P,
}

/// When the recorder looks.
#[derive(Debug, Clone, Copy, PartialEq)]
enum What {
    /// Before a measured kernel's dispatch.
    Before(Kernel),
    /// After it.
    After(Kernel),
    /// At the end of its substep, after its last call.
    End,
}

impl What {
    /// The buffers this event copies out: what the recorder reads there
    /// (λ for a mesh's normal, p for a moving obstacle's work, x for a
    /// mesh's normal at the substep's end); it does not read the rest.
    fn snaps(self, plan: &Plan) -> Vec<Snap> {
        let moving = |family: usize| {
            (plan.motion.as_ref())
                .is_some_and(|m| m.plane_of(family).is_some() || m.mesh_of(family).is_some())
        };
        let mesh =
            |family: usize| matches!(plan.families[family].kind, FamilyKind::MeshContact { .. });
        let with = |first: Snap, extra: &[(bool, Snap)]| {
            let rest = extra.iter().filter(|e| e.0).map(|e| e.1);
            std::iter::once(first).chain(rest).collect()
        };
        match self {
            What::Before(kernel) => match measured(plan, kernel) {
                Some(Measured::PlaneVelocities { .. }) => vec![Snap::V],
                Some(Measured::PlanePositions { .. } | Measured::Positions) | None => {
                    vec![Snap::X]
                }
            },
            What::After(kernel) => match measured(plan, kernel) {
                Some(Measured::PlanePositions { family }) => with(
                    Snap::X,
                    &[(mesh(family), Snap::Lambda), (moving(family), Snap::P)],
                ),
                Some(Measured::PlaneVelocities { family }) => {
                    with(Snap::V, &[(moving(family), Snap::P)])
                }
                Some(Measured::Positions) | None => vec![Snap::X],
            },
            What::End => {
                let families = || plan.obstacle_families.iter().flatten().copied();
                let x = families().any(mesh);
                with(
                    Snap::Lambda,
                    &[(x, Snap::X), (families().any(moving), Snap::P)],
                )
            }
        }
    }
}

/// One look of the recorder: copies before dispatch `at` of the exact
/// schedule (its length: after the last), at `offset` of the tape.
#[derive(Debug, Clone)]
struct Event {
    at: usize,
    substep: u32,
    what: What,
    snaps: Vec<Snap>,
    offset: u64,
}

/// The device buffers the events copy.
struct Sources {
    x: wgpu::Buffer,
    v: wgpu::Buffer,
    lambda: wgpu::Buffer,
    p: wgpu::Buffer,
}

/// The events of a step, their tape, and the recorder that replays them.
pub(crate) struct ForceTape {
    events: Vec<Event>,
    /// Dispatch indices with copies before them, ascending, once each.
    stops: Vec<usize>,
    sources: Sources,
    /// Bytes of a particle vector (x, v, p) and of λ.
    sizes: (u64, u64),
    tape: wgpu::Buffer,
    bytes: u64,
    recorder: ImpulseRecorder,
    /// λ of family f at `lambda[starts[f]..starts[f + 1]]` (the device's
    /// slot order is the golden path's).
    starts: Vec<usize>,
    precision: Precision,
}

impl ForceTape {
    /// The events of the step `program` runs on `on` (its exact schedule)
    /// and a tape for them; refused (typed) when the tape would exceed the
    /// device's buffer limit.
    pub fn new(on: &Resident, program: &Program) -> Result<ForceTape, GpuError> {
        let (plan, state, precision) = (&on.plan, &on.state, on.precision);
        let (schedule, exact) = (&program.schedule, &program.exact);
        let per_substep = schedule.kernels_per_substep.max(1);
        let mut looks = Vec::new();
        for (at, placed) in exact.iter().enumerate() {
            let call = placed.dispatch.first_call as usize;
            if call >= schedule.step_calls {
                continue;
            }
            let substep = (call / per_substep) as u32;
            if let Some(kernel) = schedule.kernel_of(call as u32)
                && measured(plan, kernel).is_some()
            {
                looks.push((at, substep, What::Before(kernel)));
                looks.push((at + 1, substep, What::After(kernel)));
            }
            if (call + 1).is_multiple_of(per_substep) {
                looks.push((at + 1, substep, What::End));
            }
        }
        let particles = state.packing.particle_bytes() * plan.particle_count() as u64;
        let slots = plan.families.iter().map(|f| f.len()).sum::<usize>();
        let sizes = (particles, (slots * real_size(precision)) as u64);
        let mut offset = 0;
        let mut events = Vec::with_capacity(looks.len());
        for (at, substep, what) in looks {
            let snaps = what.snaps(plan);
            let size = snaps.iter().map(|&s| size_of(s, sizes)).sum::<u64>();
            events.push(Event {
                at,
                substep,
                what,
                snaps,
                offset,
            });
            offset += size;
        }
        let mut stops: Vec<usize> = events.iter().map(|e| e.at).collect();
        stops.dedup();
        let tape = on.ctx.staging("contact_forces_tape", offset.max(16))?;
        let sources = Sources {
            x: state.x.clone(),
            v: state.v.clone(),
            lambda: program.lambda.clone(),
            p: program.p.clone(),
        };
        let mut starts = vec![0];
        for f in &plan.families {
            starts.push(starts[starts.len() - 1] + f.len());
        }
        Ok(ForceTape {
            events,
            stops,
            sources,
            sizes,
            tape,
            bytes: offset,
            recorder: ImpulseRecorder::new(plan),
            starts,
            precision,
        })
    }

    /// Bytes copied out per step.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Dispatch indices with copies before them (ascending).
    pub fn stops(&self) -> &[usize] {
        &self.stops
    }

    /// Records the copies of the events before dispatch `at`.
    pub fn copy(&self, encoder: &mut wgpu::CommandEncoder, at: usize) {
        for event in self.events.iter().filter(|e| e.at == at) {
            let mut offset = event.offset;
            for &snap in &event.snaps {
                let size = size_of(snap, self.sizes);
                if size > 0 {
                    let source = match snap {
                        Snap::X => &self.sources.x,
                        Snap::V => &self.sources.v,
                        Snap::Lambda => &self.sources.lambda,
                        Snap::P => &self.sources.p,
                    };
                    encoder.copy_buffer_to_buffer(source, 0, &self.tape, offset, size);
                }
                offset += size;
            }
        }
    }

    /// The contact forces of the step whose copies the tape holds (its
    /// motion clock `step`: steps accepted before it), read back and
    /// replayed.
    pub fn forces(
        &mut self,
        ctx: &GpuContext,
        plan: &Plan,
        state: &ResidentState,
        step: u64,
    ) -> Result<ContactForces, GpuError> {
        let tape = ctx.read(&self.tape, self.bytes)?;
        let (n, precision) = (plan.particle_count() * plan.dim, self.precision);
        let vector = |bytes: &[u8], world: bool| {
            let mut values = state.packing.unpack(bytes);
            values.truncate(n);
            if world {
                state.origin().to_world(&mut values);
            }
            values
        };
        let slots = self.starts[self.starts.len() - 1];
        self.recorder.clear();
        let mut now = (u32::MAX, SubstepMotion::default());
        // What an event does not copy the recorder does not read: it keeps
        // an earlier event's values (zeros at first).
        let (mut x, mut v, mut p) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut lambda = vec![0.0; slots];
        for event in &self.events {
            if let Some(motion) = plan.motion.as_ref().filter(|_| now.0 != event.substep) {
                let s = event.substep;
                let t0 = substep_time(step, plan.dt, s, plan.h);
                let t1 = substep_time(step, plan.dt, s + 1, plan.h);
                now = (s, motion.substep(plan.dim, t0, t1, plan.h));
            }
            let mut offset = event.offset as usize;
            for &snap in &event.snaps {
                let size = size_of(snap, self.sizes) as usize;
                let bytes = &tape[offset..offset + size];
                match snap {
                    Snap::X => x = vector(bytes, true),
                    Snap::V => v = vector(bytes, false),
                    Snap::P => p = vector(bytes, true),
                    Snap::Lambda => {
                        lambda = read_reals(bytes, precision);
                        lambda.truncate(slots);
                    }
                }
                offset += size;
            }
            let motion = &now.1;
            match event.what {
                What::Before(kernel) => self.recorder.before(plan, kernel, &x, &v),
                What::After(kernel) => {
                    self.recorder
                        .after(plan, (motion, &lambda, &self.starts), kernel, (&x, &v, &p))
                }
                What::End => {
                    let multipliers = (&lambda[..], &self.starts[..]);
                    self.recorder
                        .end_substep(plan, motion, multipliers, (&x, &p))
                }
            }
        }
        Ok(self.recorder.forces(plan.dt))
    }
}

/// Bytes of one copy of `snap`.
fn size_of(snap: Snap, (particles, lambda): (u64, u64)) -> u64 {
    match snap {
        Snap::X | Snap::V | Snap::P => particles,
        Snap::Lambda => lambda,
    }
}
