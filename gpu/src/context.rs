//! A device with the rules every GPU backend follows: how it is created,
//! how its failures become typed errors, how work is submitted and waited
//! for, how buffers are created and read back.
//!
//! ```text
//! GpuContext::new(adapter, precision)   the process's shared device of the
//!                                       adapter and precision (device_pool:
//!                                       queue, device-lost flag, compiled
//!                                       kernels), its own error list
//! GpuContext::private(…)                the same on a device of its own
//! check()           lost → DeviceLost; reported errors → OutOfMemory / Other
//! submit_and_wait   submit, wait for that submission, check()
//! submit_and_read   submit, map a read-back buffer: ONE wait for both, check()
//! buffer            a buffer of the given bytes; over the device limits →
//!                   BufferTooLarge naming it, before asking the device
//! read              map a MAP_READ buffer, copy, unmap (readback.rs)
//! poll              the one place the host waits for the device (every wait,
//!                   every read-back, every snapshot), each call counted
//! host_waits        the polls so far (round trips: StepReport::host_waits)
//! building(f)       runs f inside out-of-memory and validation error scopes
//! ```

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use hyperpbd_core::{BackendError, GpuError};

use crate::device_pool::{self, Pooled};
use crate::kernel_cache::KernelCache;
use crate::lockstep::Lockstep;
use crate::{AdapterSummary, Precision};

/// A device, its queue, and where its errors go (clones share them).
#[derive(Clone)]
pub(crate) struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// The kernel sets built on `device` (shared with every context on it).
    pub kernels: KernelCache,
    /// Whether `device` is the pool's, shared with other backends.
    pub shared: bool,
    /// The adapter the device was created on.
    pub summary: AdapterSummary,
    errors: Arc<Mutex<Vec<String>>>,
    lost: Arc<Mutex<Option<String>>>,
    /// Times the host waited for the device: the calls of
    /// [`GpuContext::poll`], the crate's only `device.poll`.
    waits: Arc<AtomicU64>,
    /// The batch whose worlds share the host's waits, when the context is
    /// one of its worlds' (crate::lockstep).
    lockstep: Option<Arc<Lockstep>>,
}

impl GpuContext {
    /// The shared device of `adapter` for `precision` (the features it
    /// needs), with a fresh error list and host-wait count of its own.
    pub fn new(adapter: &wgpu::Adapter, precision: Precision) -> Result<Self, GpuError> {
        Ok(Self::of(
            adapter,
            device_pool::shared(adapter, precision)?,
            true,
        ))
    }

    /// As [`GpuContext::new`] on a device of its own, shared with no other
    /// backend (one that may destroy it).
    pub fn private(adapter: &wgpu::Adapter, precision: Precision) -> Result<Self, GpuError> {
        Ok(Self::of(
            adapter,
            Pooled::private(adapter, precision)?,
            false,
        ))
    }

    fn of(adapter: &wgpu::Adapter, pooled: Pooled, shared: bool) -> Self {
        GpuContext {
            errors: pooled.subscribe(),
            device: pooled.device,
            queue: pooled.queue,
            kernels: pooled.kernels,
            shared,
            summary: AdapterSummary::of(adapter),
            lost: pooled.lost,
            waits: Arc::default(),
            lockstep: None,
        }
    }

    /// The caller's `device` and `queue`, created on `adapter`: the
    /// features `precision` needs are checked (a typed
    /// [`GpuError::MissingFeature`]); limits are checked by each kernel set
    /// as it is built. The caller keeps its own uncaptured-error handler
    /// and device-lost callback: none is installed here (errors while
    /// building are still caught, by error scopes; see [`Self::building`]).
    pub fn on_device(
        adapter: &wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        precision: Precision,
    ) -> Result<Self, GpuError> {
        let summary = AdapterSummary::of(adapter);
        let missing = crate::adapter::required_features(precision) - device.features();
        if let Some(feature) = missing.iter().next() {
            return Err(GpuError::MissingFeature {
                adapter: format!("{} (the device given)", summary.name),
                feature: format!("{feature:?}"),
            });
        }
        Ok(GpuContext {
            device,
            queue,
            kernels: KernelCache::default(),
            shared: false,
            summary,
            errors: Arc::default(),
            lost: Arc::default(),
            waits: Arc::default(),
            lockstep: None,
        })
    }

