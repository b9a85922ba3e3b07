//! The shader path: how a composed module reaches the driver.
//!
//! ```text
//! wgsl    wgpu compiles the WGSL (naga → SPIR-V/MSL/HLSL) and the driver
//!         may contract a·b + c into an FMA or regroup: results hold to the
//!         stated f32/f64 bounds, not bit for bit
//! spirv   per pipeline (entry point, override constants):
//!           compose → naga parse + validate → process_overrides
//!           → constant call arguments folded into their callees
//!             (specialize.rs) → validate
//!           → naga SPIR-V (wgpu's Vulkan options: bounds checks, loop
//!             bounding, workgroup zeroing) → NoContraction on every float
//!             arithmetic result (no_contraction.rs)
//!           → wgpu passthrough (Features::PASSTHROUGH_SHADERS, Vulkan)
//!         so no driver may fuse or regroup: gpu-f64 = golden and gpu-f32 =
//!         f32 reference bit for bit on any conforming Vulkan driver
//! choice  HYPERPBD_SHADER_PATH = wgsl | spirv | auto (default auto:
//!         spirv where the adapter is Vulkan with PASSTHROUGH_SHADERS,
//!         else wgsl with a notice); spirv where it is not offered is a
//!         MissingFeature error, never a silent downgrade
//! ```

use hyperpbd_core::GpuError;

use crate::Precision;
use crate::shader::{ShaderFile, compose_with, validate};

/// The environment variable that chooses the shader path.
pub const SHADER_PATH_VARIABLE: &str = "HYPERPBD_SHADER_PATH";

/// How composed modules reach the driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ShaderPath {
    /// wgpu compiles the WGSL; the driver may contract and regroup.
    Wgsl,
    /// naga SPIR-V with `NoContraction` on every float arithmetic result,
    /// created through wgpu's passthrough path (Vulkan).
    Spirv,
}

/// What `HYPERPBD_SHADER_PATH` asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Request {
    Auto,
    Only(ShaderPath),
}

impl ShaderPath {
    /// `wgsl` or `spirv`.
    pub fn as_str(self) -> &'static str {
        match self {
            ShaderPath::Wgsl => "wgsl",
            ShaderPath::Spirv => "spirv",
        }
    }

    /// One line for `info` and `run`: the path and what it guarantees.
    pub fn describe(self) -> &'static str {
        match self {
            ShaderPath::Spirv => {
                "shader path: spirv (naga SPIR-V, NoContraction on every float \
                 arithmetic result, wgpu passthrough): no contraction, no regrouping"
            }
            ShaderPath::Wgsl => {
                "shader path: wgsl (the driver may contract a*b + c and regroup: \
                 gpu results hold to the stated bounds, bit-identity only on a \
                 non-contracting adapter such as lavapipe)"
            }
        }
    }

    /// The path for an adapter with `features` on `backend`, as
    /// `HYPERPBD_SHADER_PATH` chooses.
    ///
    /// # Errors
    ///
    /// [`GpuError::MissingFeature`] when `spirv` is asked for and the
    /// adapter is not Vulkan with `PASSTHROUGH_SHADERS`;
    /// [`GpuError::Other`] naming the variable when its value is not one of
    /// `wgsl`, `spirv`, `auto`.
    pub fn choose(
        adapter: &str,
        backend: wgpu::Backend,
        features: wgpu::Features,
    ) -> Result<ShaderPath, GpuError> {
        let offered = offers_passthrough(backend, features);
        match request()? {
            Request::Only(ShaderPath::Wgsl) => Ok(ShaderPath::Wgsl),
            Request::Only(ShaderPath::Spirv) if offered => Ok(ShaderPath::Spirv),
            Request::Only(ShaderPath::Spirv) => Err(GpuError::MissingFeature {
                adapter: adapter.to_owned(),
                feature: format!(
                    "PASSTHROUGH_SHADERS on Vulkan ({SHADER_PATH_VARIABLE}=spirv; backend {})",
                    backend.to_str()
                ),
            }),
            Request::Auto if offered => Ok(ShaderPath::Spirv),
            Request::Auto => Ok(ShaderPath::Wgsl),
        }
    }

    /// The path GPU backends of `precision` take on the adapter
    /// [`crate::request_adapter`] picks (what `info` and `run` print).
    ///
    /// # Errors
    ///
    /// Those of [`crate::request_adapter`] and [`ShaderPath::choose`].
    pub fn current(precision: Precision) -> Result<ShaderPath, GpuError> {
        let (adapter, summary) = crate::request_adapter(precision)?;
        ShaderPath::choose(
            &summary.name,
            adapter.get_info().backend,
            adapter.features(),
        )
    }

    /// The path kernel sets on `device` use: spirv when the device was
    /// created with `PASSTHROUGH_SHADERS` on Vulkan and the variable does
    /// not say `wgsl`; wgsl otherwise, except that `spirv` asked for on a
    /// device without the feature (a caller's own device) is
    /// [`GpuError::MissingFeature`].
    pub(crate) fn of_device(device: &wgpu::Device) -> Result<ShaderPath, GpuError> {
        let info = device.adapter_info();
        let offered = offers_passthrough(info.backend, device.features());
        match (request()?, offered) {
            (Request::Only(ShaderPath::Wgsl), _) | (Request::Auto, false) => Ok(ShaderPath::Wgsl),
            (Request::Only(ShaderPath::Spirv) | Request::Auto, true) => Ok(ShaderPath::Spirv),
            (Request::Only(ShaderPath::Spirv), false) => Err(GpuError::MissingFeature {
                adapter: format!("{} (the device given)", info.name),
                feature: format!(
                    "PASSTHROUGH_SHADERS on Vulkan ({SHADER_PATH_VARIABLE}=spirv; backend {})",
                    info.backend.to_str()
                ),
            }),
        }
    }
}

