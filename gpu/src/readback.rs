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
    let mut all = read_mapped_all(ctx, &[(buffer, len)])?;
    Ok(all.pop().unwrap_or_default())
}

/// [`read_mapped`] of several buffers: every mapping started, then ONE
/// wait for all of them; the copies in `reads` order.
pub(crate) fn read_mapped_all(
    ctx: &GpuContext,
    reads: &[(&wgpu::Buffer, u64)],
) -> Result<Vec<Vec<u8>>, GpuError> {
    let pending: Vec<_> = reads
        .iter()
        .map(|&(buffer, len)| {
            (len > 0).then(|| {
                let (tx, rx) = std::sync::mpsc::channel();
                buffer
                    .slice(0..len)
                    .map_async(wgpu::MapMode::Read, move |r| {
                        let _ = tx.send(r);
                    });
                rx
            })
        })
        .collect();
    if pending.iter().any(Option::is_some) {
        ctx.poll(None)?;
    }
    let mut out = Vec::with_capacity(reads.len());
    let mut failure = None;
    for (&(buffer, len), rx) in reads.iter().zip(pending) {
        let Some(rx) = rx else {
            out.push(Vec::new());
            continue;
        };
        let mapped = match rx.recv() {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => Err(GpuError::Other {
                message: format!("buffer mapping failed: {e}"),
            }),
            Err(_) => Err(GpuError::DeviceLost {
                message: "buffer mapping was never answered".into(),
            }),
        };
        // A mapped buffer is copied out, then unmapped whatever happened,
        // so a failed read never leaves it mapped for the next one.
        let bytes = mapped.and_then(|()| {
            let bytes = buffer
                .slice(0..len)
                .get_mapped_range()
                .map(|view| view.to_vec())
                .map_err(|e| GpuError::Other {
                    message: format!("mapped range: {e:?}"),
                });
            buffer.unmap();
            bytes
        });
        match bytes {
            Ok(bytes) => out.push(bytes),
            Err(e) => {
                failure.get_or_insert(e);
                out.push(Vec::new());
            }
        }
    }
    match failure {
        // A lost device (or an error it reported) says more than the
        // failed mapping it caused.
        Some(e) => {
            ctx.check()?;
            Err(e)
        }
        None => Ok(out),
    }
}
