//! The kernel-set builder: the one piece of code that turns a kernel
//! family's WGSL into wgpu objects — bind-group layouts, the shader modules,
//! one compute pipeline per entry point, bind groups, parameter blocks — and
//! that knows each entry point's workgroup size. Every kernel set of this
//! crate is built with it.
//!
//! ```text
//! KernelSet::new(device, &KernelSetSpec {
//!     label, dim, precision,
//!     modules: [ShaderFile; …]         whose @group/@binding globals are the layouts
//!     entries: [E; …]                  E: EntryPoint → (ShaderFile, "name")
//!     constants: [(name, value); …]    overrides every pipeline of the set shares
//! })
//!   reads the bind groups from the WGSL itself (naga): binding k of group g
//!   is the module's `@group(g) @binding(k)` global — `var<storage, read>`
//!   READ, `read_write` WRITE, `var<uniform>` a uniform; group 0 holds the
//!   buffers, a group ≥ 1 the parameter blocks, bound with dynamic offsets
//!   (so no hand-written table can disagree with the shader);
//!   checks the storage bindings per stage against the device limit;
//!   composes each ShaderFile once: shader::compose(file, dim, precision),
//!   whose header carries `const WORKGROUP: u32 = file.workgroup_size()`
//!   (every entry point is `@workgroup_size(WORKGROUP)`, so the host's
//!   dispatch size and the shader's come from the same number);
//!   creates one pipeline per entry on one pipeline layout; on the spirv
//!   shader path (spirv.rs) each pipeline gets its own passthrough module,
//!   its override constants applied and every float result NoContraction.
//! set.bind(device, g, &[buffers])     the bind group g (whole buffers; a
//!                                     dynamic binding sees one block)
//! ParamBlocks::new(device)            parameter blocks at the device's
//! blocks.push(&block) -> offset       dynamic-offset alignment, one buffer,
//! blocks.finish(ctx, label)           selected per dispatch by the offset
//! set.dispatch(pass, entry, n)        set_pipeline + workgroups for n
//!                                     invocations (grid split over y)
//! ```
//! Parameter blocks are encoded with [`BlockWriter`] (u32 words and reals of
//! the set's precision in WGSL struct order), so every kernel set lays its
//! blocks out the same way.
//!
//! A new kernel set (say, a contact solver) writes its WGSL file with
//! `@workgroup_size(WORKGROUP)` and [`linear_index`-style] indexing, adds its
//! [`ShaderFile`], lists its entry points, and gets everything else (its
//! bind-group layouts included) from here.
//!
//! [`linear_index`-style]: crate::shader

use std::any::TypeId;

use hyperpbd_core::GpuError;

use crate::Precision;
use crate::context::GpuContext;
use crate::params::push_reals;
use crate::shader::{ShaderFile, compose_with};
use crate::spirv::{self, ShaderPath};

/// Workgroups along x before the grid spills over to y (the WebGPU limit).
pub(crate) const MAX_GROUPS_X: u32 = 65_535;

/// One binding of a kernel set, as the WGSL declares it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Binding {
    /// `var<storage, read>` rather than `read_write`.
    pub read_only: bool,
    /// Bound with a dynamic offset (one parameter block per dispatch).
    pub dynamic: bool,
    /// A uniform buffer rather than a storage buffer.
    pub uniform: bool,
}

