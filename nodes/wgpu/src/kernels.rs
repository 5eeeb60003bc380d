//! Compute-pipeline plumbing shared by every kernel: pipeline creation,
//! storage/uniform buffers, bind groups and 2D dispatches.

use crate::device::GpuContext;
use wgpu::util::DeviceExt;

/// Most workgroups one dispatch axis may have.
const MAX_GROUPS_PER_AXIS: u32 = 65_535;

/// One entry point of a shader module.
pub struct Kernel {
    pub name: &'static str,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

impl Kernel {
    pub fn new(ctx: &GpuContext, module: &wgpu::ShaderModule, entry: &'static str) -> Self {
        let pipeline = ctx
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
        let layout = pipeline.get_bind_group_layout(0);
        Kernel {
            name: entry,
            pipeline,
            layout,
        }
    }

    /// Records a dispatch of `groups` workgroups (as a 2D grid when more than
    /// one axis allows) with `bindings` as (binding index, buffer) of group 0.
    /// The shader maps the 2D grid back to `wid.y·groups.x + wid.x` and ignores
    /// the surplus groups of the last row.
    pub fn dispatch(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        bindings: &[(u32, &wgpu::Buffer)],
        groups: u32,
    ) {
        if groups == 0 {
            return;
        }
        let entries: Vec<wgpu::BindGroupEntry> = bindings
            .iter()
            .map(|&(binding, buffer)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(self.name),
            layout: &self.layout,
            entries: &entries,
        });
        let x = groups.min(MAX_GROUPS_PER_AXIS);
        let y = groups.div_ceil(x);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(self.name),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
}

/// Compiles WGSL (validated by wgpu; errors surface through [`GpuContext::check_errors`]).
pub fn shader(ctx: &GpuContext, name: &str, source: &str) -> wgpu::ShaderModule {
    ctx.device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        })
}

pub const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

/// Bytes of a binding that may be empty: wgpu rejects zero-sized bindings and
/// bindings smaller than one element of their array (the largest, a face
/// record, is 192 bytes).
fn padded(bytes: u64) -> u64 {
    bytes.max(256).div_ceil(4) * 4
}

/// An uninitialised storage buffer of `bytes` bytes (at least 256).
pub fn storage(ctx: &GpuContext, label: &str, bytes: u64) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: padded(bytes),
        usage: STORAGE,
        mapped_at_creation: false,
    })
}

/// A storage buffer holding `data` (zero-padded to at least 256 bytes).
pub fn storage_from<T: bytemuck::Pod>(ctx: &GpuContext, label: &str, data: &[T]) -> wgpu::Buffer {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    if bytes.len() as u64 == padded(bytes.len() as u64) {
        return ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: STORAGE,
            });
    }
    let mut padded_bytes = bytes.to_vec();
    padded_bytes.resize(padded(bytes.len() as u64) as usize, 0);
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &padded_bytes,
            usage: STORAGE,
        })
}

/// A uniform buffer holding `value`.
pub fn uniform<T: bytemuck::Pod>(ctx: &GpuContext, label: &str, value: &T) -> wgpu::Buffer {
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::bytes_of(value),
            usage: wgpu::BufferUsages::UNIFORM,
        })
}

/// Workgroups needed for `n` items at `per_group` items each.
pub fn groups_for(n: usize, per_group: usize) -> u32 {
    n.div_ceil(per_group) as u32
}
