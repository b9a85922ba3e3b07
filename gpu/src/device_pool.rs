//! One device per adapter, precision and shader path in a process, shared
//! by every backend loaded on that adapter, with the kernels compiled on it.
//!
//! ```text
//! shared(adapter, precision)   the pooled device of (adapter, precision,
//!                              shader path), made on first use; a device
//!                              that was lost is dropped and made again
//! Pooled::subscribe()          a new error list of one backend: every
//!                              uncaptured error of the device is appended
//!                              to every live list (a fault of a shared
//!                              device is every sharer's fault)
//! ```
//!
//! Why share: a backend's load is dominated by pipeline compilation (on
//! lavapipe ~1.5 s of CPU for a 2D chain, most of it the driver's), and
//! the same kernel set (dimension, precision, entry points, generated
//! WGSL) compiles to the same pipelines on the same device, so a second
//! backend on the device takes them from [`KernelCache`] instead. Backends
//! keep their own buffers, host-wait counters and state; they share the
//! queue (the device runs their submissions in order) and the device's
//! fate (a lost device is lost for all). A backend that must own its
//! device — to destroy it in a fault-injection test — is loaded with
//! `with_private_device`.

use std::sync::{Arc, Mutex, Weak};

use hyperpbd_core::GpuError;

use crate::Precision;
use crate::kernel_cache::KernelCache;

/// The uncaptured-error lists of the backends on one device.
type Subscribers = Arc<Mutex<Vec<Weak<Mutex<Vec<String>>>>>>;

/// A device of the pool and what its sharers share.
#[derive(Clone)]
pub(crate) struct Pooled {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// Set by the device-lost callback.
    pub lost: Arc<Mutex<Option<String>>>,
    /// The kernel sets compiled on the device.
    pub kernels: KernelCache,
    subscribers: Subscribers,
}

impl Pooled {
    /// A device of its own on `adapter`, with the uncaptured-error handler
    /// and device-lost callback installed (not in the pool).
    pub fn private(adapter: &wgpu::Adapter, precision: Precision) -> Result<Self, GpuError> {
        let (device, queue) = crate::request_device(adapter, precision)?;
        let subscribers: Subscribers = Arc::default();
        let sink = subscribers.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut lists) = sink.lock() {
                let message = e.to_string();
                lists.retain(|list| match list.upgrade() {
                    Some(list) => {
                        if let Ok(mut list) = list.lock() {
                            list.push(message.clone());
                        }
                        true
                    }
                    None => false,
                });
            }
        }));
        let lost: Arc<Mutex<Option<String>>> = Arc::default();
        let flag = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut l) = flag.lock() {
                *l = Some(format!("{reason:?}: {message}"));
            }
        });
        Ok(Pooled {
            device,
            queue,
            lost,
            kernels: KernelCache::default(),
            subscribers,
        })
    }

    /// A new list that receives every uncaptured error of the device from
    /// now on (drained by `device_errors::take_device_errors`).
    pub fn subscribe(&self) -> Arc<Mutex<Vec<String>>> {
        let list: Arc<Mutex<Vec<String>>> = Arc::default();
        if let Ok(mut lists) = self.subscribers.lock() {
            // The lists of dropped backends go here, not only on an error.
            lists.retain(|l| l.strong_count() > 0);
            lists.push(Arc::downgrade(&list));
        }
        list
    }

    fn is_lost(&self) -> bool {
        self.lost.lock().map(|l| l.is_some()).unwrap_or(true)
    }
}

/// The pool: (adapter, precision, shader path) → its device.
static POOL: Mutex<Vec<(String, Pooled)>> = Mutex::new(Vec::new());

/// The pooled device of `adapter` and `precision` (made on first use).
pub(crate) fn shared(adapter: &wgpu::Adapter, precision: Precision) -> Result<Pooled, GpuError> {
    let info = adapter.get_info();
    let path = crate::ShaderPath::choose(&info.name, info.backend, adapter.features())?;
    let key = format!("{info:?} {precision:?} {path:?}");
    let mut pool = POOL.lock().map_err(|_| GpuError::Other {
        message: "the device pool's lock is poisoned".into(),
    })?;
    pool.retain(|(_, pooled)| !pooled.is_lost());
    if let Some((_, pooled)) = pool.iter().find(|(k, _)| *k == key) {
        return Ok(pooled.clone());
    }
    let pooled = Pooled::private(adapter, precision)?;
    pool.push((key, pooled.clone()));
    Ok(pooled)
}