/// The bind groups of `spec`'s modules, read from their composed WGSL:
/// every `@group(g) @binding(k)` global of `spec.modules` and of every
/// file an entry comes from
/// (a binding some file writes is WRITE), dense in k; groups ≥ 1 are
/// parameter blocks, bound with dynamic offsets.
fn reflect_groups<E: EntryPoint>(
    spec: &KernelSetSpec<'_, E>,
) -> Result<Vec<Vec<Binding>>, GpuError> {
    let mut files: Vec<ShaderFile> = spec.modules.to_vec();
    for &entry in spec.entries {
        let (file, _) = entry.source();
        if !files.contains(&file) {
            files.push(file);
        }
    }
    let mut found: std::collections::BTreeMap<(u32, u32), Binding> = Default::default();
    for file in files {
        let source = compose_with(file, spec.dim, spec.precision, spec.generated);
        let module = naga::front::wgsl::parse_str(&source).map_err(|e| GpuError::Other {
            message: format!("{}: {}", file.file_name(), e.emit_to_string(&source)),
        })?;
        for (_, var) in module.global_variables.iter() {
            let Some(at) = &var.binding else { continue };
            let (read_only, uniform) = match var.space {
                naga::AddressSpace::Storage { access } => {
                    (!access.contains(naga::StorageAccess::STORE), false)
                }
                naga::AddressSpace::Uniform => (true, true),
                _ => continue,
            };
            let binding = found.entry((at.group, at.binding)).or_insert(Binding {
                read_only,
                dynamic: at.group > 0,
                uniform,
            });
            binding.read_only &= read_only;
        }
    }
    let mut groups: Vec<Vec<Binding>> = Vec::new();
    for ((group, binding), b) in found {
        let group = group as usize;
        groups.resize(groups.len().max(group + 1), Vec::new());
        if binding as usize != groups[group].len() {
            return Err(GpuError::Other {
                message: format!(
                    "{}: @group({group}) skips binding {} (bindings must be dense)",
                    spec.label,
                    groups[group].len()
                ),
            });
        }
        groups[group].push(b);
    }
    Ok(groups)
}

/// A storage-buffer layout entry visible to compute shaders.
pub(crate) fn storage(binding: u32, read_only: bool, dynamic: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: dynamic,
            min_binding_size: None,
        },
        count: None,
    }
}

/// An entry point of a kernel set: its WGSL file and function name, and
/// the values of the module's pipeline-overridable constants it is
/// specialised with (one pipeline per distinct entry).
pub(crate) trait EntryPoint: Copy + Eq + std::fmt::Debug + Send + Sync + 'static {
    /// The file that defines it and its name there.
    fn source(self) -> (ShaderFile, &'static str);

    /// `override` constants of the pipeline (none by default).
    fn constants(self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
}

/// What a kernel set is made of.
pub(crate) struct KernelSetSpec<'a, E> {
    /// Label of the layouts and pipelines (wgpu debugging).
    pub label: &'static str,
    /// Spatial dimension the modules are composed for.
    pub dim: usize,
    /// Precision the modules are composed for.
    pub precision: Precision,
    /// The modules whose `@group/@binding` globals are the set's bind
    /// groups (read even when `entries` is empty: an empty scene still
    /// binds its buffers).
    pub modules: &'a [ShaderFile],
    /// Every entry point the set dispatches.
    pub entries: &'a [E],
    /// `override` constants every pipeline of the set is specialised with,
    /// besides its entry's own (a batch's world strides).
    pub constants: &'a [(&'static str, f64)],
    /// WGSL the step module is composed with (a plan's expression
    /// families); `None` for the other sets.
    pub generated: Option<&'a str>,
}

/// Layouts and pipelines of one kernel family (clones share the wgpu
/// objects).
#[derive(Clone)]
pub(crate) struct KernelSet<E> {
    label: &'static str,
    layouts: Vec<wgpu::BindGroupLayout>,
    groups: Vec<Vec<Binding>>,
    pipelines: Vec<(E, wgpu::ComputePipeline, u32)>,
}

impl<E: EntryPoint> KernelSet<E> {
    /// The layouts and pipelines of `spec` on `ctx`'s device: the ones
    /// the device already built for the same spec ([`KernelCache`]), else
    /// built now.
    ///
    /// [`KernelCache`]: crate::kernel_cache::KernelCache
    pub fn new(ctx: &GpuContext, spec: &KernelSetSpec<'_, E>) -> Result<Self, GpuError> {
        ctx.kernels
            .get_or_build(spec_key(spec), || Self::compile(&ctx.device, spec))
    }

