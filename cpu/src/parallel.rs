//! Who executes a kernel: fixed chunks on a rayon pool, and the one shared
//! view through which chunks write disjoint data.
//!
//! ```text
//! chunk c of 0..len   c·grain .. min((c + 1)·grain, len)
//!                     grain: a constant of the kernel, never derived from the
//!                     thread count, so chunk boundaries are the same for 1 or
//!                     64 threads
//! one thread, or      the chunks run in order on the calling thread
//!   len ≤ grain
//! otherwise           the chunks run on the backend's pool, in any order
//! failures            every chunk runs to its own first failure in both cases,
//!                     so even a failed kernel's partial writes do not depend
//!                     on the thread count
//! results             per chunk, combined in chunk order (one fixed tree);
//!                     an error is the smallest failing index, whichever
//!                     chunk finds it
//! ```
//! The serial schedule is the definition. A parallel kernel only splits work
//! whose items are independent — the elements of one colour (no two share a
//! dynamic particle, checked when the backend loads), the particles of a
//! per-particle stage, the pairs of a contact iteration — and every item
//! runs exactly the arithmetic it runs serially. Sums and maxima over items
//! are formed per chunk and combined in chunk order, so their rounding does
//! not depend on the thread count either.
//!
//! # Shared writes: [`DisjointSlice`]
//!
//! Projecting a colour in parallel writes particles chosen by the elements,
//! not contiguous ranges, so the chunks cannot be handed `&mut` sub-slices.
//! Two ways out: gather (every particle reads the corrections addressed to
//! it, which needs a per-particle list of elements and a second pass), or
//! write in place through a shared view. The golden path writes in place:
//! a gather would add a pass and memory traffic to every projection, and
//! the colouring already proves the writes disjoint. [`DisjointSlice`] is
//! that view, and all the `unsafe` of the parallel path: constructing it
//! (and taking a range from it) is `unsafe`, with the disjointness its
//! caller guarantees as the contract; every access is bounds-checked. Each
//! construction site states why its writes are disjoint. Kernels are
//! written once against [`Coordinates`]: one thread hands them the plain
//! `&mut [f64]` (exactly the serial code, aliasing guarantees included),
//! several threads a chunk's [`Shared`] handle on the view.

use std::marker::PhantomData;
use std::ops::Range;
use std::sync::{Arc, Mutex};

use hyperpbd_core::BackendError;
use rayon::prelude::*;

/// The thread pool of a backend (shared by every backend of the same
/// thread count in the process) and its size.
#[derive(Clone)]
pub struct Workers {
    threads: usize,
    /// `None` for one thread: everything runs on the caller.
    pool: Option<Arc<rayon::ThreadPool>>,
    /// Largest chunk, a power of two: every kernel's grain is capped by
    /// it (tests split small scenes finely with it; `usize::MAX`
    /// otherwise).
    max_chunk: usize,
}

impl std::fmt::Debug for Workers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Workers")
            .field("threads", &self.threads)
            .finish()
    }
}

/// Pools already started, one per thread count.
static POOLS: Mutex<Vec<(usize, Arc<rayon::ThreadPool>)>> = Mutex::new(Vec::new());

/// Values per chunk of [`Workers::zero`] and [`Workers::copy`].
const VALUE_GRAIN: usize = 16_384;

impl Workers {
    /// Everything on the calling thread.
    pub fn serial() -> Self {
        Workers {
            threads: 1,
            pool: None,
            max_chunk: 1 << (usize::BITS - 1),
        }
    }

    /// Workers on `threads` threads (at least 1).
    pub fn new(threads: usize) -> Result<Self, BackendError> {
        if threads <= 1 {
            return Ok(Workers::serial());
        }
        let mut pools = POOLS
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some((_, pool)) = pools.iter().find(|(n, _)| *n == threads) {
            return Ok(Workers {
                threads,
                pool: Some(Arc::clone(pool)),
                max_chunk: 1 << (usize::BITS - 1),
            });
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("hyperpbd-cpu-{i}"))
            .build()
            .map_err(|e| {
                BackendError::InvalidCall(format!("cannot start {threads} CPU threads: {e}"))
            })?;
        let pool = Arc::new(pool);
        pools.push((threads, Arc::clone(&pool)));
        Ok(Workers {
            threads,
            pool: Some(pool),
            max_chunk: 1 << (usize::BITS - 1),
        })
    }

    /// The same workers with every chunk capped at `max_chunk` items,
    /// rounded down to a power of two (so blocks of a fixed tree stay
    /// subtrees).
    pub fn with_max_chunk(mut self, max_chunk: usize) -> Self {
        self.max_chunk = 1 << max_chunk.max(1).ilog2();
        self
    }

