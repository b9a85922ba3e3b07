//! The drawing half of `examples/wgpu_render`: particles drawn by a wgpu
//! render pipeline straight from a GPU backend's exported positions
//! (`PositionExport::encode_positions` into a vertex buffer), headless,
//! into an RGBA picture. Shared with `tests/gpu/example_wgpu_render.rs`.
//!
//! ```text
//! export     centres[i] = (x_i[h], x_i[v], 0) in world coordinates (f32)
//! pixels     (x0 + kx · X, y0 + ky · Y)  — the CPU renderer's orthographic
//!            map (hyperpbd_render::Renderer::pixel_map)
//! discs      one instanced quad per particle, fragments within the disc
//!            radius of the centre kept (the radius in pixels per particle)
//! ```

use hyperpbd::gpu::{EXPORT_BYTES_PER_PARTICLE, PositionExport};
use hyperpbd_render::{BACKGROUND, PixelMap};

/// An RGBA picture, row by row from the top.
pub struct Picture {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<u8>,
}

const SHADER: &str = r#"
struct Frame {
    origin: vec2<f32>,   // pixel of world (0, 0)
    scale: vec2<f32>,    // pixels per unit (kx, ky)
    size: vec2<f32>,     // picture width, height
    pad: vec2<f32>,
}
@group(0) @binding(0) var<uniform> frame: Frame;

struct Disc {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) centre: vec2<f32>,
    @location(1) @interpolate(flat) radius: f32,
}

@vertex
fn disc_vertex(@builtin(vertex_index) corner: u32, @location(0) world: vec3<f32>,
               @location(1) radius: f32) -> Disc {
    var corners = array<vec2<f32>, 6>(
        vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(1.0, 1.0),
        vec2(-1.0, -1.0), vec2(1.0, 1.0), vec2(-1.0, 1.0));
    let centre = frame.origin + frame.scale * world.xy;
    let px = centre + corners[corner] * (radius + 1.0);
    var out: Disc;
    out.clip = vec4(2.0 * px.x / frame.size.x - 1.0, 1.0 - 2.0 * px.y / frame.size.y, 0.0, 1.0);
    out.centre = centre;
    out.radius = radius;
    return out;
}

@fragment
fn disc_fragment(disc: Disc) -> @location(0) vec4<f32> {
    if (length(disc.clip.xy - disc.centre) > disc.radius) {
        discard;
    }
    return vec4(0.16, 0.35, 0.72, 1.0);
}
"#;

/// Draws the particles of `backend` (its positions exported on the
/// device) with radii `radii_px` (pixels, one per particle) through `map`
/// into a `width` × `height` picture.
pub fn draw(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    backend: &dyn PositionExport,
    radii_px: &[f32],
    map: &PixelMap,
    (width, height): (u32, u32),
) -> Result<Picture, String> {
    let layout = backend.position_layout();
    let (count, dim) = (layout.count, layout.dim);
    if radii_px.len() != count {
        return Err(format!("{} radii for {count} particles", radii_px.len()));
    }
    // The export: rows (horizontal axis, vertical axis, 0).
    let mut projection = vec![0.0; 3 * dim];
    projection[map.horizontal] = 1.0;
    projection[dim + map.vertical] = 1.0;
    let centres = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("particle centres"),
        size: (EXPORT_BYTES_PER_PARTICLE * count as u64).max(16),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX,
        mapped_at_creation: false,
    });
    let radii = buffer_of(device, queue, "radii", wgpu::BufferUsages::VERTEX, radii_px);
    let frame = [
        map.x0 as f32,
        map.y0 as f32,
        map.kx as f32,
        map.ky as f32,
        width as f32,
        height as f32,
        0.0,
        0.0,
    ];
    let frame = buffer_of(device, queue, "frame", wgpu::BufferUsages::UNIFORM, &frame);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("discs"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("frame"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("frame"),
        layout: &group_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: frame.as_entire_binding(),
        }],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("discs"),
        bind_group_layouts: &[Some(&group_layout)],
        immediate_size: 0,
    });
    let format = wgpu::TextureFormat::Rgba8Unorm;
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("discs"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("disc_vertex"),
            compilation_options: Default::default(),
            buffers: &[
                Some(wgpu::VertexBufferLayout {
                    array_stride: EXPORT_BYTES_PER_PARTICLE,
                    step_mode: wgpu::VertexStepMode::Instance,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3],
                }),
                Some(wgpu::VertexBufferLayout {
                    array_stride: 4,
                    step_mode: wgpu::VertexStepMode::Instance,
                    attributes: &wgpu::vertex_attr_array![1 => Float32],
                }),
            ],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("disc_fragment"),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        multiview_mask: None,
        cache: None,
    });
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("picture"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let row = (4 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("picture readback"),
        size: u64::from(row * height),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });

    let mut encoder = device.create_command_encoder(&Default::default());
    backend
        .encode_positions(&mut encoder, &centres, Some(&projection))
        .map_err(|e| e.to_string())?;
    {
        let view = texture.create_view(&Default::default());
        let [r, g, b] = BACKGROUND.map(|c| f64::from(c) / 255.0);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("discs"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.set_vertex_buffer(0, centres.slice(..));
        pass.set_vertex_buffer(1, radii.slice(..));
        pass.draw(0..6, 0..count as u32);
    }
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    queue.submit(Some(encoder.finish()));
    let slice = readback.slice(..);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    device
        .poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .map_err(|e| e.to_string())?;
    let mut rgba = Vec::with_capacity((4 * width * height) as usize);
    {
        let mapped = slice.get_mapped_range().map_err(|e| e.to_string())?;
        for y in 0..height as usize {
            let start = y * row as usize;
            rgba.extend_from_slice(&mapped[start..start + 4 * width as usize]);
        }
    }
    readback.unmap();
    Ok(Picture {
        width,
        height,
        rgba,
    })
}

/// A buffer of `usage` holding `values`.
fn buffer_of(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    usage: wgpu::BufferUsages,
    values: &[f32],
) -> wgpu::Buffer {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (bytes.len() as u64).max(16).next_multiple_of(4),
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    queue.write_buffer(&buffer, 0, &bytes);
    buffer
}