/// Whether SPIR-V passthrough is available: Vulkan with the feature.
fn offers_passthrough(backend: wgpu::Backend, features: wgpu::Features) -> bool {
    backend == wgpu::Backend::Vulkan && features.contains(wgpu::Features::PASSTHROUGH_SHADERS)
}

/// `HYPERPBD_SHADER_PATH`, parsed (unset or empty: auto).
fn request() -> Result<Request, GpuError> {
    match std::env::var(SHADER_PATH_VARIABLE) {
        Err(std::env::VarError::NotPresent) => Ok(Request::Auto),
        Err(std::env::VarError::NotUnicode(v)) => Err(GpuError::Other {
            message: format!("{SHADER_PATH_VARIABLE}={v:?}: expected wgsl, spirv or auto"),
        }),
        Ok(v) => match v.trim() {
            "" | "auto" => Ok(Request::Auto),
            "wgsl" => Ok(Request::Only(ShaderPath::Wgsl)),
            "spirv" => Ok(Request::Only(ShaderPath::Spirv)),
            other => Err(GpuError::Other {
                message: format!("{SHADER_PATH_VARIABLE}={other:?}: expected wgsl, spirv or auto"),
            }),
        },
    }
}

/// naga's SPIR-V options, as wgpu's Vulkan backend sets them for a checked
/// module: index and buffer accesses restricted, loops bounded, workgroup
/// memory zeroed (polyfill: needs no extension), SPIR-V 1.3 (Vulkan 1.1).
fn options() -> naga::back::spv::Options<'static> {
    use naga::proc::{BoundsCheckPolicies, BoundsCheckPolicy};
    naga::back::spv::Options {
        lang_version: (1, 3),
        flags: naga::back::spv::WriterFlags::empty(),
        bounds_check_policies: BoundsCheckPolicies {
            index: BoundsCheckPolicy::Restrict,
            buffer: BoundsCheckPolicy::Restrict,
            image_load: BoundsCheckPolicy::Restrict,
            binding_array: BoundsCheckPolicy::Unchecked,
        },
        zero_initialize_workgroup_memory:
            naga::back::spv::ZeroInitializeWorkgroupMemoryMode::Polyfill,
        force_loop_bounding: true,
        ..Default::default()
    }
}