    /// Threads this backend runs on.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Runs `op` on the pool, so that the loops inside it split without a
    /// hand-over between threads for every loop. Inline with one thread.
    pub fn install<R: Send>(&self, op: impl FnOnce() -> R + Send) -> R {
        match &self.pool {
            Some(pool) => pool.install(op),
            None => op(),
        }
    }

    /// `a` and `b` at once (each may split further) when the caller runs
    /// on the pool; one after the other otherwise (a hand-over to the pool
    /// costs more than a small scene's two loops).
    pub fn join<A: Send, B: Send>(
        &self,
        a: impl FnOnce() -> A + Send,
        b: impl FnOnce() -> B + Send,
    ) -> (A, B) {
        match &self.pool {
            Some(pool) if pool.current_thread_index().is_some() => rayon::join(a, b),
            _ => (a(), b()),
        }
    }

    /// A kernel's chunk size: its `grain`, capped by the test cap.
    #[inline]
    pub fn grain(&self, grain: usize) -> usize {
        grain.min(self.max_chunk).max(1)
    }

    /// The chunks of `0..len` for `grain` (as the parallel loops cut them),
    /// for a kernel that runs them in order on the calling thread.
    pub fn chunks(&self, len: usize, grain: usize) -> impl Iterator<Item = Range<usize>> {
        let grain = self.grain(grain);
        (0..len.div_ceil(grain)).map(move |c| chunk(c, len, grain))
    }

    /// Whether `len` items in chunks of `grain` run in parallel.
    #[inline]
    pub fn splits(&self, len: usize, grain: usize) -> bool {
        self.pool.is_some() && len > self.grain(grain)
    }

    /// Runs `body` over the chunks of `0..len` (items independent of each
    /// other); the smallest error index of any chunk.
    #[inline]
    pub fn try_for_chunks(
        &self,
        len: usize,
        grain: usize,
        body: impl Fn(Range<usize>) -> Result<(), usize> + Sync,
    ) -> Result<(), usize> {
        self.try_for_chunks_with(len, grain, &mut (), || (), |r, _| body(r))
    }

    /// [`Workers::try_for_chunks`] with scratch: `scratch` when the chunks
    /// run on the calling thread, else one `fresh()` per task.
    #[inline]
    pub fn try_for_chunks_with<S>(
        &self,
        len: usize,
        grain: usize,
        scratch: &mut S,
        fresh: impl Fn() -> S + Sync + Send,
        body: impl Fn(Range<usize>, &mut S) -> Result<(), usize> + Sync,
    ) -> Result<(), usize> {
        let grain = self.grain(grain);
        if !self.splits(len, grain) {
            if len <= grain {
                return body(0..len, scratch);
            }
            // Every chunk runs to its own first error, as on the pool, so
            // that even the partial writes of a failed kernel are the same
            // for any thread count.
            return (0..len.div_ceil(grain))
                .map(|c| body(chunk(c, len, grain), scratch))
                .fold(Ok(()), first_error);
        }
        self.try_on_pool(len, grain, fresh, body)
    }

    /// The parallel half of [`Workers::try_for_chunks_with`].
    #[inline(never)]
    fn try_on_pool<S>(
        &self,
        len: usize,
        grain: usize,
        fresh: impl Fn() -> S + Sync + Send,
        body: impl Fn(Range<usize>, &mut S) -> Result<(), usize> + Sync,
    ) -> Result<(), usize> {
        self.install(|| {
            (0..len.div_ceil(grain))
                .into_par_iter()
                .map_init(&fresh, |scratch, c| body(chunk(c, len, grain), scratch))
                .reduce(|| Ok(()), first_error)
        })
    }

    /// Runs `body` over the chunks of `0..len` items that own `stride`
    /// consecutive values of every slice in `slices` (particles and their
    /// coordinates): chunk `r` gets the values of items `r` as plain slices.
    /// The smallest error index of any chunk.
    #[inline]
    pub fn try_for_spans<const K: usize>(
        &self,
        len: usize,
        grain: usize,
        stride: usize,
        slices: [&mut [f64]; K],
        body: impl Fn(Range<usize>, [&mut [f64]; K]) -> Result<(), usize> + Sync,
    ) -> Result<(), usize> {
        if len <= self.grain(grain) {
            return body(0..len, slices);
        }
        let spans = Spans::new(len, stride, slices);
        // SAFETY: the chunks are disjoint and each is taken once.
        self.try_for_chunks(len, grain, |r| body(r.clone(), unsafe { spans.take(r) }))
    }

    /// `values` = 0 (the multipliers at the start of a substep), in
    /// chunks of [`VALUE_GRAIN`].
    pub fn zero(&self, values: &mut [f64]) {
        let _ = self.try_for_spans(values.len(), VALUE_GRAIN, 1, [values], |_, [v]| {
            v.fill(0.0);
            Ok(())
        });
    }

