//! Kernel sets compiled once per device.
//!
//! A kernel set is a function of its [`KernelSetSpec`] and the device: the
//! same label, modules, dimension, precision, entry points (with their
//! constants), set-wide constants and generated WGSL compose the same
//! shaders and compile to the same pipelines. The cache keys a set by all
//! of them (and by the entry type), so a backend loaded on a device that
//! already built its set gets the built layouts and pipelines (wgpu
//! handles, shared) instead of compiling them again; a spec that differs
//! in anything is built anew. Nothing of a backend's state lives in a
//! kernel set (buffers and bind groups are the backend's own).

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use hyperpbd_core::GpuError;

use crate::kernel_set::{EntryPoint, KernelSet, KernelSetSpec};

/// Kernel sets by spec, on one device (clones share the map).
#[derive(Clone, Default)]
pub(crate) struct KernelCache {
    sets: Arc<Mutex<HashMap<String, Arc<dyn Any + Send + Sync>>>>,
}

impl KernelCache {
    /// The set of `spec`: the cached one, else `build()`, cached when it
    /// succeeds (a failed build is not remembered).
    pub fn get_or_build<E: EntryPoint + Send + Sync>(
        &self,
        spec: &KernelSetSpec<'_, E>,
        build: impl FnOnce() -> Result<KernelSet<E>, GpuError>,
    ) -> Result<KernelSet<E>, GpuError> {
        let key = key(spec);
        if let Ok(sets) = self.sets.lock()
            && let Some(set) = sets.get(&key).and_then(|s| s.downcast_ref::<KernelSet<E>>())
        {
            return Ok(set.clone());
        }
        let set = build()?;
        if let Ok(mut sets) = self.sets.lock() {
            sets.insert(key, Arc::new(set.clone()));
        }
        Ok(set)
    }
}

/// Everything a kernel set is made of, as one string.
fn key<E: EntryPoint>(spec: &KernelSetSpec<'_, E>) -> String {
    let entries: Vec<_> = spec
        .entries
        .iter()
        .map(|&e| (e, e.source(), e.constants()))
        .collect();
    format!(
        "{:?}|{}|{}|{:?}|{:?}|{:?}|{:?}|{:?}",
        TypeId::of::<E>(),
        spec.label,
        spec.dim,
        spec.precision,
        spec.modules,
        entries,
        spec.constants,
        spec.generated,
    )
}
