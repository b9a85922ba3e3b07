//! Criterion benchmark: which memory layout, access width and workgroup size
//! the XPBD kernels should use, measured on this machine's adapter
//! (lavapipe here) next to a plain copy kernel (the bandwidth floor).
//!
//! ```text
//! layout/{f32,f64}/{kernel}/{candidate}/wg{W}
//!   kernel     copy       y[i] = x[i], one particle vector per element (floor)
//!              predict    w = 0 skips; v += h s g; p = x; x += h v; finite check
//!              velocity   w = 0 skips; v = (x − p) / h; finite check
//!              project    one colour of XPBD distance projections (32,768 edges
//!                         of a 256 × 256 grid, λ and α~ as in shaders/project.wgsl)
//!   candidate  interleaved  x[i·3 + a], one scalar access per component (before)
//!              soa          x[a·n + i], component-major structure of arrays
//!              vec4         x[i] as vec4 (w padding), one access per vector
//!              vec4w        vec4 with the inverse mass in w (project only)
//!              vec4x4       vec4, 4 particles per invocation (a loop)
//!              dense4       x[i·3 + a] read as vec4: 4 particles in 3 accesses
//!   wg         workgroup size (64, 128, 256; copy and predict also 32 and 512)
//! ```
//! 65,536 particles (a 256² cloth), R = 20 dispatches of one kernel in one
//! compute pass and one submit per iteration; criterion's elem/s is
//! particles (edges for project) × R per second, so 1e9 / (elem/s) is ns per
//! element. Every candidate's result is checked against the same arithmetic
//! on the host before it is timed (f64: bit for bit; f32: bit for bit as
//! well — the same IEEE operations in the same order).
//!
//! Run: `NODEVICE_SELECT=1 cargo bench --bench gpu_kernels` (add
//! `LP_NUM_THREADS=0` for lavapipe on one thread). The choice this bench
//! informs is recorded in docs/performance.md.

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group};
use hyperpbd::gpu::{Precision, request_adapter, request_device};

const SIDE: usize = 256;
const N: usize = SIDE * SIDE;
const EDGES: usize = SIDE * SIDE / 2;
const REPEATS: u32 = 20;
const H: f64 = 1.0 / 600.0;
const G: [f64; 3] = [0.0, -9.81, 0.0];

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Layout {
    Interleaved,
    Soa,
    Vec4,
    Vec4W,
    Vec4x4,
    Dense4,
}

