//! Adapter discovery and device creation.
//!
//! One [`wgpu::Instance`] per call, configured from the environment the way
//! wgpu documents it (`WGPU_BACKEND=vulkan`, `WGPU_VALIDATION=1`, …), so a
//! user can steer the choice without a flag of ours. Nothing here unwraps
//! anything a driver can cause: a missing adapter, a missing feature and a
//! refused device are all [`GpuError`]s.

use std::fmt;

use hyperpbd_core::GpuError;

/// What to tell a user whose machine shows no adapter at all.
const INSTALL_HINT: &str = " (install a Vulkan driver; for the software rasteriser lavapipe: \
     apt-get install mesa-vulkan-drivers libvulkan1)";

pub use hyperpbd_core::Precision;

/// The device features kernels of `precision` need.
pub fn required_features(precision: Precision) -> wgpu::Features {
    match precision {
        Precision::F32 => wgpu::Features::empty(),
        Precision::F64 => wgpu::Features::SHADER_F64,
    }
}

/// What an adapter is and what it can do, in plain data (for printing,
/// reports, and deciding which tests apply).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AdapterSummary {
    /// Adapter name as the driver reports it (e.g.
    /// `llvmpipe (LLVM 15.0.7, 256 bits)`).
    pub name: String,
    /// Backend API, lower case: `vulkan`, `metal`, `dx12`, `gl`, …
    pub backend: String,
    /// `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu`, `Cpu` or `Other`.
    pub device_type: String,
    /// Driver name (may be empty on some backends).
    pub driver: String,
    /// Driver version and details (may be empty on some backends).
    pub driver_info: String,
    /// Whether the adapter offers [`wgpu::Features::SHADER_F64`].
    pub shader_f64: bool,
    /// Whether the adapter is Vulkan with
    /// [`wgpu::Features::PASSTHROUGH_SHADERS`] (the no-contraction SPIR-V
    /// shader path, [`crate::ShaderPath::Spirv`], can run).
    pub passthrough: bool,
    /// Largest storage-buffer binding, in bytes.
    pub max_storage_buffer_binding_size: u64,
    /// Largest buffer, in bytes.
    pub max_buffer_size: u64,
}

impl AdapterSummary {
    /// Summarise an adapter.
    pub fn of(adapter: &wgpu::Adapter) -> Self {
        let info = adapter.get_info();
        let limits = adapter.limits();
        AdapterSummary {
            name: info.name,
            backend: info.backend.to_str().to_owned(),
            device_type: format!("{:?}", info.device_type),
            driver: info.driver,
            driver_info: info.driver_info,
            shader_f64: adapter.features().contains(wgpu::Features::SHADER_F64),
            passthrough: info.backend == wgpu::Backend::Vulkan
                && adapter
                    .features()
                    .contains(wgpu::Features::PASSTHROUGH_SHADERS),
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            max_buffer_size: limits.max_buffer_size,
        }
    }

    /// Whether kernels of `precision` can run on this adapter.
    pub fn supports(&self, precision: Precision) -> bool {
        match precision {
            Precision::F32 => true,
            Precision::F64 => self.shader_f64,
        }
    }
}

impl fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} [{}, {}]", self.name, self.backend, self.device_type)?;
        match (self.driver.is_empty(), self.driver_info.is_empty()) {
            (false, false) => write!(f, " driver: {} ({})", self.driver, self.driver_info)?,
            (false, true) => write!(f, " driver: {}", self.driver)?,
            (true, false) => write!(f, " driver: {}", self.driver_info)?,
            (true, true) => {}
        }
        write!(
            f,
            "; f64: {}; passthrough: {}; max storage binding: {} B; max buffer: {} B",
            if self.shader_f64 { "yes" } else { "no" },
            if self.passthrough { "yes" } else { "no" },
            self.max_storage_buffer_binding_size,
            self.max_buffer_size
        )
    }
}

