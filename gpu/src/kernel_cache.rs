//! Kernel sets compiled once per device.
//!
//! A kernel set is a function of its spec (`kernel_set::KernelSetSpec`)
//! and the device: the
//! same label, modules, dimension, precision, entry points (with their
//! constants), set-wide constants and generated WGSL compose the same
//! shaders and compile to the same pipelines. The cache keys a set by all
//! of them (and by the entry type), so a backend loaded on a device that
//! already built its set gets the built layouts and pipelines (wgpu
//! handles, shared) instead of compiling them again; a spec that differs
//! in anything is built anew. Nothing of a backend's state lives in a
//! kernel set (buffers and bind groups are the backend's own).

use std::any::Any;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use hyperpbd_core::GpuError;

/// Built values by key, on one device (clones share the map).
#[derive(Clone, Default)]
pub(crate) struct KernelCache {
    sets: Arc<Mutex<HashMap<String, Arc<dyn Any + Send + Sync>>>>,
}

impl KernelCache {
    /// The value cached under `key` (and of type `T`), else `build()`,
    /// cached when it succeeds (a failed build is not remembered).
    pub fn get_or_build<T: Clone + Send + Sync + 'static>(
        &self,
        key: String,
        build: impl FnOnce() -> Result<T, GpuError>,
    ) -> Result<T, GpuError> {
        if let Ok(sets) = self.sets.lock()
            && let Some(value) = sets.get(&key).and_then(|s| s.downcast_ref::<T>())
        {
            return Ok(value.clone());
        }
        let value = build()?;
        if let Ok(mut sets) = self.sets.lock() {
            sets.insert(key, Arc::new(value.clone()));
        }
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_is_built_once_and_a_failed_build_is_not_kept() {
        let cache = KernelCache::default();
        let mut builds = 0;
        for _ in 0..3 {
            let value = cache.get_or_build("a".into(), || {
                builds += 1;
                Ok(7_u32)
            });
            assert_eq!(value, Ok(7));
        }
        assert_eq!(builds, 1);
        let failed: Result<u32, GpuError> = cache.get_or_build("b".into(), || {
            Err(GpuError::Other {
                message: "refused".into(),
            })
        });
        assert!(failed.is_err());
        assert_eq!(cache.get_or_build("b".into(), || Ok(8_u32)), Ok(8));
        // Another type under the same key is built, not mistaken.
        assert_eq!(cache.get_or_build("a".into(), || Ok(9_u64)), Ok(9));
    }
}
