//! Shader portability, with no GPU: every WGSL kernel file, composed for
//! every supported dimension (1..=8) and both precisions, is parsed and
//! validated by naga and translated through naga's SPIR-V, MSL and HLSL back
//! ends.
//!
//! ```text
//! for file in ShaderFile::ALL, dim in 1..=MAX_GPU_DIM, precision in {f32, f64}:
//!   source  = shader::compose(file, dim, precision)
//!   module  = shader::validate(source, precision)        (naga, all checks on)
//!   entry points of the module == file.entry_points()    (all compute)
//!   SPIR-V  naga::back::spv::write_vec                   (f32 and f64)
//!   HLSL    naga::back::hlsl::Writer                     (f32 and f64: `double`)
//!   MSL     naga::back::msl::write_string                (f32 only, see below)
//! ```
//!
//! Metal has no 64-bit float type. naga's MSL back end states this in its
//! capability set (`naga::back::msl::supported_capabilities()` lacks
//! `FLOAT64`), so the f64 modules are refused where naga refuses them:
//! validating them against the MSL capability set fails with
//! `Type { name: "real", source: WidthError(MissingCapability { name: "f64",
//! flag: "FLOAT64" }) }` — the header's `alias real = f64` is the first thing
//! refused. That exact refusal is asserted for every f64 module, and success
//! for every f32 one. (Calling `msl::write_string` on an f64 module validated
//! with FLOAT64 is outside naga's contract and, with naga 30.0.1, panics in
//! `Scalar::to_msl_name` with "Unsupported scalar kind" instead of returning
//! an error; the capability check above is the supported way to ask.) f64
//! kernels are therefore Vulkan (SPIR-V) and D3D12 (HLSL `double`) only; on
//! Metal the GPU backend runs f32.

use std::collections::BTreeSet;

use hyperpbd_gpu::Precision;
use hyperpbd_gpu::shader::{MAX_GPU_DIM, ShaderFile, compose, validate};
use naga::back::{hlsl, msl, spv};
use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};

const PRECISIONS: [Precision; 2] = [Precision::F32, Precision::F64];

/// Every (file, dim, precision) case.
fn cases() -> Vec<(ShaderFile, usize, Precision)> {
    let mut out = Vec::new();
    for file in ShaderFile::ALL {
        for dim in 1..=MAX_GPU_DIM {
            for precision in PRECISIONS {
                out.push((file, dim, precision));
            }
        }
    }
    out
}

fn label(file: ShaderFile, dim: usize, precision: Precision) -> String {
    format!("{} dim {dim} {precision}", file.file_name())
}

/// Composes and validates one case, failing with naga's rendered message;
/// pipeline-overridable constants take their defaults (as a pipeline
/// created without constants would).
fn module_of(file: ShaderFile, dim: usize, precision: Precision) -> (naga::Module, ModuleInfo) {
    let source = compose(file, dim, precision);
    let (module, info) = validate(&source, precision)
        .unwrap_or_else(|e| panic!("{} does not validate:\n{e}", label(file, dim, precision)));
    with_default_overrides(&module, &info)
}

/// `module` with every override replaced by its default.
fn with_default_overrides(module: &naga::Module, info: &ModuleInfo) -> (naga::Module, ModuleInfo) {
    let (module, info) =
        naga::back::pipeline_constants::process_overrides(module, info, None, &Default::default())
            .expect("every override has a default");
    (module.into_owned(), info.into_owned())
}

#[test]
fn there_are_eight_kernel_files_and_eight_dimensions() {
    assert_eq!(ShaderFile::ALL.len(), 8);
    assert_eq!(MAX_GPU_DIM, 8);
    assert_eq!(cases().len(), 8 * 8 * 2);
}

#[test]
fn every_file_dimension_and_precision_composes_parses_and_validates() {
    for (file, dim, precision) in cases() {
        let source = compose(file, dim, precision);
        assert!(
            source.contains(&format!("alias real = {precision};"))
                && source.contains(&format!("const DIM: u32 = {dim}u;")),
            "{}: the generated header does not name the precision and dimension",
            label(file, dim, precision)
        );
        let (module, _) = module_of(file, dim, precision);
        assert!(!module.entry_points.is_empty());
    }
}

#[test]
fn every_listed_entry_point_exists_as_a_compute_entry_point() {
    for (file, dim, precision) in cases() {
        let (module, _) = module_of(file, dim, precision);
        let found: BTreeSet<&str> = module
            .entry_points
            .iter()
            .map(|e| e.name.as_str())
            .collect();
        let listed: BTreeSet<&str> = file.entry_points().iter().copied().collect();
        assert_eq!(
            found,
            listed,
            "{}: entry points in the module vs ShaderFile::entry_points()",
            label(file, dim, precision)
        );
        for ep in &module.entry_points {
            assert_eq!(
                ep.stage,
                naga::ShaderStage::Compute,
                "{}: {} is not a compute entry point",
                label(file, dim, precision),
                ep.name
            );
            assert_eq!(
                ep.workgroup_size,
                [file.workgroup_size(), 1, 1],
                "{}: {} must use its file's workgroup size {}",
                label(file, dim, precision),
                ep.name,
                file.workgroup_size()
            );
        }
    }
}

#[test]
fn f64_modules_need_the_float64_capability_and_f32_modules_do_not() {
    // Validation without FLOAT64 is exactly what a device without
    // SHADER_F64 would do; the f32 modules must pass it.
    for (file, dim, precision) in cases() {
        let source = compose(file, dim, precision);
        let module = naga::front::wgsl::parse_str(&source).expect("parses");
        let result =
            Validator::new(ValidationFlags::all(), Capabilities::default()).validate(&module);
        match precision {
            Precision::F32 => assert!(
                result.is_ok(),
                "{}: f32 module needs more than the default capabilities: {:?}",
                label(file, dim, precision),
                result.err()
            ),
            Precision::F64 => assert_missing_float64(
                result.map(|_| ()),
                &format!("{} without FLOAT64", label(file, dim, precision)),
            ),
        }
    }
}

