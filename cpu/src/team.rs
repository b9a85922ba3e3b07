//! A team of threads held for the substeps of one step, so that a kernel's
//! chunks reach the other cores without a rayon fork-join per kernel.
//!
//! ```text
//! step        the caller (a pool thread) becomes the team's leader and
//!             spawns threads − 1 helpers on the pool; the helpers wait
//!             for jobs (spin, then yield the core) until the step's
//!             substeps are done
//! job         the leader publishes (epoch, next chunk = 0, chunks) in one
//!             atomic word; every member, leader included, claims the next
//!             chunk by compare-and-swap on that word and runs it; the
//!             leader returns once every chunk has finished
//! results     a chunk's failure index goes into one atomic minimum: the
//!             smallest failing index whoever ran it
//! ```
//! A peer cloth substep is five such jobs (the fused particle pass and four
//! colours): handing each to a waiting helper costs a cache-line transfer
//! instead of a rayon split, steal and wake. Claiming is dynamic, so a
//! helper the OS has put aside (a loaded machine) delays no one: the others
//! take its chunks. The chunks are the kernels' own (`parallel.rs`), so
//! who runs which changes nothing in the result.
//!
//! # Why a claimed job is the current one
//!
//! The state word only grows (epoch in the high bits, next chunk below),
//! so a compare-and-swap that succeeds proves the word did not change
//! between the member's load and its swap. The leader replaces the job
//! pointer only after every chunk of the current job has been claimed and
//! has finished; a member that read the word with chunks left and then
//! claimed one therefore read the current job's pointer, and the job (on
//! the leader's stack) lives until that chunk finishes.

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, AtomicUsize, Ordering::SeqCst};

/// Bits of the chunk count and of the next chunk in the state word.
const CHUNK_BITS: u32 = 20;
/// Largest chunk count a job may have (larger loops use rayon).
pub const MAX_CHUNKS: usize = (1 << CHUNK_BITS) - 1;
const CHUNK_MASK: u64 = (1 << CHUNK_BITS) - 1;

/// Spins (with the pause hint) before a waiting member yields its core.
const SPINS: u32 = 256;

/// A chunk's work: runs chunk `c`, returns its failure index if any.
type Job<'a> = dyn Fn(usize) -> Result<(), usize> + Sync + 'a;

/// The shared state of a team.
pub struct Team {
    /// epoch · 2⁴⁰ + next chunk · 2²⁰ + chunk count.
    state: AtomicU64,
    /// Chunks of the current job that have finished.
    done: AtomicUsize,
    /// Smallest failure index of the current job (`usize::MAX`: none).
    failure: AtomicUsize,
    /// A chunk panicked.
    panicked: AtomicBool,
    /// The current job: a pointer to the leader's `&Job`.
    job: AtomicPtr<()>,
    /// The step is over: helpers return.
    stop: AtomicBool,
}

thread_local! {
    /// The team this thread leads, if any.
    static LEADING: Cell<*const Team> = const { Cell::new(std::ptr::null()) };
}

/// Runs `op` as the leader of a team of `threads` threads: the caller and
/// `threads − 1` helpers spawned on the caller's rayon pool. The calling
/// thread must be a thread of that pool (inside `install`).
pub fn lead<R>(threads: usize, op: impl FnOnce() -> R) -> R {
    let team = Team {
        state: AtomicU64::new(0),
        done: AtomicUsize::new(0),
        failure: AtomicUsize::new(usize::MAX),
        panicked: AtomicBool::new(false),
        job: AtomicPtr::new(std::ptr::null_mut()),
        stop: AtomicBool::new(false),
    };
    /// Ends the team even if `op` panics (helpers return, the scope ends).
    struct Leading<'t>(&'t Team, *const Team);
    impl Drop for Leading<'_> {
        fn drop(&mut self) {
            self.0.stop.store(true, SeqCst);
            LEADING.with(|l| l.set(self.1));
        }
    }
    rayon::in_place_scope(|scope| {
        let team = &team;
        for _ in 1..threads {
            scope.spawn(move |_| team.help());
        }
        let _leading = Leading(team, LEADING.with(|l| l.replace(team)));
        op()
    })
}

/// Whether the calling thread leads a team (its loops go to the team).
pub fn leading() -> bool {
    !LEADING.with(Cell::get).is_null()
}

/// Runs `body` over chunks `0..chunks` on the team the calling thread
/// leads (`chunks ≤ MAX_CHUNKS`); the smallest failure index. `None` when
/// the thread leads no team.
pub fn run(chunks: usize, body: &Job) -> Option<Result<(), usize>> {
    let team = LEADING.with(Cell::get);
    if team.is_null() || chunks > MAX_CHUNKS {
        return None;
    }
    // SAFETY: set by `lead` on this thread for the lifetime of its team,
    // which outlives every call made inside `op`.
    let team = unsafe { &*team };
    Some(team.run(chunks, body))
}

impl Team {
    /// The leader's half of a job.
    fn run(&self, chunks: usize, body: &Job) -> Result<(), usize> {
        if chunks == 0 {
            return Ok(());
        }
        self.done.store(0, SeqCst);
        self.failure.store(usize::MAX, SeqCst);
        let job: &Job = body;
        self.job.store((&raw const job).cast_mut().cast(), SeqCst);
        let epoch = (self.state.load(SeqCst) >> (2 * CHUNK_BITS)) + 1;
        self.state
            .store((epoch << (2 * CHUNK_BITS)) | chunks as u64, SeqCst);
        while self.claim() {}
        let mut waited = 0;
        while self.done.load(SeqCst) < chunks {
            back_off(&mut waited);
        }
        if self.panicked.swap(false, SeqCst) {
            panic!("a chunk of a parallel CPU kernel panicked");
        }
        match self.failure.load(SeqCst) {
            usize::MAX => Ok(()),
            i => Err(i),
        }
    }

    /// Claims and runs one chunk of the current job; false when none is
    /// left.
    fn claim(&self) -> bool {
        loop {
            let state = self.state.load(SeqCst);
            let (next, chunks) = ((state >> CHUNK_BITS) & CHUNK_MASK, state & CHUNK_MASK);
            if next >= chunks {
                return false;
            }
            let job = self.job.load(SeqCst);
            if self
                .state
                .compare_exchange(state, state + (1 << CHUNK_BITS), SeqCst, SeqCst)
                .is_err()
            {
                continue;
            }
            // SAFETY: the claim succeeded, so `job` is the current job's
            // `&Job` (module doc), alive until `done` counts this chunk.
            let body = unsafe { *job.cast::<&Job>() };
            let ran =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| body(next as usize)));
            match ran {
                Ok(Ok(())) => {}
                Ok(Err(i)) => {
                    self.failure.fetch_min(i, SeqCst);
                }
                Err(_) => self.panicked.store(true, SeqCst),
            }
            self.done.fetch_add(1, SeqCst);
            return true;
        }
    }

    /// A helper: runs chunks until the step is over.
    fn help(&self) {
        if std::ptr::eq(LEADING.with(Cell::get), self) {
            // The leader itself picked up a helper task (it never waits on
            // the pool inside the team, but stay safe): nothing to do.
            return;
        }
        let mut waited = 0;
        while !self.stop.load(SeqCst) {
            if self.claim() {
                waited = 0;
            } else {
                back_off(&mut waited);
            }
        }
    }
}

/// Waits a little: a pause first, then the core goes to whoever wants it.
fn back_off(waited: &mut u32) {
    if *waited < SPINS {
        *waited += 1;
        std::hint::spin_loop();
    } else {
        std::thread::yield_now();
    }
}