/// An instance over `backends`, or over those `WGPU_BACKEND` names when it
/// is set, with the instance flags the environment sets (`WGPU_VALIDATION`,
/// …). Returns the backends actually enabled.
fn instance(backends: wgpu::Backends) -> (wgpu::Instance, wgpu::Backends) {
    quiet_device_select_layer();
    let desc = wgpu::InstanceDescriptor {
        backends,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    }
    .with_env();
    let backends = desc.backends;
    (wgpu::Instance::new(desc), backends)
}

/// Keeps Mesa's device-select Vulkan layer from printing
/// `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` on
/// every instance of a process started outside a desktop session.
///
/// That implicit layer only reorders devices for a display server (it asks
/// Wayland, whose client library prints the line when the session's runtime
/// directory is missing); it is switched off by `NODEVICE_SELECT=1`, the
/// variable its manifest names. This sets it once per process, before the
/// first instance, and only when there is no session directory to find and
/// the user set neither it nor `MESA_VK_DEVICE_SELECT` (whose device choice
/// the layer would then honour). Nothing is filtered: a driver's real
/// errors still reach stderr.
fn quiet_device_select_layer() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
        let session = std::env::var_os("XDG_RUNTIME_DIR")
            .is_some_and(|dir| std::path::Path::new(&dir).is_dir());
        if !session && !set("NODEVICE_SELECT") && !set("MESA_VK_DEVICE_SELECT") {
            // SAFETY: runs once, before this process creates its first
            // wgpu instance, so no Vulkan or GL loader thread reads the
            // environment yet; Rust's own readers take std's environment
            // lock.
            unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
        }
    });
}

/// Every adapter on every backend compiled in (or those `WGPU_BACKEND`
/// names), in the order wgpu enumerates them. Empty when there is none;
/// never panics on a machine without a GPU.
pub fn list_adapters() -> Vec<AdapterSummary> {
    let (instance, backends) = instance(wgpu::Backends::all());
    pollster::block_on(instance.enumerate_adapters(backends))
        .iter()
        .map(AdapterSummary::of)
        .collect()
}

/// The adapter hyperpbd runs on: wgpu's high-performance choice, or failing
/// that its fallback (software) adapter.
///
/// The primary backends (Vulkan, Metal, DX12) are searched first and OpenGL
/// only when they have no adapter at all: GL offers no `SHADER_F64` and only
/// downlevel compute, and wgpu ranks a GL adapter of type `Other` above a
/// Vulkan `Cpu` one, so searching all backends at once could pick GL over
/// lavapipe. `WGPU_BACKEND` (e.g. `WGPU_BACKEND=gl`) overrides this.
///
/// # Errors
///
/// - [`GpuError::NoAdapter`] when no adapter exists at all (the detail says
///   what wgpu looked at and how to install a driver).
/// - [`GpuError::MissingFeature`] when `precision` is [`Precision::F64`] and
///   the chosen adapter lacks `SHADER_F64`. There is no silent downgrade to
///   f32 and no fallback to the CPU.
pub fn request_adapter(precision: Precision) -> Result<(wgpu::Adapter, AdapterSummary), GpuError> {
    let adapter = find_adapter()?;
    let summary = AdapterSummary::of(&adapter);
    check_features(&adapter, &summary.name, precision)?;
    Ok((adapter, summary))
}

/// Primary backends, then all; in each, high performance, then fallback.
fn find_adapter() -> Result<wgpu::Adapter, GpuError> {
    let options = |force_fallback_adapter| wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter,
        compatible_surface: None,
        apply_limit_buckets: false,
    };
    let mut searched = wgpu::Backends::empty();
    let mut last_error = None;
    for wanted in [wgpu::Backends::PRIMARY, wgpu::Backends::all()] {
        let (instance, backends) = instance(wanted);
        if searched.contains(backends) {
            continue; // WGPU_BACKEND is set: the second pass would repeat the first
        }
        searched |= backends;
        for force_fallback_adapter in [false, true] {
            match pollster::block_on(instance.request_adapter(&options(force_fallback_adapter))) {
                Ok(adapter) => return Ok(adapter),
                Err(e) => last_error = Some(e),
            }
        }
    }
    let why = last_error.map_or_else(String::new, |e| format!(": {e}"));
    Err(GpuError::NoAdapter {
        detail: format!("{why}{INSTALL_HINT}"),
    })
}