impl Layout {
    fn name(self) -> &'static str {
        match self {
            Layout::Interleaved => "interleaved",
            Layout::Soa => "soa",
            Layout::Vec4 => "vec4",
            Layout::Vec4W => "vec4w",
            Layout::Vec4x4 => "vec4x4",
            Layout::Dense4 => "dense4",
        }
    }

    /// Storage element type.
    fn element(self) -> &'static str {
        match self {
            Layout::Interleaved | Layout::Soa => "real",
            _ => "vec4<real>",
        }
    }

    /// Particles per invocation.
    fn per_invocation(self) -> usize {
        match self {
            Layout::Vec4x4 | Layout::Dense4 => 4,
            _ => 1,
        }
    }

    /// Host data (3 reals per particle) into this layout; `w` goes in the
    /// fourth slot of vec4w.
    fn pack(self, values: &[f64], w: &[f64]) -> Vec<f64> {
        match self {
            Layout::Interleaved | Layout::Dense4 => values.to_vec(),
            Layout::Soa => (0..3)
                .flat_map(|a| (0..N).map(move |i| values[3 * i + a]))
                .collect(),
            Layout::Vec4 | Layout::Vec4x4 => (0..N)
                .flat_map(|i| [values[3 * i], values[3 * i + 1], values[3 * i + 2], 0.0])
                .collect(),
            Layout::Vec4W => (0..N)
                .flat_map(|i| [values[3 * i], values[3 * i + 1], values[3 * i + 2], w[i]])
                .collect(),
        }
    }

    /// Back to 3 reals per particle.
    fn unpack(self, data: &[f64]) -> Vec<f64> {
        (0..N)
            .flat_map(|i| {
                (0..3).map(move |a| match self {
                    Layout::Interleaved | Layout::Dense4 => data[3 * i + a],
                    Layout::Soa => data[a * N + i],
                    _ => data[4 * i + a],
                })
            })
            .collect()
    }

    /// WGSL accessors `load(which, i)` / `store(which, i, value)` of a
    /// particle vector (vec4, w unused) for the buffers x, v, p.
    fn accessors(self) -> String {
        let mut s = String::new();
        if self == Layout::Dense4 {
            return s; // its kernels index the vec4 words directly
        }
        for buf in ["x", "v", "p"] {
            let (load, store) = match self {
                Layout::Interleaved => (
                    format!(
                        "vec4<real>({buf}[3u * i], {buf}[3u * i + 1u], {buf}[3u * i + 2u], 0.0)"
                    ),
                    format!(
                        "{buf}[3u * i] = q.x; {buf}[3u * i + 1u] = q.y; {buf}[3u * i + 2u] = q.z;"
                    ),
                ),
                Layout::Soa => (
                    format!("vec4<real>({buf}[i], {buf}[NP + i], {buf}[2u * NP + i], 0.0)"),
                    format!("{buf}[i] = q.x; {buf}[NP + i] = q.y; {buf}[2u * NP + i] = q.z;"),
                ),
                _ => (format!("{buf}[i]"), format!("{buf}[i] = q;")),
            };
            s += &format!(
                "fn load_{buf}(i: u32) -> vec4<real> {{ return {load}; }}\n\
                 fn store_{buf}(i: u32, q: vec4<real>) {{ {store} }}\n"
            );
        }
        s
    }
}

/// What a candidate adds to its layout's kernel.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Extra {
    /// Parameters in a uniform block.
    None,
    /// Parameters read from a storage buffer (as the kernels did before).
    StorageParams,
    /// One atomicLoad of a status word per invocation (as `failed_before`).
    AtomicCheck,
}

impl Extra {
    fn suffix(self) -> &'static str {
        match self {
            Extra::None => "",
            Extra::StorageParams => "+sparams",
            Extra::AtomicCheck => "+atomic",
        }
    }
}

/// One measured configuration.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    layout: Layout,
    wg: u32,
    extra: Extra,
}

impl Candidate {
    fn name(self) -> String {
        format!("{}{}", self.layout.name(), self.extra.suffix())
    }

    /// The whole WGSL module of `kernel`.
    fn source(self, precision: Precision, kernel: Kernel) -> String {
        let mut body = body(kernel, self.layout);
        if self.extra == Extra::AtomicCheck {
            body = body.replacen(
                "gid: vec3<u32>) {\n",
                "gid: vec3<u32>) {\n  if (atomicLoad(&status[1]) < 5u) { return; }\n",
                1,
            );
        }
        let params = if self.extra == Extra::StorageParams {
            "@group(0) @binding(10) var<storage, read> params: Params;\n"
        } else {
            "@group(0) @binding(0) var<uniform> params: Params;\n"
        };
        header(precision, self.layout, self.wg, params) + &body
    }
}

