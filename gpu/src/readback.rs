//! Reading a mappable buffer back to the host: map, wait, copy, unmap.
//!
//! Every backend and kernel set reads results the same way, so a mapping
//! failure is reported the same way everywhere: a device that stops
//! answering is [`GpuError::DeviceLost`], a refused mapping is
//! [`GpuError::Other`].

use hyperpbd_core::GpuError;

use crate::context::GpuContext;

/// Maps the first `len` bytes of `buffer` (a `MAP_READ` buffer whose copies
/// have been submitted), waits for the device (one counted
/// [`GpuContext::poll`]), and returns a copy of them.
pub(crate) fn read_mapped(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    len: u64,
) -> Result<Vec<u8>, GpuError> {
    if len == 0 {
        return Ok(Vec::new());
    }
    let slice = buffer.slice(0..len);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.poll(None)?;
    match rx.recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => {
            return Err(GpuError::Other {
                message: format!("buffer mapping failed: {e}"),
            });
        }
        Err(_) => {
            return Err(GpuError::DeviceLost {
                message: "buffer mapping was never answered".into(),
            });
        }
    }
    // Copy out, then unmap whatever happened, so a failed read never
    // leaves the buffer mapped for the next one.
    let bytes = slice.get_mapped_range().map(|view| view.to_vec());
    buffer.unmap();
    bytes.map_err(|e| GpuError::Other {
        message: format!("mapped range: {e:?}"),
    })
}
