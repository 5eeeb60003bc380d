//! Compute-pipeline plumbing shared by every kernel: pipeline creation,
//! storage buffers and their grow-only pools, uniform blocks staged in an
//! arena, bind groups and 2D dispatches.

use objectsplat_gpu::GpuContext;
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
    /// one axis allows) with `uniform` at binding 0 and `bindings` as
    /// (binding index, buffer) of group 0. The shader maps the 2D grid back to
    /// `wid.y·groups.x + wid.x` and ignores the surplus groups of the last row.
    fn dispatch_with(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        uniform: Option<&UniformSlice>,
        bindings: &[(u32, &wgpu::Buffer)],
        groups: u32,
    ) {
        if groups == 0 {
            return;
        }
        let mut entries: Vec<wgpu::BindGroupEntry> = bindings
            .iter()
            .map(|&(binding, buffer)| wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        if let Some(u) = uniform {
            entries.push(wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &u.buffer,
                    offset: u.offset,
                    size: wgpu::BufferSize::new(u.size),
                }),
            });
        }
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

/// Compiles `source` and one [`Kernel`] per entry point in `entries`, in that order.
pub fn compile_kernels<const N: usize>(
    ctx: &GpuContext,
    name: &str,
    source: &str,
    entries: [&'static str; N],
) -> [Kernel; N] {
    let module = shader(ctx, name, source);
    entries.map(|entry| Kernel::new(ctx, &module, entry))
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

/// Workgroups needed for `n` items at `per_group` items each.
pub fn groups_for(n: usize, per_group: usize) -> u32 {
    n.div_ceil(per_group) as u32
}

/// Uniform blocks of one submission, written with one `queue.write_buffer`
/// per 64 KiB chunk at submit time instead of one new buffer per dispatch.
/// Chunks are kept and reused (they grow in number only when one submission
/// needs more); every dispatch of a submission gets its own aligned slice, so
/// no dispatch sees another's parameters.
#[derive(Default)]
pub struct UniformArena {
    chunks: Vec<(wgpu::Buffer, Vec<u8>)>,
    /// The chunk being filled.
    chunk: usize,
    /// Buffers this arena created (for the pooling checks).
    pub created: u64,
}

const UNIFORM_CHUNK: u64 = 64 * 1024;
/// Offset alignment of the blocks: WebGPU caps `min_uniform_buffer_offset_alignment` at 256.
const UNIFORM_ALIGN: u64 = 256;

/// A slice of a [`UniformArena`] chunk holding one dispatch's parameters.
pub struct UniformSlice {
    buffer: wgpu::Buffer,
    offset: u64,
    size: u64,
}

impl UniformArena {
    /// Stages `value` for the next submission and returns where it will be.
    pub fn push<T: bytemuck::Pod>(&mut self, ctx: &GpuContext, value: &T) -> UniformSlice {
        let bytes = bytemuck::bytes_of(value);
        let size = bytes.len() as u64;
        let fits = |staged: &Vec<u8>| {
            (staged.len() as u64).div_ceil(UNIFORM_ALIGN) * UNIFORM_ALIGN + size <= UNIFORM_CHUNK
        };
        while self.chunk < self.chunks.len() && !fits(&self.chunks[self.chunk].1) {
            self.chunk += 1;
        }
        if self.chunk == self.chunks.len() {
            let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("uniform arena"),
                size: UNIFORM_CHUNK,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            self.created += 1;
            self.chunks
                .push((buffer, Vec::with_capacity(UNIFORM_CHUNK as usize)));
        }
        let (buffer, staged) = &mut self.chunks[self.chunk];
        let offset = (staged.len() as u64).div_ceil(UNIFORM_ALIGN) * UNIFORM_ALIGN;
        staged.resize(offset as usize, 0);
        staged.extend_from_slice(bytes);
        UniformSlice {
            buffer: buffer.clone(),
            offset,
            size,
        }
    }

    /// Writes the staged blocks to their chunks (ahead of the next submission) and starts over.
    pub fn flush(&mut self, ctx: &GpuContext) {
        for (buffer, staged) in &mut self.chunks {
            if !staged.is_empty() {
                // Copies are whole multiples of 4 bytes.
                staged.resize(staged.len().div_ceil(4) * 4, 0);
                ctx.queue.write_buffer(buffer, 0, staged);
                staged.clear();
            }
        }
        self.chunk = 0;
    }
}

/// A command encoder whose dispatches take their parameters from a
/// [`UniformArena`]; [`Recorder::submit`] writes them and submits.
pub struct Recorder<'a> {
    ctx: &'a GpuContext,
    pub enc: wgpu::CommandEncoder,
    uniforms: &'a mut UniformArena,
}

impl<'a> Recorder<'a> {
    pub fn new(ctx: &'a GpuContext, uniforms: &'a mut UniformArena) -> Self {
        Recorder {
            ctx,
            enc: ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default()),
            uniforms,
        }
    }

    pub fn ctx(&self) -> &'a GpuContext {
        self.ctx
    }

    /// Records `kernel` over `groups` workgroups with `params` at binding 0.
    pub fn dispatch<T: bytemuck::Pod>(
        &mut self,
        kernel: &Kernel,
        params: &T,
        bindings: &[(u32, &wgpu::Buffer)],
        groups: u32,
    ) {
        if groups == 0 {
            return;
        }
        let slice = self.uniforms.push(self.ctx, params);
        kernel.dispatch_with(self.ctx, &mut self.enc, Some(&slice), bindings, groups);
    }

    /// Writes the parameters and submits the recorded work (no wait).
    pub fn submit(self) {
        self.uniforms.flush(self.ctx);
        self.ctx.queue.submit([self.enc.finish()]);
    }
}

/// A storage buffer that grows (never shrinks) to the largest size asked of
/// it: the pools of the training loop, which allocate nothing once they have
/// grown to the model and the image.
pub struct Pooled {
    label: &'static str,
    buffer: wgpu::Buffer,
}

impl Pooled {
    /// A minimal buffer (256 bytes); `created` counts it.
    pub fn new(ctx: &GpuContext, label: &'static str, created: &mut u64) -> Self {
        *created += 1;
        Pooled {
            label,
            buffer: storage(ctx, label, 0),
        }
    }

    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// Makes the buffer hold at least `bytes` bytes, growing by a quarter
    /// more than asked so that slowly growing needs reallocate rarely. The
    /// contents do not survive a growth.
    pub fn ensure(&mut self, ctx: &GpuContext, bytes: u64, created: &mut u64) {
        if self.buffer.size() < padded(bytes) {
            *created += 1;
            self.buffer = storage(ctx, self.label, bytes + bytes / 4);
        }
    }

    /// Grows to hold `data` and writes it from offset 0 (ahead of the next submission).
    pub fn write<T: bytemuck::Pod>(&mut self, ctx: &GpuContext, data: &[T], created: &mut u64) {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        self.ensure(ctx, bytes.len() as u64, created);
        if !bytes.is_empty() {
            ctx.queue.write_buffer(&self.buffer, 0, bytes);
        }
    }
}
