// Positions out to a caller's vertex buffer: world coordinates, f32, three
// per particle (gpu/src/export.rs).
//
//   out[3i + c] = f32( offset_c + Σ_a P[c][a] · x_local[i][a] )
//   x_local[i][a] = x[stride · i + a]   (records or dense: the backend's layout)
//   P (3 × DIM) the projection (the first three axes by default),
//   offset = P · origin (the f32 scene origin, host f64, rounded once)
// so out = P · (x_local + origin) = P · x_world, summed in axis order.

struct ExportParams {
    count: u32,
    stride: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
    pad3: u32,
    pad4: u32,
    pad5: u32,
    // Row c of P in rows[2c], rows[2c + 1] (DIM ≤ 8), then the offset.
    rows: array<vec4<real>, 6>,
    offset: vec4<real>,
}

@group(0) @binding(0) var<storage, read> x: array<real>;
@group(0) @binding(1) var<uniform> params: ExportParams;
@group(0) @binding(2) var<storage, read_write> out: array<f32>;

@compute @workgroup_size(WORKGROUP)
fn export_positions(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * WORKGROUP;
    if (i >= params.count) {
        return;
    }
    for (var c = 0u; c < 3u; c++) {
        var s: real = params.offset[c];
        for (var a = 0u; a < DIM; a++) {
            s += params.rows[2u * c + a / 4u][a % 4u] * x[params.stride * i + a];
        }
        out[3u * i + c] = f32(s);
    }
}
