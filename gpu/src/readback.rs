//! Reading a mappable buffer back to the host: map, wait, copy, unmap.
//!
//! Every backend and kernel set reads results the same way, so a mapping
//! failure is reported the same way everywhere: a device that stops
//! answering is [`GpuError::DeviceLost`], a refused mapping is
//! [`GpuError::Other`].

use hyperpbd_core::GpuError;

/// The device's side of a read: `poll` waits for it (the context's one
/// counted poll), `check` names a lost device or a reported error.
pub(crate) struct Waiter<'a> {
    pub poll: &'a dyn Fn() -> Result<(), GpuError>,
    pub check: &'a dyn Fn() -> Result<(), GpuError>,
}

/// Maps the first `len` bytes of every (buffer, len) of `reads` (`MAP_READ`
/// buffers whose copies have been submitted), waits ONCE for all of them,
/// and returns copies in `reads` order (no wait when every len is 0).
pub(crate) fn read_mapped_all(
    waiter: &Waiter<'_>,
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
        (waiter.poll)()?;
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
            (waiter.check)()?;
            Err(e)
        }
        None => Ok(out),
    }
}