/// A device and its queue on `adapter`, with the features `precision` needs
/// (and `PASSTHROUGH_SHADERS` where the shader path is
/// [`crate::ShaderPath::Spirv`], see [`crate::ShaderPath::choose`])
/// and the adapter's own limits (not the WebGPU defaults: large scenes need
/// the large storage bindings a desktop adapter offers).
///
/// # Errors
///
/// - [`GpuError::MissingFeature`] when the adapter lacks a feature
///   `precision` needs (checked before asking, so wgpu never panics on it).
/// - [`GpuError::DeviceRequest`] when the driver refuses the device.
/// - The errors of [`crate::ShaderPath::choose`] (`HYPERPBD_SHADER_PATH`).
pub fn request_device(
    adapter: &wgpu::Adapter,
    precision: Precision,
) -> Result<(wgpu::Device, wgpu::Queue), GpuError> {
    let info = adapter.get_info();
    let name = info.name;
    check_features(adapter, &name, precision)?;
    let path = crate::ShaderPath::choose(&name, info.backend, adapter.features())?;
    let passthrough = match path {
        crate::ShaderPath::Spirv => wgpu::Features::PASSTHROUGH_SHADERS,
        crate::ShaderPath::Wgsl => wgpu::Features::empty(),
    };
    let desc = wgpu::DeviceDescriptor {
        label: Some("hyperpbd"),
        required_features: required_features(precision) | passthrough,
        required_limits: adapter.limits(),
        experimental_features: wgpu::ExperimentalFeatures::disabled(),
        memory_hints: wgpu::MemoryHints::Performance,
        trace: wgpu::Trace::Off,
    };
    pollster::block_on(adapter.request_device(&desc)).map_err(|e| GpuError::DeviceRequest {
        adapter: name,
        message: e.to_string(),
    })
}

/// [`GpuError::MissingFeature`] naming the first feature `precision` needs
/// that `adapter` lacks.
fn check_features(
    adapter: &wgpu::Adapter,
    adapter_name: &str,
    precision: Precision,
) -> Result<(), GpuError> {
    let missing = required_features(precision) - adapter.features();
    match missing.iter().next() {
        None => Ok(()),
        Some(feature) => Err(GpuError::MissingFeature {
            adapter: adapter_name.to_owned(),
            feature: feature_name(feature),
        }),
    }
}

/// `SHADER_F64` for [`wgpu::Features::SHADER_F64`], the bitflags name of a
/// single feature.
fn feature_name(feature: wgpu::Features) -> String {
    feature
        .iter_names()
        .next()
        .map_or_else(|| format!("{feature:?}"), |(name, _)| name.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feature_names_are_the_constant_names() {
        assert_eq!(feature_name(wgpu::Features::SHADER_F64), "SHADER_F64");
    }

    #[test]
    fn f32_needs_nothing_f64_needs_shader_f64() {
        assert!(required_features(Precision::F32).is_empty());
        assert_eq!(
            required_features(Precision::F64),
            wgpu::Features::SHADER_F64
        );
    }

    #[test]
    fn summary_displays_on_one_line() {
        let s = AdapterSummary {
            name: "llvmpipe (LLVM 15.0.7, 256 bits)".into(),
            backend: "vulkan".into(),
            device_type: "Cpu".into(),
            driver: "llvmpipe".into(),
            driver_info: "Mesa 23.2.1".into(),
            shader_f64: true,
            passthrough: true,
            max_storage_buffer_binding_size: 1 << 27,
            max_buffer_size: 1 << 30,
        };
        let line = s.to_string();
        assert!(!line.contains('\n'), "{line}");
        assert!(
            line.contains("llvmpipe")
                && line.contains("f64: yes")
                && line.contains("passthrough: yes"),
            "{line}"
        );
        assert!(s.supports(Precision::F64));
    }
}