    /// Destroys a device of this context's own; the shared device serves
    /// other backends and is refused.
    pub fn destroy(&self) -> Result<(), GpuError> {
        if self.shared {
            return Err(GpuError::Unsupported {
                what: "destroying the process's shared device (load the backend with \
                       with_private_device)"
                    .into(),
            });
        }
        self.device.destroy();
        Ok(())
    }

    /// A lost device, then any error the device reported since the last
    /// check.
    pub fn check(&self) -> Result<(), GpuError> {
        if let Ok(l) = self.lost.lock()
            && let Some(message) = l.clone()
        {
            return Err(GpuError::DeviceLost { message });
        }
        crate::device_errors::take_device_errors(&self.errors)
    }

    /// Submits `encoder` and waits for it.
    pub fn submit_and_wait(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        let index = self.submit(encoder)?;
        self.wait(index)
    }

    /// Submits `encoder` without waiting.
    pub fn submit(&self, encoder: wgpu::CommandEncoder) -> Result<wgpu::SubmissionIndex, GpuError> {
        let index = self.queue.submit(Some(encoder.finish()));
        self.check()?;
        Ok(index)
    }

    /// Times the host has waited for the device since it was created (the
    /// calls of [`GpuContext::poll`]).
    pub fn host_waits(&self) -> u64 {
        self.waits.load(Ordering::Relaxed)
    }

    /// Blocks until the device has finished `submission` (every submission
    /// when `None`) and the map callbacks it completes have run: the crate's
    /// one `device.poll`, counted in [`GpuContext::host_waits`].
    /// In a lockstep batch's step the wait is the batch's round, for
    /// every submission of every world (crate::lockstep).
    pub fn poll(&self, submission: Option<wgpu::SubmissionIndex>) -> Result<(), GpuError> {
        self.waits.fetch_add(1, Ordering::Relaxed);
        match &self.lockstep {
            Some(lockstep) => lockstep.wait(&|| self.device_poll(None)),
            None => self.device_poll(submission),
        }
    }

    /// Joins `lockstep`: this context's waits become its rounds.
    pub fn join(&mut self, lockstep: Arc<Lockstep>) {
        self.lockstep = Some(lockstep);
    }

    /// Whether `other` works on the same device (one pool entry).
    pub fn same_device(&self, other: &GpuContext) -> bool {
        Arc::ptr_eq(&self.lost, &other.lost)
    }

    /// Leaves the lockstep batch's step (the context's world is done).
    pub fn leave_lockstep(&self) {
        if let Some(lockstep) = &self.lockstep {
            lockstep.leave(&|| self.device_poll(None));
        }
    }

