//! The typed errors of loops llvmpipe cut short.
//!
//! llvmpipe keeps one loop counter per group of 8 neighbouring invocations
//! (its SIMD width): 65 535 iterations in all loops together; past it every
//! loop runs its body once and stops, silently. The kernels detect the cut
//! (backend/status.rs, barrier.rs, contact); these are the errors the host
//! returns, after restoring the step's saved state.

use hyperpbd_core::GpuError;

/// The typed error of results whose loops were cut short (`invocation`:
/// the first such invocation, when the kernel names one).
pub(crate) fn loops_cut_short(invocation: Option<u32>) -> GpuError {
    let which = invocation.map_or_else(String::new, |i| format!(" of invocation {i}"));
    GpuError::Unsupported {
        what: format!(
            "loops this long on this adapter: it ended the loops{which} early \
             (llvmpipe stops a shader's loops after 65 535 iterations); use the CPU \
             backend (or, for a long fused run of calls, fewer substeps per step)"
        ),
    }
}

/// The typed error of barrier / incremental-potential results whose loops
/// over the obstacles were cut short (`particle`: the first such particle).
pub(crate) fn obstacle_loops_cut_short(particle: u32) -> GpuError {
    GpuError::Unsupported {
        what: format!(
            "loops this long on this adapter: it ended the obstacle loops of particle \
             {particle} early (llvmpipe stops a shader's loops after 65 535 iterations, \
             shared by 8 neighbouring particles); use fewer obstacle simplices (a coarser \
             mesh, or only the part the particles can reach), a hardware adapter, or the \
             CPU backend"
        ),
    }
}
