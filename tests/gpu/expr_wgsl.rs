//! Expressions emitted as WGSL (`expr::emit_wgsl`) and run on the GPU give
//! the CPU evaluators' results bit for bit: gpu-f64 = `Tape::eval_f64`,
//! gpu-f32 = `Tape::eval_f32`, for value, gradient and Hessian, on every
//! built-in written as an expression, on expressions using every function
//! (ln, exp, sqrt, min, max, abs, det) and on random ones — on adapters
//! that neither contract nor regroup (llvmpipe). And every emitted module
//! validates with naga for dims 1..=8, both precisions (no GPU needed).
//!
//! Printed as `BOUND | name | measured | bound | rationale`.

use crate::common;

#[allow(dead_code)]
#[path = "../../core/src/expr/tests/random.rs"]
mod random;

use common::exact::f64_identical;
use common::gpu::adapter_or_skip;
use hyperpbd::core::expr::{
    Outputs, ParamValue, Tape, compile, emit_wgsl, exp_f32, exp_f64, wgsl_support,
};
use hyperpbd::gpu::Precision;
use random::{Rng, param_c, program};

const WORKGROUP: u32 = 64;

/// A compute module around the tape's function: lane i reads its K inputs
/// from `xin[i·K…]` and writes its M outputs to `yout[i·M…]`.
fn module(tape: &Tape, precision: Precision, lanes: usize) -> String {
    let t = precision.as_str();
    let (k, m) = (tape.inputs.max(1), tape.outputs().count());
    format!(
        "{support}\n{function}\n\
         @group(0) @binding(0) var<storage, read> xin: array<{t}>;\n\
         @group(0) @binding(1) var<storage, read_write> yout: array<{t}>;\n\
         @compute @workgroup_size({WORKGROUP})\n\
         fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
             let lane = id.x;\n\
             if (lane >= {lanes}u) {{ return; }}\n\
             var x: array<{t}, {k}>;\n\
             for (var j = 0u; j < {k}u; j++) {{ x[j] = xin[lane * {k}u + j]; }}\n\
             var y = expr_value(x, arrayLength(&xin) == 0u);\n\
             for (var o = 0u; o < {m}u; o++) {{ yout[lane * {m}u + o] = y[o]; }}\n\
         }}\n",
        support = wgsl_support(precision),
        function = emit_wgsl(tape, "expr_value", precision),
    )
}

fn validate(source: &str, precision: Precision) -> Result<(), String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    let mut caps = naga::valid::Capabilities::default();
    if precision == Precision::F64 {
        caps |= naga::valid::Capabilities::FLOAT64;
    }
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
        .validate(&module)
        .map_err(|e| e.emit_to_string(source))?;
    Ok(())
}

/// The expressions under test for (arity, source) in R^dim; `c` is a
/// vector param and `r` a scalar one.
fn expressions(dim: usize, rng: &mut Rng, randoms: usize) -> Vec<(usize, String)> {
    let fact = |k: usize| (1..=k).product::<usize>();
    let mut out = vec![
        (2, "norm(x1 - x0)".to_string()),
        (1, "dot(c, x0) - r".to_string()),
        (2, "let e = x1 - x0; dot(e, e)".to_string()),
        (
            3,
            "let a = x1 - x0; let b = x2 - x0; \
             det(dot(a, a), dot(a, b), dot(b, a), dot(b, b)) / 4"
                .to_string(),
        ),
        (
            2,
            "let d = norm(x1 - x0); -r * (d - 2) * (d - 2) * ln(d / 2) + exp(-d) \
             + min(x0[0], x1[0]) * max(x0[0], abs(x1[0])) + sqrt(1 + dot(x0, x0))"
                .to_string(),
        ),
    ];
    let cols: Vec<String> = (1..=dim).map(|j| format!("x{j} - x0")).collect();
    out.push((dim + 1, format!("det({}) / {}", cols.join(", "), fact(dim))));
    for _ in 0..randoms {
        let arity = 1 + rng.below(3);
        out.push((arity, program(rng, 3, arity, dim)));
    }
    out
}

fn params(dim: usize) -> Vec<(String, ParamValue)> {
    vec![
        ("c".into(), ParamValue::Vector(param_c(dim))),
        ("r".into(), ParamValue::Scalar(0.75)),
    ]
}