/// The parsed and validated module of `file` (compose, naga).
pub(crate) fn parse(
    file: ShaderFile,
    dim: usize,
    precision: Precision,
    generated: Option<&str>,
) -> Result<(naga::Module, naga::valid::ModuleInfo), GpuError> {
    let source = compose_with(file, dim, precision, generated);
    validate(&source, precision).map_err(|message| GpuError::Other {
        message: format!("{} (DIM {dim}, {precision}): {message}", file.file_name()),
    })
}

/// SPIR-V words of one pipeline of `module` (`file`'s): entry point `entry`
/// specialised with `constants`, every float arithmetic result decorated
/// `NoContraction`.
pub(crate) fn pipeline_words(
    file: ShaderFile,
    parsed: &(naga::Module, naga::valid::ModuleInfo),
    entry: &str,
    constants: &[(&str, f64)],
) -> Result<Vec<u32>, GpuError> {
    let fail = |what: String| GpuError::Other {
        message: format!("{} entry {entry}: {what}", file.file_name()),
    };
    let mut values = naga::back::PipelineConstants::default();
    for &(name, value) in constants {
        values.insert(name.to_owned(), value);
    }
    let stage = naga::ShaderStage::Compute;
    let (module, _) = naga::back::pipeline_constants::process_overrides(
        &parsed.0,
        &parsed.1,
        Some((stage, entry)),
        &values,
    )
    .map_err(|e| fail(format!("override constants: {e}")))?;
    // Constant call arguments folded into their callees: the driver gets
    // only the branches this pipeline runs (specialize.rs).
    let module = crate::specialize::constant_arguments(module.into_owned());
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| fail(format!("specialised module: {e:?}")))?;
    let pipeline = naga::back::spv::PipelineOptions {
        shader_stage: stage,
        entry_point: entry.to_owned(),
    };
    let words = naga::back::spv::write_vec(&module, &info, &options(), Some(&pipeline))
        .map_err(|e| fail(format!("SPIR-V: {e}")))?;
    crate::no_contraction::decorate(&words).map_err(fail)
}

/// SPIR-V of every entry point of `file` for `dim` and `precision`, with
/// no override constants given (their WGSL defaults), decorated: what the
/// tests parse to prove every float result carries `NoContraction`.
///
/// # Errors
///
/// [`GpuError::Other`] naming the file and entry when naga rejects it.
pub fn entry_words(
    file: ShaderFile,
    dim: usize,
    precision: Precision,
) -> Result<Vec<(&'static str, Vec<u32>)>, GpuError> {
    let parsed = parse(file, dim, precision, None)?;
    file.entry_points()
        .iter()
        .map(|&entry| Ok((entry, pipeline_words(file, &parsed, entry, &[])?)))
        .collect()
}

/// The passthrough module of one pipeline (see [`pipeline_words`]): one
/// entry point, its override constants already applied.
pub(crate) fn passthrough_module(
    device: &wgpu::Device,
    file: ShaderFile,
    parsed: &(naga::Module, naga::valid::ModuleInfo),
    entry: &'static str,
    constants: &[(&str, f64)],
) -> Result<wgpu::ShaderModule, GpuError> {
    let words = pipeline_words(file, parsed, entry, constants)?;
    let workgroup = file.workgroup_size();
    let entry_points = [wgpu::PassthroughShaderEntryPoint {
        name: entry.into(),
        workgroup_size: (workgroup, 1, 1),
    }];
    let desc = wgpu::ShaderModuleDescriptorPassthrough {
        label: Some(file.file_name()),
        entry_points: entry_points[..].into(),
        spirv: Some(words.into()),
        ..Default::default()
    };
    // SAFETY: the words are naga's SPIR-V of a module naga parsed and
    // validated (the checks wgpu runs on WGSL), written with the options
    // wgpu's Vulkan backend uses for a checked module (bounds checks, loop
    // bounding, workgroup zeroing); the only change is added `OpDecorate
    // … NoContraction` instructions, which do not alter the interface. The
    // pipeline layout is explicit and is the one reflected from the same
    // module (kernel_set.rs), so bindings agree.
    Ok(unsafe { device.create_shader_module_passthrough(desc) })
}