/// Header: precision, sizes, bindings shared by every candidate.
fn header(precision: Precision, layout: Layout, wg: u32, params: &str) -> String {
    format!(
        "alias real = {precision};\n\
         const NP: u32 = {N}u;\n\
         const WG: u32 = {wg}u;\n\
         const REAL_MAX: real = {max};\n\
         struct Params {{ g: vec4<real>, h: real, alpha_tilde: real, count: u32, pad: u32 }}\n\
         {params}\
         @group(0) @binding(1) var<storage, read_write> x: array<{elem}>;\n\
         @group(0) @binding(2) var<storage, read_write> v: array<{elem}>;\n\
         @group(0) @binding(3) var<storage, read_write> p: array<{elem}>;\n\
         @group(0) @binding(4) var<storage, read> inv_mass: array<real>;\n\
         @group(0) @binding(5) var<storage, read> gravity_scale: array<real>;\n\
         @group(0) @binding(6) var<storage, read> edges: array<u32>;\n\
         @group(0) @binding(7) var<storage, read> rest: array<real>;\n\
         @group(0) @binding(8) var<storage, read_write> lambda: array<real>;\n\
         @group(0) @binding(9) var<storage, read_write> status: array<atomic<u32>, 4>;\n\
         fn finite(a: real) -> bool {{ return abs(a) <= REAL_MAX; }}\n\
         fn finite4(q: vec4<real>) -> bool {{ return all(abs(q) <= vec4<real>(REAL_MAX)); }}\n\
         fn fail(i: u32) {{ atomicMin(&status[0], i); }}\n",
        max = match precision {
            Precision::F32 => "3.4028234663852886e38",
            Precision::F64 => "1.7976931348623157e308",
        },
        elem = layout.element(),
    ) + &layout.accessors()
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Kernel {
    Copy,
    Predict,
    Velocity,
    Project,
}

impl Kernel {
    fn name(self) -> &'static str {
        match self {
            Kernel::Copy => "copy",
            Kernel::Predict => "predict",
            Kernel::Velocity => "velocity",
            Kernel::Project => "project",
        }
    }

    fn elements(self) -> usize {
        match self {
            Kernel::Project => EDGES,
            _ => N,
        }
    }
}

