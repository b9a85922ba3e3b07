//! The candidate layouts, their accessors and the WGSL header they share.

use super::*;
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Layout {
    Interleaved,
    Soa,
    Vec4,
    Vec4W,
    Vec4x4,
    Dense4,
}

impl Layout {
    pub(crate) fn name(self) -> &'static str {
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
    pub(crate) fn element(self) -> &'static str {
        match self {
            Layout::Interleaved | Layout::Soa => "real",
            _ => "vec4<real>",
        }
    }

    /// Particles per invocation.
    pub(crate) fn per_invocation(self) -> usize {
        match self {
            Layout::Vec4x4 | Layout::Dense4 => 4,
            _ => 1,
        }
    }

    /// Host data (3 reals per particle) into this layout; `w` goes in the
    /// fourth slot of vec4w.
    pub(crate) fn pack(self, values: &[f64], w: &[f64]) -> Vec<f64> {
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
    pub(crate) fn unpack(self, data: &[f64]) -> Vec<f64> {
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
    pub(crate) fn accessors(self) -> String {
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
pub(crate) enum Extra {
    /// Parameters in a uniform block.
    None,
    /// Parameters read from a storage buffer (as the kernels did before).
    StorageParams,
    /// One atomicLoad of a status word per invocation (as `failed_before`).
    AtomicCheck,
}

impl Extra {
    pub(crate) fn suffix(self) -> &'static str {
        match self {
            Extra::None => "",
            Extra::StorageParams => "+sparams",
            Extra::AtomicCheck => "+atomic",
        }
    }
}

/// One measured configuration.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Candidate {
    pub(crate) layout: Layout,
    pub(crate) wg: u32,
    pub(crate) extra: Extra,
}

impl Candidate {
    pub(crate) fn name(self) -> String {
        format!("{}{}", self.layout.name(), self.extra.suffix())
    }

    /// The whole WGSL module of `kernel`.
    pub(crate) fn source(self, precision: Precision, kernel: Kernel) -> String {
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
pub(crate) fn header(precision: Precision, layout: Layout, wg: u32, params: &str) -> String {
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