#[test]
fn every_emitted_module_validates_for_dims_1_to_8() {
    let mut rng = Rng(5);
    let mut validated = 0;
    for dim in 1..=8 {
        for (arity, src) in expressions(dim, &mut rng, 2) {
            let c =
                compile(&src, &params(dim), arity, dim).unwrap_or_else(|e| panic!("{src}: {e}"));
            for outputs in [
                Outputs::Value,
                Outputs::ValueGradient,
                Outputs::ValueGradientHessian,
            ] {
                let tape = c.tape(outputs).expect("tape");
                for precision in [Precision::F32, Precision::F64] {
                    let m = module(&tape, precision, 1);
                    validate(&m, precision).unwrap_or_else(|e| panic!("{src} dim {dim}: {e}"));
                    validated += 1;
                }
            }
        }
    }
    assert_eq!(validated, 8 * 8 * 3 * 2);
}

/// Runs `source` over `lanes` lanes: inputs `xin` (K per lane), `m` outputs
/// per lane, as raw little-endian words of `bytes` bytes each.
fn run(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    source: &str,
    xin: &[u8],
    out_len: usize,
    lanes: usize,
) -> Vec<u8> {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("expr"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("expr"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let usage =
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    let input = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("xin"),
        size: xin.len() as u64,
        usage,
        mapped_at_creation: false,
    });
    queue.write_buffer(&input, 0, xin);
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("yout"),
        size: out_len as u64,
        usage,
        mapped_at_creation: false,
    });
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("staging"),
        size: out_len as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("expr"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((lanes as u32).div_ceil(WORKGROUP), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &staging, 0, out_len as u64);
    queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("poll");
    rx.recv().expect("answer").expect("mapped");
    let bytes = slice.get_mapped_range().expect("mapped range").to_vec();
    staging.unmap();
    bytes
}

fn gpu_equals_cpu(precision: Precision) {
    let test = format!("expr_gpu_{precision}");
    let Some((adapter, summary)) = adapter_or_skip(&test, precision) else {
        return;
    };
    if !f64_identical(&summary) {
        println!("{test}: adapter may contract or regroup; bit identity is not asserted here");
        return;
    }
    let (device, queue) = hyperpbd::gpu::request_device(&adapter, precision).expect("device");
    let mut rng = Rng(99);
    let (mut compared, mut differing, mut nans) = (0usize, 0usize, 0usize);
    let lanes = 193; // not a multiple of the workgroup size
    for dim in [1, 2, 3, 4] {
        for (arity, src) in expressions(dim, &mut rng, 6) {
            let c =
                compile(&src, &params(dim), arity, dim).unwrap_or_else(|e| panic!("{src}: {e}"));
            let tape = c.tape(Outputs::ValueGradientHessian).expect("tape");
            let (k, m) = (tape.inputs, tape.outputs().count());
            // Inputs exactly representable in f32, away from ln's pole.
            let x: Vec<f32> = (0..k * lanes)
                .map(|_| rng.uniform(-1.5, 1.5) as f32)
                .collect();
            let source = module(&tape, precision, lanes);
            let outputs: Vec<usize> = tape.outputs().collect();
            let mut check = |cpu: u64, gpu: u64, is_nan: bool, lane: usize, output: usize| {
                compared += 1;
                if is_nan {
                    nans += 1;
                } else if cpu != gpu {
                    if differing < 5 {
                        eprintln!(
                            "{src} dim {dim} lane {lane} output {output}: CPU bits {cpu:#x}, GPU bits {gpu:#x}"
                        );
                    }
                    differing += 1;
                }
            };
            match precision {
                Precision::F64 => {
                    let bytes: Vec<u8> =
                        x.iter().flat_map(|&v| f64::from(v).to_le_bytes()).collect();
                    let got = run(&device, &queue, &source, &bytes, 8 * m * lanes, lanes);
                    let mut cols = hyperpbd::core::expr::Columns::new();
                    tape.eval_f64(lanes, |j, l| f64::from(x[l * k + j]), &mut cols);
                    for l in 0..lanes {
                        for (o, &s) in outputs.iter().enumerate() {
                            let at = 8 * (l * m + o);
                            let g =
                                f64::from_le_bytes(got[at..at + 8].try_into().expect("8 bytes"));
                            let e = cols.get(s, l);
                            check(e.to_bits(), g.to_bits(), e.is_nan() && g.is_nan(), l, o);
                        }
                    }
                }
                Precision::F32 => {
                    let bytes: Vec<u8> = x.iter().flat_map(|&v| v.to_le_bytes()).collect();
                    let got = run(&device, &queue, &source, &bytes, 4 * m * lanes, lanes);
                    let mut cols = hyperpbd::core::expr::Columns::<f32>::new();
                    tape.eval_f32(lanes, |j, l| x[l * k + j], &mut cols);
                    for l in 0..lanes {
                        for (o, &s) in outputs.iter().enumerate() {
                            let at = 4 * (l * m + o);
                            let g =
                                f32::from_le_bytes(got[at..at + 4].try_into().expect("4 bytes"));
                            let e = cols.get(s, l);
                            check(
                                u64::from(e.to_bits()),
                                u64::from(g.to_bits()),
                                e.is_nan() && g.is_nan(),
                                l,
                                o,
                            );
                        }
                    }
                }
            }
        }
    }
    common::bound::print_bound(
        format_args!(
            "expressions: CPU eval_{precision} vs {precision} WGSL, {compared} outputs ({nans} NaN on both)"
        ),
        format_args!("{differing} differing"),
        0,
        "same operations in the same order, correctly rounded on both sides",
    );
    assert!(compared > 100_000, "{compared}");
    assert!(nans * 100 <= compared, "{nans} NaN of {compared}");
    assert_eq!(differing, 0);
}