/// The WGSL body of `kernel` in `layout`.
fn body(kernel: Kernel, layout: Layout) -> String {
    let entry = "@compute @workgroup_size(WG)\n\
                 fn main(@builtin(global_invocation_id) gid: vec3<u32>) {\n";
    match (kernel, layout) {
        (Kernel::Copy, Layout::Dense4) => format!(
            "{entry}  let t = gid.x; if (t >= NP / 4u) {{ return; }}\n\
             for (var c = 0u; c < 3u; c++) {{ p[3u * t + c] = x[3u * t + c]; }}\n}}\n"
        ),
        (Kernel::Copy, _) => format!(
            "{entry}  let t = gid.x; if (t >= NP / {k}u) {{ return; }}\n\
             for (var k = 0u; k < {k}u; k++) {{ let i = {k}u * t + k; store_p(i, load_x(i)); }}\n}}\n",
            k = layout.per_invocation()
        ),
        (Kernel::Predict, Layout::Dense4) => format!(
            "{entry}  let t = gid.x; if (t >= NP / 4u) {{ return; }}\n\
             let g = params.g; let h = params.h;\n\
             let gs = array<vec4<real>, 3>(g.xyzx, g.yzxy, g.zxyz);\n\
             let w = vec4<real>(inv_mass[4u * t], inv_mass[4u * t + 1u], inv_mass[4u * t + 2u], inv_mass[4u * t + 3u]);\n\
             let s = vec4<real>(gravity_scale[4u * t], gravity_scale[4u * t + 1u], gravity_scale[4u * t + 2u], gravity_scale[4u * t + 3u]);\n\
             let ws = array<vec4<real>, 3>(w.xxxy, w.yyzz, w.zwww);\n\
             let ss = array<vec4<real>, 3>(s.xxxy, s.yyzz, s.zwww);\n\
             var ok = true;\n\
             for (var c = 0u; c < 3u; c++) {{\n\
               let k = 3u * t + c; let xo = x[k];\n\
               let dynamic = ws[c] != vec4<real>(0.0);\n\
               let vn = select(v[k], v[k] + h * (ss[c] * gs[c]), dynamic);\n\
               let xn = select(xo, xo + h * vn, dynamic);\n\
               p[k] = xo; v[k] = vn; x[k] = xn;\n\
               ok = ok && finite4(vn) && finite4(xn);\n\
             }}\n\
             if (!ok) {{ fail(t); }}\n}}\n"
        ),
        (Kernel::Predict, _) => format!(
            "{entry}  let t = gid.x; if (t >= NP / {k}u) {{ return; }}\n\
             for (var k = 0u; k < {k}u; k++) {{\n\
               let i = {k}u * t + k;\n\
               let xo = load_x(i); store_p(i, xo);\n\
               let w = {w}; if (w == 0.0) {{ continue; }}\n\
               let vn = load_v(i) + params.h * (gravity_scale[i] * params.g);\n\
               let xn = xo + params.h * vn;\n\
               store_v(i, vn); store_x(i, xn);\n\
               if (!(finite4(vn) && finite4(xn))) {{ fail(i); }}\n\
             }}\n}}\n",
            k = layout.per_invocation(),
            w = if layout == Layout::Vec4W {
                "xo.w"
            } else {
                "inv_mass[i]"
            },
        ),
        (Kernel::Velocity, Layout::Dense4) => format!(
            "{entry}  let t = gid.x; if (t >= NP / 4u) {{ return; }}\n\
             let w = vec4<real>(inv_mass[4u * t], inv_mass[4u * t + 1u], inv_mass[4u * t + 2u], inv_mass[4u * t + 3u]);\n\
             let ws = array<vec4<real>, 3>(w.xxxy, w.yyzz, w.zwww);\n\
             var ok = true;\n\
             for (var c = 0u; c < 3u; c++) {{\n\
               let k = 3u * t + c;\n\
               let vn = select(v[k], (x[k] - p[k]) / params.h, ws[c] != vec4<real>(0.0));\n\
               v[k] = vn; ok = ok && finite4(vn);\n\
             }}\n\
             if (!ok) {{ fail(t); }}\n}}\n"
        ),
        (Kernel::Velocity, _) => format!(
            "{entry}  let t = gid.x; if (t >= NP / {k}u) {{ return; }}\n\
             for (var k = 0u; k < {k}u; k++) {{\n\
               let i = {k}u * t + k;\n\
               let q = load_x(i);\n\
               if ({w} == 0.0) {{ continue; }}\n\
               let vn = (q - load_p(i)) / params.h;\n\
               store_v(i, vn);\n\
               if (!finite4(vn)) {{ fail(i); }}\n\
             }}\n}}\n",
            k = layout.per_invocation(),
            w = if layout == Layout::Vec4W {
                "q.w"
            } else {
                "inv_mass[i]"
            },
        ),
        (Kernel::Project, _) => {
            let (wi, wj) = if layout == Layout::Vec4W {
                ("qi.w", "qj.w")
            } else {
                ("inv_mass[i]", "inv_mass[j]")
            };
            let keep = if layout == Layout::Vec4W {
                "qi.w"
            } else {
                "0.0"
            };
            let keep_j = if layout == Layout::Vec4W {
                "qj.w"
            } else {
                "0.0"
            };
            format!(
                "{entry}  let e = gid.x; if (e >= params.count) {{ return; }}\n\
                 let i = edges[2u * e]; let j = edges[2u * e + 1u];\n\
                 let qi = load_x(i); let qj = load_x(j);\n\
                 let wi = {wi}; let wj = {wj};\n\
                 let d = qj.xyz - qi.xyz;\n\
                 let d2 = d.x * d.x + d.y * d.y + d.z * d.z;\n\
                 let len = sqrt(d2); let wsum = wi + wj;\n\
                 if (!(len > 0.0) || wsum == 0.0) {{ if (!finite(len)) {{ fail(e); }} return; }}\n\
                 let l = lambda[e];\n\
                 let dl = (-(len - rest[e]) - params.alpha_tilde * l) / (wsum + params.alpha_tilde);\n\
                 if (!finite(dl)) {{ fail(e); return; }}\n\
                 lambda[e] = l + dl;\n\
                 let unit = d * (1.0 / len);\n\
                 if (wi != 0.0) {{ store_x(i, vec4<real>(qi.xyz + wi * -unit * dl, {keep})); }}\n\
                 if (wj != 0.0) {{ store_x(j, vec4<real>(qj.xyz + wj * unit * dl, {keep_j})); }}\n}}\n"
            )
        }
    }
}

