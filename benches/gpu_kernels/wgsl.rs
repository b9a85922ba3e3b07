//! The measured kernels and their WGSL bodies per layout.

use super::*;

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Kernel {
    Copy,
    Predict,
    Velocity,
    Project,
}

impl Kernel {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Kernel::Copy => "copy",
            Kernel::Predict => "predict",
            Kernel::Velocity => "velocity",
            Kernel::Project => "project",
        }
    }

    pub(crate) fn elements(self) -> usize {
        match self {
            Kernel::Project => EDGES,
            _ => N,
        }
    }
}

/// The WGSL body of `kernel` in `layout`.
pub(crate) fn body(kernel: Kernel, layout: Layout) -> String {
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