#[test]
fn gpu_f64_is_eval_f64_bit_for_bit() {
    gpu_equals_cpu(Precision::F64);
}

#[test]
fn gpu_f32_is_eval_f32_bit_for_bit() {
    gpu_equals_cpu(Precision::F32);
}

/// `exp_real` of `wgsl_support` against `exp_f64` / `exp_f32` over the
/// whole range, bit for bit.
fn exp_equals_cpu(precision: Precision) {
    let test = format!("exp_{precision}");
    let Some((adapter, summary)) = adapter_or_skip(&test, precision) else {
        return;
    };
    if !f64_identical(&summary) {
        println!("{test}: adapter may contract or regroup; bit identity is not asserted here");
        return;
    }
    let (device, queue) = hyperpbd::gpu::request_device(&adapter, precision).expect("device");
    let t = precision.as_str();
    let (lo, hi) = match precision {
        Precision::F64 => (-720.0, 712.0),
        Precision::F32 => (-90.0, 90.0),
    };
    let mut xs: Vec<f64> = (0..=100_000)
        .map(|i| lo + (hi - lo) * f64::from(i) / 100_000.0)
        .collect();
    xs.extend((-2000..=2000).map(|i| f64::from(i) * 1e-4));
    xs.extend([0.0, -0.0, 1.0, -1.0, 1e-300, -1e-300]);
    let xs: Vec<f64> = match precision {
        Precision::F64 => xs,
        Precision::F32 => xs.iter().map(|&v| f64::from(v as f32)).collect(),
    };
    let lanes = xs.len();
    let source = format!(
        "{support}\n\
         @group(0) @binding(0) var<storage, read> xin: array<{t}>;\n\
         @group(0) @binding(1) var<storage, read_write> yout: array<{t}>;\n\
         @compute @workgroup_size({WORKGROUP})\n\
         fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
             if (id.x >= {lanes}u) {{ return; }}\n\
             yout[id.x] = exp_real(xin[id.x]);\n\
         }}\n",
        support = wgsl_support(precision)
    );
    let mut differing = 0;
    match precision {
        Precision::F64 => {
            let bytes: Vec<u8> = xs.iter().flat_map(|v| v.to_le_bytes()).collect();
            let got = run(&device, &queue, &source, &bytes, 8 * lanes, lanes);
            for (i, &x) in xs.iter().enumerate() {
                let g = f64::from_le_bytes(got[8 * i..8 * i + 8].try_into().expect("8 bytes"));
                if g.to_bits() != exp_f64(x).to_bits() {
                    if differing < 5 {
                        eprintln!("exp({x:e}): GPU {g:e}, CPU {:e}", exp_f64(x));
                    }
                    differing += 1;
                }
            }
        }
        Precision::F32 => {
            let bytes: Vec<u8> = xs.iter().flat_map(|&v| (v as f32).to_le_bytes()).collect();
            let got = run(&device, &queue, &source, &bytes, 4 * lanes, lanes);
            for (i, &x) in xs.iter().enumerate() {
                let g = f32::from_le_bytes(got[4 * i..4 * i + 4].try_into().expect("4 bytes"));
                let e = exp_f32(x as f32);
                if g.to_bits() != e.to_bits() {
                    if differing < 5 {
                        eprintln!("exp({x:e}): GPU {g:e}, CPU {e:e}");
                    }
                    differing += 1;
                }
            }
        }
    }
    common::bound::print_bound(
        format_args!("exp: CPU exp_{precision} vs WGSL exp_real, {lanes} values over [{lo}, {hi}]"),
        format_args!("{differing} differing"),
        0,
        "same operations in the same order, correctly rounded on both sides",
    );
    assert!(lanes > 100_000);
    assert_eq!(differing, 0);
}

#[test]
fn exp_f64_shader_is_exp_f64_bit_for_bit() {
    exp_equals_cpu(Precision::F64);
}

#[test]
fn exp_f32_shader_is_exp_f32_bit_for_bit() {
    exp_equals_cpu(Precision::F32);
}