/// Deterministic jitter in [−0.5, 0.5).
fn jitter(k: usize) -> f64 {
    let mut s = (k as u32)
        .wrapping_mul(747_796_405)
        .wrapping_add(2_891_336_453);
    s = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277_803_737);
    s = (s >> 22) ^ s;
    f64::from(s) / f64::from(u32::MAX) - 0.5
}

/// Initial data: a jittered 256² grid, velocities, every 97th particle
/// fixed, one colour of horizontal edges.
struct Data {
    x: Vec<f64>,
    v: Vec<f64>,
    w: Vec<f64>,
    s: Vec<f64>,
    edges: Vec<u32>,
    rest: Vec<f64>,
}

fn data() -> Data {
    let spacing = 1.0 / (SIDE - 1) as f64;
    let mut x = vec![0.0; 3 * N];
    let mut v = vec![0.0; 3 * N];
    for i in 0..N {
        let (r, c) = (i / SIDE, i % SIDE);
        x[3 * i] = c as f64 * spacing + 0.1 * spacing * jitter(3 * i);
        x[3 * i + 1] = 1.0 + 0.1 * spacing * jitter(3 * i + 1);
        x[3 * i + 2] = r as f64 * spacing + 0.1 * spacing * jitter(3 * i + 2);
        for a in 0..3 {
            v[3 * i + a] = jitter(7 * i + a + 11);
        }
    }
    let w = (0..N)
        .map(|i| {
            if i % 97 == 0 {
                0.0
            } else {
                1.0 + 0.5 * jitter(5 * i)
            }
        })
        .collect();
    let s = vec![1.0; N];
    let mut edges = Vec::with_capacity(2 * EDGES);
    for r in 0..SIDE {
        for c in (0..SIDE).step_by(2) {
            edges.push((r * SIDE + c) as u32);
            edges.push((r * SIDE + c + 1) as u32);
        }
    }
    let rest = vec![spacing; EDGES];
    Data {
        x,
        v,
        w,
        s,
        edges,
        rest,
    }
}

/// Rounds through the precision (f32 data is f32 from the start).
fn round(values: &[f64], precision: Precision) -> Vec<f64> {
    match precision {
        Precision::F32 => values.iter().map(|&v| f64::from(v as f32)).collect(),
        Precision::F64 => values.to_vec(),
    }
}

/// The host reference of one call (in the precision's arithmetic).
fn reference(kernel: Kernel, precision: Precision, d: &Data) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    macro_rules! run {
        ($t:ty) => {{
            let r = |v: f64| v as $t;
            let x0: Vec<$t> = d.x.iter().map(|&v| r(v)).collect();
            let mut x = x0.clone();
            let mut v: Vec<$t> = d.v.iter().map(|&v| r(v)).collect();
            let mut p = vec![0.0 as $t; 3 * N];
            let h = r(H);
            match kernel {
                Kernel::Copy => p.copy_from_slice(&x),
                Kernel::Predict => {
                    p.copy_from_slice(&x);
                    for i in (0..N).filter(|&i| d.w[i] != 0.0) {
                        for a in 0..3 {
                            v[3 * i + a] += h * (r(d.s[i]) * r(G[a]));
                            x[3 * i + a] += h * v[3 * i + a];
                        }
                    }
                }
                Kernel::Velocity => {
                    // p = x0, x = x0 + jitter: v = (x − p) / h.
                    p.copy_from_slice(&x);
                    for k in 0..3 * N {
                        x[k] += r(1e-3 * jitter(k + 5));
                    }
                    for i in (0..N).filter(|&i| d.w[i] != 0.0) {
                        for a in 0..3 {
                            v[3 * i + a] = (x[3 * i + a] - p[3 * i + a]) / h;
                        }
                    }
                }
                Kernel::Project => {
                    let w: Vec<$t> = d.w.iter().map(|&v| r(v)).collect();
                    for e in 0..EDGES {
                        let (i, j) = (d.edges[2 * e] as usize, d.edges[2 * e + 1] as usize);
                        let mut dv = [0.0 as $t; 3];
                        for a in 0..3 {
                            dv[a] = x[3 * j + a] - x[3 * i + a];
                        }
                        let len = (dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]).sqrt();
                        let wsum = w[i] + w[j];
                        if len.is_nan() || len <= 0.0 || wsum == 0.0 {
                            continue;
                        }
                        let alpha = r(1e-7) / (h * h);
                        let dl = (-(len - r(d.rest[e])) - alpha * 0.0) / (wsum + alpha);
                        let inv = 1.0 / len;
                        for a in 0..3 {
                            let unit = dv[a] * inv;
                            if w[i] != 0.0 {
                                x[3 * i + a] += w[i] * -unit * dl;
                            }
                            if w[j] != 0.0 {
                                x[3 * j + a] += w[j] * unit * dl;
                            }
                        }
                    }
                }
            }
            let back = |v: &[$t]| v.iter().map(|&c| c as f64).collect::<Vec<f64>>();
            (back(&x), back(&v), back(&p))
        }};
    }
    match precision {
        Precision::F32 => run!(f32),
        Precision::F64 => run!(f64),
    }
}