    /// `to` = `from` (equal lengths: the saved state), in chunks of
    /// [`VALUE_GRAIN`].
    pub fn copy(&self, from: &[f64], to: &mut [f64]) {
        let _ = self.try_for_spans(to.len(), VALUE_GRAIN, 1, [to], |r, [to]| {
            to.copy_from_slice(&from[r]);
            Ok(())
        });
    }

    /// `body` of every chunk of items, as in [`Workers::try_for_spans`],
    /// in chunk order.
    pub fn map_spans<const K: usize, T: Send>(
        &self,
        len: usize,
        grain: usize,
        stride: usize,
        slices: [&mut [f64]; K],
        body: impl Fn(Range<usize>, [&mut [f64]; K]) -> T + Sync,
    ) -> Vec<T> {
        if len <= self.grain(grain) {
            return vec![body(0..len, slices)];
        }
        let spans = Spans::new(len, stride, slices);
        // SAFETY: the chunks are disjoint and each is taken once.
        self.map_chunks(len, grain, |r| body(r.clone(), unsafe { spans.take(r) }))
    }

    /// `body` of every chunk of `0..len`, in chunk order.
    pub fn map_chunks<T: Send>(
        &self,
        len: usize,
        grain: usize,
        body: impl Fn(Range<usize>) -> T + Sync,
    ) -> Vec<T> {
        let grain = self.grain(grain);
        let chunks = len.div_ceil(grain);
        if !self.splits(len, grain) {
            return (0..chunks).map(|c| body(chunk(c, len, grain))).collect();
        }
        self.install(|| {
            (0..chunks)
                .into_par_iter()
                .map(|c| body(chunk(c, len, grain)))
                .collect()
        })
    }
}

/// Chunk `c` of `0..len`: `grain` items, the last chunk shorter.
fn chunk(c: usize, len: usize, grain: usize) -> Range<usize> {
    c * grain..((c + 1) * grain).min(len)
}

/// The smaller of two errors (a failure is reported by its smallest index).
pub fn first_error(a: Result<(), usize>, b: Result<(), usize>) -> Result<(), usize> {
    match (a, b) {
        (Err(a), Err(b)) => Err(a.min(b)),
        (Err(a), Ok(())) | (Ok(()), Err(a)) => Err(a),
        (Ok(()), Ok(())) => Ok(()),
    }
}

/// Slices holding `stride` values per item, handed out chunk by chunk.
struct Spans<'a, const K: usize> {
    stride: usize,
    views: [DisjointSlice<'a, f64>; K],
}

impl<'a, const K: usize> Spans<'a, K> {
    #[inline]
    fn new(len: usize, stride: usize, slices: [&'a mut [f64]; K]) -> Self {
        assert!(
            slices.iter().all(|s| s.len() == len * stride),
            "every slice holds {stride} values per item"
        );
        // SAFETY: values are reached only through `take`, whose callers
        // take disjoint item ranges.
        let views = slices.map(|s| unsafe { DisjointSlice::new(s) });
        Spans { stride, views }
    }

    /// The values of items `r`.
    ///
    /// # Safety
    ///
    /// `r` is disjoint from every other range taken while these slices
    /// live.
    #[allow(clippy::mut_from_ref)]
    #[inline]
    unsafe fn take(&self, r: Range<usize>) -> [&mut [f64]; K] {
        let values = r.start * self.stride..r.end * self.stride;
        // SAFETY: disjoint from every other taken range (the contract).
        self.views
            .each_ref()
            .map(|view| unsafe { view.range_mut(values.clone()) })
    }
}

/// A mutable slice shared by the chunks of one parallel loop, each of which
/// writes only indices no other chunk touches. Every access is
/// bounds-checked; what the compiler cannot check — that the writes of
/// different threads are disjoint — is the contract of [`DisjointSlice::new`].
pub struct DisjointSlice<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: PhantomData<&'a mut [T]>,
}

// SAFETY: the view hands out copies of `T` and stores `T`s; under the
// contract of `new` no index is accessed by two threads unless all of them
// only read it, so sharing the view is sharing disjoint `&mut T`s and
// common `&T`s, which `T: Send + Sync` allows.
unsafe impl<T: Send + Sync> Sync for DisjointSlice<'_, T> {}
// SAFETY: as for `Sync`: the view is a `&mut [T]` that may move threads.
unsafe impl<T: Send> Send for DisjointSlice<'_, T> {}

impl<'a, T: Copy> DisjointSlice<'a, T> {
    /// A view of `slice` for the duration of one loop.
    ///
    /// # Safety
    ///
    /// While the view is shared between threads, an index written through
    /// it by one thread is neither read nor written by any other thread;
    /// an index several threads read is written by none.
    pub unsafe fn new(slice: &'a mut [T]) -> Self {
        DisjointSlice {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _borrow: PhantomData,
        }
    }

