//! Errors the device reported through wgpu's uncaptured-error handler.
//!
//! The device's handler (device_pool) appends every message to the list
//! of each backend on the device; after each submission a backend's list
//! is drained here, so one rule turns them into a typed error everywhere: a message
//! mentioning "out of memory" is [`GpuError::OutOfMemory`], anything else
//! [`GpuError::Other`], all messages joined with "; ". A wait that fails is
//! [`GpuError::DeviceLost`].

use std::sync::Mutex;

use hyperpbd_core::GpuError;

/// Drains `errors`; `Ok` when the device reported nothing.
pub(crate) fn take_device_errors(errors: &Mutex<Vec<String>>) -> Result<(), GpuError> {
    if let Ok(mut e) = errors.lock()
        && !e.is_empty()
    {
        let message = e.join("; ");
        e.clear();
        if message.to_lowercase().contains("out of memory") {
            return Err(GpuError::OutOfMemory { message });
        }
        return Err(GpuError::Other { message });
    }
    Ok(())
}