fn reals(values: &[f64], precision: Precision) -> Vec<u8> {
    let mut out = Vec::new();
    hyperpbd::gpu::push_reals(&mut out, values, precision);
    out
}

fn from_reals(bytes: &[u8], precision: Precision) -> Vec<f64> {
    hyperpbd::gpu::read_reals(bytes, precision)
}

/// One candidate on the device: pipeline, buffers, bind group.
struct Case {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    buffers: Vec<wgpu::Buffer>,
    groups: u32,
}

struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

impl Gpu {
    fn buffer(&self, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: (bytes.len() as u64).max(16).next_multiple_of(16),
            usage: usage | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        self.queue.write_buffer(&buffer, 0, bytes);
        buffer
    }

    fn read(&self, buffer: &wgpu::Buffer) -> Vec<u8> {
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: buffer.size(),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, buffer.size());
        self.queue.submit(Some(encoder.finish()));
        staging.slice(..).map_async(wgpu::MapMode::Read, |r| {
            r.expect("map");
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("poll");
        let bytes = staging
            .slice(..)
            .get_mapped_range()
            .expect("mapped")
            .to_vec();
        staging.unmap();
        bytes
    }

    fn build(&self, precision: Precision, kernel: Kernel, candidate: Candidate, d: &Data) -> Case {
        let (layout, wg) = (candidate.layout, candidate.wg);
        let source = candidate.source(precision, kernel);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: None,
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: None,
                layout: Some(&self.pipeline_layout),
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
        let x0 = round(&d.x, precision);
        let (x_in, p_in) = match kernel {
            Kernel::Velocity => {
                let mut x = x0.clone();
                for (k, c) in x.iter_mut().enumerate() {
                    *c = round(
                        &[*c + round(&[1e-3 * jitter(k + 5)], precision)[0]],
                        precision,
                    )[0];
                }
                (x, x0.clone())
            }
            _ => (x0.clone(), vec![0.0; 3 * N]),
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let mut params = reals(&[G[0], G[1], G[2], 0.0, H, 1e-7 / (H * H)], precision);
        params.extend_from_slice(&(EDGES as u32).to_le_bytes());
        params.resize(params.len().next_multiple_of(32).max(64), 0);
        let buffers = vec![
            self.buffer(&params, wgpu::BufferUsages::UNIFORM),
            self.buffer(&reals(&layout.pack(&x_in, &d.w), precision), storage),
            self.buffer(&reals(&layout.pack(&d.v, &d.w), precision), storage),
            self.buffer(&reals(&layout.pack(&p_in, &d.w), precision), storage),
            self.buffer(&reals(&d.w, precision), storage),
            self.buffer(&reals(&d.s, precision), storage),
            self.buffer(&u32_bytes(&d.edges), storage),
            self.buffer(&reals(&d.rest, precision), storage),
            self.buffer(&reals(&vec![0.0; EDGES], precision), storage),
            self.buffer(&u32_bytes(&[u32::MAX; 4]), storage),
            self.buffer(&params, storage),
        ];
        let entries: Vec<_> = buffers
            .iter()
            .enumerate()
            .map(|(b, buffer)| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &self.layout,
            entries: &entries,
        });
        let invocations = kernel.elements()
            / if kernel == Kernel::Project {
                1
            } else {
                layout.per_invocation()
            };
        Case {
            pipeline,
            group,
            buffers,
            groups: (invocations as u32).div_ceil(wg),
        }
    }

    fn dispatch(&self, case: &Case, repeats: u32) {
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&case.pipeline);
            pass.set_bind_group(0, &case.group, &[]);
            for _ in 0..repeats {
                pass.dispatch_workgroups(case.groups, 1, 1);
            }
        }
        let index = self.queue.submit(Some(encoder.finish()));
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .expect("poll");
    }
}