    /// Builds the layouts, modules and pipelines of `spec` on `device`.
    fn compile(device: &wgpu::Device, spec: &KernelSetSpec<'_, E>) -> Result<Self, GpuError> {
        let limits = device.limits();
        let groups = reflect_groups(spec)?;
        let needed: usize = groups
            .iter()
            .map(|g| g.iter().filter(|b| !b.uniform).count())
            .sum();
        if (limits.max_storage_buffers_per_shader_stage as usize) < needed {
            return Err(GpuError::Unsupported {
                what: format!(
                    "the adapter allows {} storage buffers per shader stage; the {} kernels need {needed}",
                    limits.max_storage_buffers_per_shader_stage, spec.label
                ),
            });
        }
        let layouts: Vec<wgpu::BindGroupLayout> = groups
            .iter()
            .map(|bindings| {
                let entries: Vec<_> = bindings
                    .iter()
                    .enumerate()
                    .map(|(k, b)| {
                        let mut entry = storage(k as u32, b.read_only, b.dynamic);
                        if b.uniform {
                            entry.ty = wgpu::BindingType::Buffer {
                                ty: wgpu::BufferBindingType::Uniform,
                                has_dynamic_offset: b.dynamic,
                                min_binding_size: None,
                            };
                        }
                        entry
                    })
                    .collect();
                device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(spec.label),
                    entries: &entries,
                })
            })
            .collect();
        let layout_refs: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(Some).collect();
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(spec.label),
            bind_group_layouts: &layout_refs,
            immediate_size: 0,
        });
        let path = ShaderPath::of_device(device)?;
        let mut modules: Vec<(ShaderFile, wgpu::ShaderModule)> = Vec::new();
        let mut parsed: Vec<(ShaderFile, (naga::Module, naga::valid::ModuleInfo))> = Vec::new();
        let mut pipelines = Vec::with_capacity(spec.entries.len());
        for &entry in spec.entries {
            let (file, name) = entry.source();
            let mut constants = entry.constants();
            constants.extend_from_slice(spec.constants);
            // The spirv path applies the constants itself (one module per
            // pipeline); the wgsl path shares one module per file.
            let passthrough;
            let (module, constants): (&wgpu::ShaderModule, &[(&str, f64)]) = match path {
                ShaderPath::Spirv => {
                    if !parsed.iter().any(|(f, _)| *f == file) {
                        let parsed_module =
                            spirv::parse(file, spec.dim, spec.precision, spec.generated)?;
                        parsed.push((file, parsed_module));
                    }
                    let Some((_, module)) = parsed.iter().find(|(f, _)| *f == file) else {
                        return Err(GpuError::Other {
                            message: format!("{}: no module for {file:?}", spec.label),
                        });
                    };
                    passthrough =
                        spirv::passthrough_module(device, file, module, name, &constants)?;
                    (&passthrough, &[])
                }
                ShaderPath::Wgsl => {
                    if !modules.iter().any(|(f, _)| *f == file) {
                        let source = compose_with(file, spec.dim, spec.precision, spec.generated);
                        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                            label: Some(file.file_name()),
                            source: wgpu::ShaderSource::Wgsl(source.into()),
                        });
                        modules.push((file, module));
                    }
                    let Some((_, module)) = modules.iter().find(|(f, _)| *f == file) else {
                        return Err(GpuError::Other {
                            message: format!("{}: no module for {file:?}", spec.label),
                        });
                    };
                    (module, &constants)
                }
            };
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(&pipeline_layout),
                module,
                entry_point: Some(name),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                cache: None,
            });
            pipelines.push((entry, pipeline, file.workgroup_size()));
        }
        Ok(KernelSet {
            label: spec.label,
            layouts,
            groups,
            pipelines,
        })
    }

    /// Bind group `group` over `buffers` in binding order. A dynamic
    /// binding sees `block` bytes at the offset given per dispatch; the
    /// others see their whole buffer.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        group: usize,
        buffers: &[&wgpu::Buffer],
        block: u64,
    ) -> Result<wgpu::BindGroup, GpuError> {
        let (Some(layout), Some(bindings)) = (self.layouts.get(group), self.groups.get(group))
        else {
            return Err(GpuError::Other {
                message: format!("{}: no bind group {group}", self.label),
            });
        };
        if bindings.len() != buffers.len() {
            return Err(GpuError::Other {
                message: format!(
                    "{}: bind group {group} has {} bindings, {} buffers given",
                    self.label,
                    bindings.len(),
                    buffers.len()
                ),
            });
        }
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .zip(bindings)
            .enumerate()
            .map(|(k, (buffer, binding))| wgpu::BindGroupEntry {
                binding: k as u32,
                resource: if binding.dynamic {
                    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer,
                        offset: 0,
                        size: wgpu::BufferSize::new(block.max(4)),
                    })
                } else {
                    buffer.as_entire_binding()
                },
            })
            .collect();
        Ok(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(self.label),
            layout,
            entries: &entries,
        }))
    }

    /// Pipelines built (one per entry and constants).
    pub fn pipeline_count(&self) -> usize {
        self.pipelines.len()
    }

    fn find(&self, entry: E) -> Option<&(E, wgpu::ComputePipeline, u32)> {
        self.pipelines.iter().find(|(e, _, _)| *e == entry)
    }

    /// Sets `entry`'s pipeline and dispatches `invocations` invocations.
    /// The caller has set the bind groups.
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, entry: E, invocations: u32) {
        if let Some((_, pipeline, workgroup)) = self.find(entry) {
            let (x, y) = grid(invocations, *workgroup);
            pass.set_pipeline(pipeline);
            pass.dispatch_workgroups(x, y, 1);
        }
    }

    /// Sets `entry`'s pipeline and dispatches `workgroups` workgroups
    /// (kernels that index by workgroup: more than 65,535 spread over y,
    /// the kernel rebuilds x + y · groups_x).
    pub fn dispatch_workgroups(&self, pass: &mut wgpu::ComputePass<'_>, entry: E, workgroups: u32) {
        if let Some((_, pipeline, _)) = self.find(entry) {
            let (x, y) = grid(workgroups, 1);
            pass.set_pipeline(pipeline);
            pass.dispatch_workgroups(x, y, 1);
        }
    }
}