/// Asserts that a validation result is naga's refusal of the f64 type:
/// the first type of the module, the header's `alias real = f64`, fails with
/// `WidthError::MissingCapability { name: "f64", flag: "FLOAT64" }`.
fn assert_missing_float64(
    result: Result<(), naga::WithSpan<naga::valid::ValidationError>>,
    what: &str,
) {
    use naga::valid::{TypeError, ValidationError, WidthError};
    let err = match result {
        Ok(()) => panic!("{what}: expected the FLOAT64 refusal, but validation passed"),
        Err(e) => e.into_inner(),
    };
    match &err {
        ValidationError::Type {
            name,
            source: TypeError::WidthError(WidthError::MissingCapability { name: scalar, flag }),
            ..
        } => {
            assert_eq!(name, "real", "{what}: refused type");
            assert_eq!(*scalar, "f64", "{what}: refused scalar");
            assert_eq!(*flag, "FLOAT64", "{what}: missing capability");
        }
        other => panic!("{what}: expected MissingCapability(FLOAT64) on `real`, got {other:?}"),
    }
}

#[test]
fn every_module_translates_to_spirv() {
    let options = spv::Options {
        lang_version: (1, 3),
        ..spv::Options::default()
    };
    for (file, dim, precision) in cases() {
        let (module, info) = module_of(file, dim, precision);
        let words = spv::write_vec(&module, &info, &options, None)
            .unwrap_or_else(|e| panic!("{}: SPIR-V back end: {e}", label(file, dim, precision)));
        assert_eq!(words[0], 0x0723_0203, "SPIR-V magic number");
        // OpCapability Float64 (opcode 17, capability 10) iff f64.
        let float64 = words
            .windows(2)
            .any(|w| w[0] == (2 << 16 | 17) && w[1] == 10);
        assert_eq!(
            float64,
            precision == Precision::F64,
            "{}: OpCapability Float64 present = {float64}",
            label(file, dim, precision)
        );
    }
}

#[test]
fn every_module_translates_to_hlsl() {
    let options = hlsl::Options {
        shader_model: hlsl::ShaderModel::V6_0,
        ..hlsl::Options::default()
    };
    let pipeline = hlsl::PipelineOptions::default();
    for (file, dim, precision) in cases() {
        let (module, info) = module_of(file, dim, precision);
        let mut out = String::new();
        let mut writer = hlsl::Writer::new(&mut out, &options, &pipeline);
        let reflection = writer
            .write(&module, &info, None)
            .unwrap_or_else(|e| panic!("{}: HLSL back end: {e}", label(file, dim, precision)));
        for (ep, name) in module
            .entry_points
            .iter()
            .zip(&reflection.entry_point_names)
        {
            assert!(
                name.is_ok(),
                "{}: HLSL entry point {}: {:?}",
                label(file, dim, precision),
                ep.name,
                name
            );
        }
        assert_eq!(
            out.contains("double"),
            precision == Precision::F64,
            "{}: HLSL uses `double` exactly for f64",
            label(file, dim, precision)
        );
    }
}

fn msl_options(module: &naga::Module) -> msl::Options {
    // Runtime-sized arrays (`arrayLength`) need the buffer-sizes argument in
    // Metal; give every entry point one, as wgpu's Metal backend does.
    let mut per_entry_point_map = msl::EntryPointResourceMap::default();
    for ep in &module.entry_points {
        per_entry_point_map.insert(
            ep.name.clone(),
            msl::EntryPointResources {
                sizes_buffer: Some(30),
                ..Default::default()
            },
        );
    }
    msl::Options {
        lang_version: (2, 4),
        per_entry_point_map,
        ..msl::Options::default()
    }
}

#[test]
fn f32_modules_translate_to_msl_and_f64_modules_are_refused_for_lack_of_float64() {
    assert!(
        !msl::supported_capabilities().contains(Capabilities::FLOAT64),
        "naga's MSL back end now claims FLOAT64: translate the f64 modules too"
    );
    let pipeline = msl::PipelineOptions::default();
    for (file, dim, precision) in cases() {
        let source = compose(file, dim, precision);
        let module = naga::front::wgsl::parse_str(&source).expect("parses");
        let for_msl =
            Validator::new(ValidationFlags::all(), msl::supported_capabilities()).validate(&module);
        match precision {
            Precision::F64 => assert_missing_float64(
                for_msl.map(|_| ()),
                &format!("{} for MSL", label(file, dim, precision)),
            ),
            Precision::F32 => {
                let info = for_msl.unwrap_or_else(|e| {
                    panic!(
                        "{}: does not validate with MSL's capabilities: {}",
                        label(file, dim, precision),
                        e.emit_to_string(&source)
                    )
                });
                let (module, info) = with_default_overrides(&module, &info);
                let options = msl_options(&module);
                let (text, translation) = msl::write_string(&module, &info, &options, &pipeline)
                    .unwrap_or_else(|e| {
                        panic!("{}: MSL back end: {e}", label(file, dim, precision))
                    });
                for (ep, name) in module
                    .entry_points
                    .iter()
                    .zip(&translation.entry_point_names)
                {
                    assert!(
                        name.is_ok(),
                        "{}: MSL entry point {}: {:?}",
                        label(file, dim, precision),
                        ep.name,
                        name
                    );
                }
                assert!(text.contains("kernel void"), "MSL output has kernels");
            }
        }
    }
}