fn u32_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// Checks one call of `case` against the host reference.
fn verify(gpu: &Gpu, case: &Case, kernel: Kernel, layout: Layout, precision: Precision, d: &Data) {
    gpu.dispatch(case, 1);
    let (x, v, p) = reference(kernel, precision, d);
    let got = |b: usize| layout.unpack(&from_reals(&gpu.read(&case.buffers[b]), precision));
    let label = format!("{precision} {} {}", kernel.name(), layout.name());
    let same = |name: &str, a: &[f64], b: &[f64]| {
        let bad = a
            .iter()
            .zip(b)
            .position(|(x, y)| x.to_bits() != y.to_bits());
        assert!(
            bad.is_none(),
            "{label}: {name}[{}] = {} on the device, {} on the host",
            bad.unwrap_or(0),
            a[bad.unwrap_or(0)],
            b[bad.unwrap_or(0)]
        );
    };
    match kernel {
        Kernel::Copy => same("p", &got(3)[..3 * N], &x),
        Kernel::Predict => {
            same("x", &got(1)[..3 * N], &x);
            same("v", &got(2)[..3 * N], &v);
            same("p", &got(3)[..3 * N], &p);
        }
        Kernel::Velocity => same("v", &got(2)[..3 * N], &v),
        Kernel::Project => same("x", &got(1)[..3 * N], &x),
    }
}

fn candidates(kernel: Kernel) -> Vec<Candidate> {
    let mut out = Vec::new();
    let layouts: &[Layout] = match kernel {
        Kernel::Project => &[
            Layout::Interleaved,
            Layout::Soa,
            Layout::Vec4,
            Layout::Vec4W,
        ],
        Kernel::Copy => &[
            Layout::Interleaved,
            Layout::Soa,
            Layout::Vec4,
            Layout::Vec4x4,
            Layout::Dense4,
        ],
        _ => &[
            Layout::Interleaved,
            Layout::Soa,
            Layout::Vec4,
            Layout::Vec4W,
            Layout::Vec4x4,
            Layout::Dense4,
        ],
    };
    let plain = |layout, wg| Candidate {
        layout,
        wg,
        extra: Extra::None,
    };
    for &layout in layouts {
        for wg in [64, 256] {
            out.push(plain(layout, wg));
        }
    }
    if matches!(kernel, Kernel::Copy | Kernel::Predict) {
        for wg in [32, 128, 512] {
            out.push(plain(Layout::Vec4, wg));
        }
    }
    if kernel != Kernel::Copy {
        for extra in [Extra::StorageParams, Extra::AtomicCheck] {
            out.push(Candidate {
                layout: Layout::Vec4,
                wg: 64,
                extra,
            });
        }
    }
    out
}