/// Everything a kernel set is made of, as one string.
fn spec_key<E: EntryPoint>(spec: &KernelSetSpec<'_, E>) -> String {
    let entries: Vec<_> = spec
        .entries
        .iter()
        .map(|&e| (e, e.source(), e.constants()))
        .collect();
    format!(
        "{:?}|{}|{}|{:?}|{:?}|{:?}|{:?}|{:?}",
        TypeId::of::<E>(),
        spec.label,
        spec.dim,
        spec.precision,
        spec.modules,
        entries,
        spec.constants,
        spec.generated,
    )
}

/// Workgroups (x, y) covering `invocations` at `workgroup` per group.
pub(crate) fn grid(invocations: u32, workgroup: u32) -> (u32, u32) {
    let groups = invocations.div_ceil(workgroup.max(1)).max(1);
    if groups <= MAX_GROUPS_X {
        (groups, 1)
    } else {
        (MAX_GROUPS_X, groups.div_ceil(MAX_GROUPS_X))
    }
}

/// Encodes one parameter block: u32 words and reals of one precision, in
/// the order of the WGSL struct's members. Reals are aligned to their own
/// size (WGSL's rule for f32/f64 members and arrays of them).
pub(crate) struct BlockWriter {
    bytes: Vec<u8>,
    precision: Precision,
}

impl BlockWriter {
    /// An empty block of reals in `precision`.
    pub fn new(precision: Precision) -> Self {
        BlockWriter {
            bytes: Vec::new(),
            precision,
        }
    }

    /// Appends u32 words.
    pub fn words(mut self, words: &[u32]) -> Self {
        for w in words {
            self.bytes.extend_from_slice(&w.to_le_bytes());
        }
        self
    }

    /// Appends reals, first aligning to one real.
    pub fn reals(mut self, values: &[f64]) -> Self {
        let size = crate::params::real_size(self.precision);
        self.bytes
            .resize(self.bytes.len().next_multiple_of(size), 0);
        push_reals(&mut self.bytes, values, self.precision);
        self
    }