    /// The device's wait itself.
    fn device_poll(&self, submission: Option<wgpu::SubmissionIndex>) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: submission,
                timeout: None,
            })
            .map(|_| ())
            .map_err(|e| {
                // The device-lost callback's reason, when it has fired, says
                // more than the failed wait.
                self.check().err().unwrap_or(GpuError::DeviceLost {
                    message: e.to_string(),
                })
            })
    }

    /// Waits for the submission `index`.
    pub fn wait(&self, index: wgpu::SubmissionIndex) -> Result<(), GpuError> {
        self.poll(Some(index))?;
        self.check()
    }

    /// Maps the first `len` bytes of `buffer` (its copies submitted) and
    /// returns them (one wait; none for `len` 0).
    pub fn read(&self, buffer: &wgpu::Buffer, len: u64) -> Result<Vec<u8>, GpuError> {
        let mut all = self.read_all(&[(buffer, len)])?;
        Ok(all.pop().unwrap_or_default())
    }

    /// Maps every (buffer, len) of `reads` (their copies submitted) and
    /// returns them, with ONE wait for all.
    pub fn read_all(&self, reads: &[(&wgpu::Buffer, u64)]) -> Result<Vec<Vec<u8>>, GpuError> {
        let waiter = crate::readback::Waiter {
            poll: &|| self.poll(None),
            check: &|| self.check(),
        };
        crate::readback::read_mapped_all(&waiter, reads)
    }

    /// Submits `encoder` (which copies into `buffer`) and reads the first
    /// `len` bytes of `buffer` back: one wait, where `submit_and_wait`
    /// followed by `read` waits twice.
    pub fn submit_and_read(
        &self,
        encoder: wgpu::CommandEncoder,
        buffer: &wgpu::Buffer,
        len: u64,
    ) -> Result<Vec<u8>, GpuError> {
        self.submit(encoder)?;
        let bytes = self.read(buffer, len)?;
        self.check()?;
        Ok(bytes)
    }

    /// A buffer holding `bytes` (at least 16 bytes), refusing sizes over the
    /// device limits with a typed error naming `label`.
    pub fn buffer(
        &self,
        label: &str,
        bytes: &[u8],
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        let buffer = self.sized(label, bytes.len() as u64, usage)?;
        if !bytes.is_empty() && !usage.contains(wgpu::BufferUsages::MAP_READ) {
            let mut padded = bytes.to_vec();
            padded.resize(padded.len().next_multiple_of(4), 0);
            self.queue.write_buffer(&buffer, 0, &padded);
        }
        Ok(buffer)
    }

    /// A buffer of `len` bytes (at least 16), nothing written, refusing
    /// sizes over the device limits with a typed error naming `label`.
    fn sized(
        &self,
        label: &str,
        len: u64,
        usage: wgpu::BufferUsages,
    ) -> Result<wgpu::Buffer, GpuError> {
        let limits = self.device.limits();
        let size = len.max(16).next_multiple_of(4);
        let maximum = if usage.contains(wgpu::BufferUsages::STORAGE) {
            limits
                .max_storage_buffer_binding_size
                .min(limits.max_buffer_size)
        } else {
            limits.max_buffer_size
        };
        if size > maximum {
            return Err(GpuError::BufferTooLarge {
                buffer: label.into(),
                requested: size,
                maximum,
            });
        }
        Ok(self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: usage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }))
    }

    /// A storage buffer (also a copy source and destination) of `bytes`.
    pub fn storage(&self, label: &str, bytes: &[u8]) -> Result<wgpu::Buffer, GpuError> {
        self.buffer(
            label,
            bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        )
    }

    /// A mappable read-back buffer of `len` bytes.
    pub fn staging(&self, label: &str, len: u64) -> Result<wgpu::Buffer, GpuError> {
        self.sized(
            label,
            len,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        )
    }

    /// Runs `build` (buffer and pipeline creation) inside out-of-memory and
    /// validation error scopes, so a device that refuses is a typed error
    /// of the load, not a later surprise.
    pub fn building<T>(
        &self,
        build: impl FnOnce() -> Result<T, BackendError>,
    ) -> Result<T, BackendError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let built = build();
        let validation_error = pollster::block_on(validation.pop());
        let oom_error = pollster::block_on(oom.pop());
        if let Some(e) = oom_error {
            return Err(GpuError::OutOfMemory {
                message: e.to_string(),
            }
            .into());
        }
        if let Some(e) = validation_error {
            return Err(GpuError::Other {
                message: e.to_string(),
            }
            .into());
        }
        built
    }
}

/// Where a backend's device comes from: its own, made on an adapter, or
/// the caller's.
pub enum DeviceSource<'a> {
    /// The process's shared device of this adapter (device_pool).
    Own(&'a wgpu::Adapter),
    /// A device of its own on this adapter.
    Private(&'a wgpu::Adapter),
    /// The caller's device and queue, made on `adapter`.
    Given {
        adapter: &'a wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
    },
}

impl DeviceSource<'_> {
    /// The device with the rules every backend follows.
    pub(crate) fn context(self, precision: Precision) -> Result<GpuContext, GpuError> {
        match self {
            DeviceSource::Own(adapter) => GpuContext::new(adapter, precision),
            DeviceSource::Private(adapter) => GpuContext::private(adapter, precision),
            DeviceSource::Given {
                adapter,
                device,
                queue,
            } => GpuContext::on_device(adapter, device, queue, precision),
        }
    }
}
