//! Errors the device reported through wgpu's uncaptured-error handler.
//!
//! Every backend and kernel set installs a handler that appends the
//! messages to a shared list; after each submission the list is drained
//! here, so one rule turns them into a typed error everywhere: a message
//! mentioning "out of memory" is [`GpuError::OutOfMemory`], anything else
//! [`GpuError::Other`], all messages joined with "; ". A wait that fails is
//! [`GpuError::DeviceLost`].

use std::sync::{Arc, Mutex};

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

/// Installs the handler that appends every uncaptured error of `device` to
/// the returned list (drained by [`take_device_errors`]).
pub(crate) fn collect_device_errors(device: &wgpu::Device) -> Arc<Mutex<Vec<String>>> {
    let errors: Arc<Mutex<Vec<String>>> = Arc::default();
    let sink = errors.clone();
    device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
        if let Ok(mut v) = sink.lock() {
            v.push(e.to_string());
        }
    }));
    errors
}