    /// Shared access to `range` (values this thread reads).
    ///
    /// # Safety
    ///
    /// Nothing writes `range` while the returned slice lives.
    #[inline(always)]
    pub unsafe fn range(&self, range: Range<usize>) -> &[T] {
        assert!(
            range.start <= range.end && range.end <= self.len,
            "range {range:?} out of range {}",
            self.len
        );
        // SAFETY: in bounds; unwritten meanwhile by the caller's contract.
        unsafe { std::slice::from_raw_parts(self.ptr.add(range.start), range.len()) }
    }

    /// Exclusive access to `range` (values only this thread touches: a
    /// chunk's own span, a particle of its own elements).
    ///
    /// # Safety
    ///
    /// No other thread accesses `range` while the returned slice lives, and
    /// this thread accesses it only through the slice meanwhile.
    #[inline(always)]
    #[allow(clippy::mut_from_ref)]
    pub unsafe fn range_mut(&self, range: Range<usize>) -> &mut [T] {
        assert!(
            range.start <= range.end && range.end <= self.len,
            "range {range:?} out of range {}",
            self.len
        );
        // SAFETY: in bounds; exclusive by the caller's contract.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(range.start), range.len()) }
    }
}

/// Where a kernel finds the coordinates it updates element by element: the
/// whole slice when one thread runs the kernel, or a chunk's [`Shared`]
/// handle on a [`DisjointSlice`] when several do. A kernel is written once,
/// generic over both.
pub trait Coordinates {
    /// Values `range`, to read.
    fn values(&self, range: Range<usize>) -> &[f64];
    /// Values `range`, to write.
    fn values_mut(&mut self, range: Range<usize>) -> &mut [f64];
}

impl Coordinates for [f64] {
    #[inline(always)]
    fn values(&self, range: Range<usize>) -> &[f64] {
        &self[range]
    }

    #[inline(always)]
    fn values_mut(&mut self, range: Range<usize>) -> &mut [f64] {
        &mut self[range]
    }
}

/// A chunk's handle on a shared view: its accesses are those the view's
/// contract (see [`DisjointSlice::new`]) makes exclusive to this chunk.
pub struct Shared<'v, 'a>(pub &'v DisjointSlice<'a, f64>);

impl Coordinates for Shared<'_, '_> {
    #[inline(always)]
    fn values(&self, range: Range<usize>) -> &[f64] {
        // SAFETY: the values a chunk reads are written by no other chunk
        // (contract of the view), and this handle's writes need `&mut self`.
        unsafe { self.0.range(range) }
    }

    #[inline(always)]
    fn values_mut(&mut self, range: Range<usize>) -> &mut [f64] {
        // SAFETY: the values a chunk writes are touched by no other chunk
        // (contract of the view); borrowed mutably from this handle.
        unsafe { self.0.range_mut(range) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_cover_the_range_in_order_for_any_thread_count() {
        for threads in [1, 2, 3] {
            let workers = Workers::new(threads).expect("pool");
            for (len, grain) in [(0, 4), (1, 4), (4, 4), (5, 4), (17, 4), (1000, 7)] {
                let ranges = workers.map_chunks(len, grain, |r| r);
                let flat: Vec<usize> = ranges.iter().cloned().flatten().collect();
                assert_eq!(flat, (0..len).collect::<Vec<_>>(), "{len} / {grain}");
                assert!(ranges.iter().all(|r| r.len() <= grain));
            }
        }
    }

    #[test]
    fn the_smallest_error_wins() {
        let workers = Workers::new(2).expect("pool");
        let failing = [913, 17, 4000, 18];
        let got = workers.try_for_chunks(5000, 16, |r| {
            r.clone().find(|i| failing.contains(i)).map_or(Ok(()), Err)
        });
        assert_eq!(got, Err(17));
        assert_eq!(workers.try_for_chunks(5000, 16, |_| Ok(())), Ok(()));
    }

    #[test]
    fn disjoint_writes_land() {
        let workers = Workers::new(2).expect("pool");
        let mut values = vec![0u32; 10_000];
        // SAFETY: chunk r writes only indices in r; chunks are disjoint.
        let view = unsafe { DisjointSlice::new(&mut values) };
        let _ = workers.try_for_chunks(10_000, 64, |r| {
            for k in r {
                // SAFETY: index k belongs to this chunk alone.
                let value = unsafe { view.range_mut(k..k + 1) };
                value[0] = 3 * k as u32;
            }
            Ok(())
        });
        assert!(values.iter().enumerate().all(|(k, &v)| v == 3 * k as u32));
    }
}