fn layouts(c: &mut Criterion) {
    let d = data();
    for precision in [Precision::F32, Precision::F64] {
        let Some(gpu) = setup(precision) else {
            continue;
        };
        let mut group = c.benchmark_group(format!("layout/{precision}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(200))
            .measurement_time(Duration::from_secs(2));
        for kernel in [
            Kernel::Copy,
            Kernel::Predict,
            Kernel::Velocity,
            Kernel::Project,
        ] {
            for candidate in candidates(kernel) {
                let (layout, wg) = (candidate.layout, candidate.wg);
                let case = gpu.build(precision, kernel, candidate, &d);
                verify(&gpu, &case, kernel, layout, precision, &d);
                group.throughput(Throughput::Elements(
                    kernel.elements() as u64 * u64::from(REPEATS),
                ));
                group.bench_function(
                    BenchmarkId::new(
                        format!("{}/{}", kernel.name(), candidate.name()),
                        format!("wg{wg}"),
                    ),
                    |b| b.iter(|| gpu.dispatch(&case, REPEATS)),
                );
            }
        }
        group.finish();
    }
}

/// The device, its shared layouts, and the test data of one precision.
fn setup(precision: Precision) -> Option<Gpu> {
    let (adapter, summary) = match request_adapter(precision) {
        Ok(found) => found,
        Err(e) => {
            eprintln!("SKIPPED {precision}: {e}");
            return None;
        }
    };
    eprintln!("gpu_kernels {precision} on {summary}");
    let (device, queue) = request_device(&adapter, precision).expect("device");
    let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let mut entries = vec![entry(0, wgpu::BufferBindingType::Uniform)];
    for (b, read_only) in [
        (1, false),
        (2, false),
        (3, false),
        (4, true),
        (5, true),
        (6, true),
        (7, true),
        (8, false),
        (9, false),
        (10, true),
    ] {
        entries.push(entry(b, wgpu::BufferBindingType::Storage { read_only }));
    }
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &entries,
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    Some(Gpu {
        device,
        queue,
        layout,
        pipeline_layout,
    })
}

/// Instruction-count mode (no criterion): `GPU_KERNELS_CASE=f32/predict/vec4/wg64
/// GPU_KERNELS_CALLS=K` builds and verifies one case, then submits K × 20
/// dispatches. `perf stat -e instructions` of K = 0 and K > 0 gives the
/// instructions per element, independent of the machine's load.
fn count(case: &str) {
    let parts: Vec<&str> = case.split('/').collect();
    let [precision, kernel, candidate, wg] = parts[..] else {
        panic!("GPU_KERNELS_CASE: precision/kernel/candidate/wgN, got {case}");
    };
    let precision = if precision == "f64" {
        Precision::F64
    } else {
        Precision::F32
    };
    let kernel = [
        Kernel::Copy,
        Kernel::Predict,
        Kernel::Velocity,
        Kernel::Project,
    ]
    .into_iter()
    .find(|k| k.name() == kernel)
    .expect("kernel name");
    let wg: u32 = wg.trim_start_matches("wg").parse().expect("wgN");
    let candidate = candidates(kernel)
        .into_iter()
        .find(|c| c.name() == candidate && c.wg == wg)
        .expect("a candidate of this bench");
    let calls: u32 = std::env::var("GPU_KERNELS_CALLS")
        .ok()
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let Some(gpu) = setup(precision) else {
        return;
    };
    let d = data();
    let built = gpu.build(precision, kernel, candidate, &d);
    verify(&gpu, &built, kernel, candidate.layout, precision, &d);
    for _ in 0..calls {
        gpu.dispatch(&built, REPEATS);
    }
    println!(
        "{case}: {calls} × {REPEATS} dispatches of {} elements",
        kernel.elements()
    );
}

criterion_group!(
    name = benches;
    // No plots: plotters needs system fonts, which CI images may lack.
    config = Criterion::default().without_plots();
    targets = layouts
);

fn main() {
    if let Ok(case) = std::env::var("GPU_KERNELS_CASE") {
        count(&case);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
