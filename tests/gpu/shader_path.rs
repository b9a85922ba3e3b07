//! The no-contraction SPIR-V shader path (gpu/src/spirv.rs,
//! gpu/src/no_contraction.rs).
//!
//! ```text
//! every ShaderFile × DIM 1..=MAX_GPU_DIM × {f32, f64} × entry point:
//!   naga's SPIR-V has float arithmetic (FAdd, FMul, …) and no NoContraction
//!   the spirv path's words carry NoContraction on every float result
//!   removing one decoration is caught (the check can fail)
//! on an adapter (lavapipe in CI): Vulkan offers PASSTHROUGH_SHADERS, the
//!   default path is spirv, HYPERPBD_SHADER_PATH=wgsl and =spirv choose
//! ```
//! `HYPERPBD_DUMP_SPIRV=DIR` writes every decorated pipeline module there
//! (`spirv-val --target-env vulkan1.1 DIR/*.spv` checks them).
//!
//! Both paths giving the same bits is shown by running the differential
//! tests under each value of `HYPERPBD_SHADER_PATH` (docs/device-check.md).

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd_gpu::no_contraction::{decorate, strip_decoration, undecorated};
use hyperpbd_gpu::shader::{MAX_GPU_DIM, ShaderFile};
use hyperpbd_gpu::spirv::entry_words;
use hyperpbd_gpu::{Precision, SHADER_PATH_VARIABLE, ShaderPath};

const PRECISIONS: [Precision; 2] = [Precision::F32, Precision::F64];

#[test]
fn every_float_result_of_every_module_carries_no_contraction() {
    let mut modules = 0;
    let mut results = 0;
    for file in ShaderFile::ALL {
        for dim in 1..=MAX_GPU_DIM {
            for precision in PRECISIONS {
                let words = entry_words(file, dim, precision)
                    .unwrap_or_else(|e| panic!("{file:?} DIM {dim} {precision}: {e}"));
                assert_eq!(words.len(), file.entry_points().len());
                for (entry, words) in words {
                    if let Some(dir) = std::env::var_os("HYPERPBD_DUMP_SPIRV") {
                        // For an external validator: spirv-val --target-env vulkan1.1 DIR/*.spv
                        let name = format!("{}-{dim}-{precision}-{entry}.spv", file.file_name());
                        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
                        std::fs::write(std::path::Path::new(&dir).join(name), bytes).unwrap();
                    }
                    let (missing, total) = undecorated(&words).unwrap();
                    assert!(
                        missing.is_empty(),
                        "{file:?} {entry} DIM {dim} {precision}: {} of {total} float results \
                         lack NoContraction: {missing:?}",
                        missing.len()
                    );
                    modules += 1;
                    results += total;
                    if let Some(&id) = find_decorated(&words) {
                        let stripped = strip_decoration(&words, id).unwrap();
                        let (missing, _) = undecorated(&stripped).unwrap();
                        assert_eq!(missing, vec![id], "{file:?} {entry}: removal not caught");
                    }
                }
            }
        }
    }
    eprintln!("{modules} pipelines, {results} float arithmetic results, all NoContraction");
    assert!(
        results > 10_000,
        "suspiciously few float results: {results}"
    );
}

/// The first float result id of `words` (the test removes its decoration).
fn find_decorated(words: &[u32]) -> Option<&u32> {
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        let opcode = words[at] & 0xffff;
        if hyperpbd_gpu::no_contraction::FLOAT_ARITHMETIC.contains(&opcode) {
            return words.get(at + 2);
        }
        at += count.max(1);
    }
    None
}

#[test]
fn nagas_own_spirv_has_no_no_contraction_so_the_pass_is_needed() {
    // The module naga writes for the WGSL path (the same options, no
    // decoration pass): float results without NoContraction.
    for precision in PRECISIONS {
        let source = hyperpbd_gpu::shader::compose(ShaderFile::Step, 3, precision);
        let (module, info) = hyperpbd_gpu::shader::validate(&source, precision).unwrap();
        let (module, info) = naga::back::pipeline_constants::process_overrides(
            &module,
            &info,
            None,
            &Default::default(),
        )
        .unwrap();
        let words =
            naga::back::spv::write_vec(&module, &info, &naga::back::spv::Options::default(), None)
                .unwrap();
        let (missing, total) = undecorated(&words).unwrap();
        assert!(total > 100, "{precision}: {total} float results");
        assert_eq!(missing.len(), total, "{precision}: naga decorated some");
        let decorated = decorate(&words).unwrap();
        assert_eq!(decorated.len(), words.len() + 3 * total);
        assert!(undecorated(&decorated).unwrap().0.is_empty());
    }
}