    /// The encoded bytes.
    pub fn finish(self) -> Vec<u8> {
        self.bytes
    }
}

/// Parameter blocks of one kernel set in one buffer, each at a multiple of
/// the device's dynamic-offset alignment.
pub(crate) struct ParamBlocks {
    uniform: bool,
    stride_alignment: usize,
    bytes: Vec<u8>,
    largest: usize,
    last: usize,
}

impl ParamBlocks {
    /// No blocks yet, for a storage dynamic binding ([`Binding::BLOCK`]);
    /// offsets will be multiples of `device`'s
    /// `min_storage_buffer_offset_alignment`.
    pub fn new(device: &wgpu::Device) -> Self {
        Self::with_kind(device, false)
    }

    /// No blocks yet, for a uniform dynamic binding
    /// ([`Binding::UNIFORM_BLOCK`]); offsets will be multiples of `device`'s
    /// `min_uniform_buffer_offset_alignment`.
    pub fn uniform(device: &wgpu::Device) -> Self {
        Self::with_kind(device, true)
    }

    fn with_kind(device: &wgpu::Device, uniform: bool) -> Self {
        let limits = device.limits();
        ParamBlocks {
            uniform,
            stride_alignment: if uniform {
                limits.min_uniform_buffer_offset_alignment
            } else {
                limits.min_storage_buffer_offset_alignment
            } as usize,
            bytes: Vec::new(),
            largest: 0,
            last: 0,
        }
    }

    /// Appends `block`; returns its dynamic offset.
    pub fn push(&mut self, block: &[u8]) -> u32 {
        let offset = self.bytes.len().next_multiple_of(self.stride_alignment);
        self.bytes.resize(offset, 0);
        self.bytes.extend_from_slice(block);
        self.largest = self.largest.max(block.len());
        self.last = offset;
        offset as u32
    }

    /// Bytes one dispatch sees (the largest block, at least 16).
    pub fn block_size(&self) -> u64 {
        (self.largest.max(16).next_multiple_of(16)) as u64
    }

    /// The buffer holding every block (padded so the last block's binding
    /// fits).
    pub fn finish(mut self, ctx: &GpuContext, label: &str) -> Result<wgpu::Buffer, GpuError> {
        let end = self.last + self.block_size() as usize;
        self.bytes.resize(end.max(self.bytes.len()), 0);
        let usage = if self.uniform {
            wgpu::BufferUsages::UNIFORM
        } else {
            wgpu::BufferUsages::STORAGE
        };
        ctx.buffer(label, &self.bytes, usage)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two entry points of one file, for keys.
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum Entry {
        A,
        B,
    }

    impl EntryPoint for Entry {
        fn source(self) -> (ShaderFile, &'static str) {
            match self {
                Entry::A => (ShaderFile::Collide, "a"),
                Entry::B => (ShaderFile::Collide, "b"),
            }
        }
    }

    #[test]
    fn every_part_of_a_spec_is_in_its_key() {
        let entries = [Entry::A, Entry::B];
        let base = KernelSetSpec {
            label: "contact",
            dim: 3,
            precision: Precision::F64,
            modules: &[ShaderFile::Collide],
            entries: &entries,
            constants: &[],
            generated: None,
        };
        let key = spec_key(&base);
        assert_eq!(key, spec_key(&KernelSetSpec { ..base }));
        let others = [
            KernelSetSpec {
                label: "other",
                ..base
            },
            KernelSetSpec { dim: 4, ..base },
            KernelSetSpec {
                precision: Precision::F32,
                ..base
            },
            KernelSetSpec {
                modules: &[ShaderFile::Grid],
                ..base
            },
            KernelSetSpec {
                entries: &entries[1..],
                ..base
            },
            KernelSetSpec {
                constants: &[("WORLDS", 2.0)],
                ..base
            },
            KernelSetSpec {
                generated: Some("fn f() {}"),
                ..base
            },
        ];
        for other in &others {
            assert_ne!(spec_key(other), key);
        }
    }
}