#[test]
fn lavapipe_offers_passthrough_and_the_variable_chooses_the_path() {
    let Some((adapter, summary)) = adapter_or_skip("shader path", Precision::F32) else {
        return;
    };
    let backend = adapter.get_info().backend;
    let features = adapter.features();
    if summary.backend == "vulkan" {
        assert!(
            summary.passthrough,
            "Vulkan without PASSTHROUGH_SHADERS: {summary}"
        );
    }
    let chosen = ShaderPath::choose(&summary.name, backend, features).unwrap();
    match std::env::var(SHADER_PATH_VARIABLE).as_deref() {
        Ok("wgsl") => assert_eq!(chosen, ShaderPath::Wgsl),
        Ok("spirv") => assert_eq!(chosen, ShaderPath::Spirv),
        _ if summary.passthrough => assert_eq!(chosen, ShaderPath::Spirv),
        _ => assert_eq!(chosen, ShaderPath::Wgsl),
    }
    // Without the feature the default is wgsl (and asking for spirv is a
    // typed error unless the variable says wgsl).
    let without = features - wgpu::Features::PASSTHROUGH_SHADERS;
    match std::env::var(SHADER_PATH_VARIABLE).as_deref() {
        Ok("spirv") => {
            let e = ShaderPath::choose(&summary.name, backend, without).unwrap_err();
            assert!(e.to_string().contains("PASSTHROUGH_SHADERS"), "{e}");
        }
        _ => assert_eq!(
            ShaderPath::choose(&summary.name, backend, without).unwrap(),
            ShaderPath::Wgsl
        ),
    }
    eprintln!("{}", chosen.describe());
}

/// `hyperpbd` with `args` and `HYPERPBD_SHADER_PATH` set to `path` (or
/// unset): exit status and stdout + stderr.
fn cli(args: &[&str], path: Option<&str>) -> (bool, String) {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_hyperpbd"));
    command.args(args).env_remove(SHADER_PATH_VARIABLE);
    if let Some(path) = path {
        command.env(SHADER_PATH_VARIABLE, path);
    }
    let out = command.output().expect("hyperpbd runs");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

#[test]
fn info_and_run_say_which_path_runs_and_a_bad_value_is_named() {
    let Some((_, summary)) = adapter_or_skip("shader path cli", Precision::F32) else {
        return;
    };
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/chain2d.json");
    let default = if summary.passthrough { "spirv" } else { "wgsl" };
    for (path, expected) in [(None, default), (Some("wgsl"), "wgsl")] {
        let (ok, text) = cli(&["info"], path);
        assert!(ok, "{text}");
        assert!(
            text.contains(&format!("shader path: {expected} ")),
            "{path:?}: {text}"
        );
        let (ok, text) = cli(&["run", scene, "--backend", "gpu", "--frames", "1"], path);
        assert!(ok, "{text}");
        assert!(
            text.contains(&format!("shader path: {expected} ")),
            "{path:?}: {text}"
        );
    }
    let (ok, text) = cli(
        &["run", scene, "--backend", "gpu", "--frames", "1"],
        Some("fast"),
    );
    assert!(!ok, "{text}");
    assert!(
        text.contains(SHADER_PATH_VARIABLE) && text.contains("\"fast\""),
        "{text}"
    );
}

/// The wgsl path keeps the generated expression code's opaque selects
/// (OPAQUE_ARITHMETIC true; the spirv path drops them, NoContraction doing
/// their work): there too gpu-f32 is the f32 reference bit for bit on an
/// adapter that neither contracts nor regroups, the expression scene's
/// three relations and a 2D chain on a plane.
#[test]
fn the_wgsl_path_is_the_f32_reference_bit_for_bit() {
    let Some(_) = adapter_or_skip("wgsl path exact", Precision::F32) else {
        return;
    };
    for scene in ["expression.json", "chain2d.json"] {
        let path = format!("{}/scenes/{scene}", env!("CARGO_MANIFEST_DIR"));
        let args = [
            "compare",
            &path,
            "--precision",
            "f32",
            "--exact",
            "--frames",
            "20",
            "--every",
            "20",
        ];
        let (ok, text) = cli(&args, Some("wgsl"));
        assert!(ok, "{scene}: {text}");
        assert!(
            text.contains("bit for bit in 20 of 20 frames"),
            "{scene}: {text}"
        );
    }
}
