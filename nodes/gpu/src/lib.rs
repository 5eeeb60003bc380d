//! The GPU platform ObjectSplat's kernels run on, with no 3D knowledge: adapter selection
//! (hardware GPU, then Mesa lavapipe), the shared device, WGSL validation and buffer
//! readback. The rasterizer backend (`objectsplat-raster-gpu`) and the face-id rasterizer of
//! ground-truth masks (`objectsplat-masks`) both use it.
//!
//! Nothing here panics when no adapter exists: every failure is an `Err`
//! whose message says why, so callers can fall back to the CPU backend.

use anyhow::{Context, Result, anyhow, bail};
use std::sync::{Arc, Mutex, OnceLock};

/// The wgpu this crate is built on, for crates that write kernels on its devices.
pub use wgpu;

/// Which adapter to ask for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AdapterChoice {
    /// A hardware GPU when there is one, otherwise lavapipe (CPU Vulkan).
    Auto,
    /// A hardware GPU only.
    Gpu,
    /// Mesa lavapipe (or any CPU adapter) only.
    Lavapipe,
}

/// Environment variable that disables every adapter (tests the fallback path).
pub const NO_GPU_ENV: &str = "OBJECTSPLAT_NO_GPU";

/// A device and queue with what the kernels need to know about them.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    /// `SHADER_FLOAT32_ATOMIC` is enabled: kernels may use native `atomic<f32>` adds.
    pub float_atomics: bool,
    /// Validation errors the device reported asynchronously (wgpu would panic
    /// on them by default); [`GpuContext::check_errors`] turns them into `Err`.
    errors: Arc<Mutex<Vec<String>>>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.adapter_info.name)
            .field("backend", &self.adapter_info.backend)
            .field("float_atomics", &self.float_atomics)
            .finish()
    }
}

fn is_cpu(info: &wgpu::AdapterInfo) -> bool {
    info.device_type == wgpu::DeviceType::Cpu
}

fn describe(info: &wgpu::AdapterInfo) -> String {
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => "discrete GPU",
        wgpu::DeviceType::IntegratedGpu => "integrated GPU",
        wgpu::DeviceType::VirtualGpu => "virtual GPU",
        wgpu::DeviceType::Cpu => "CPU",
        wgpu::DeviceType::Other => "other",
    };
    format!("{} ({:?}, {kind})", info.name, info.backend)
}

impl GpuContext {
    /// Creates a new device on the chosen adapter. `Ok((ctx, why))` with `why`
    /// one line for the run report; `Err(reason)` when no adapter fits.
    pub fn acquire(choice: AdapterChoice) -> Result<(Arc<GpuContext>, String)> {
        if std::env::var(NO_GPU_ENV).is_ok_and(|v| !v.is_empty() && v != "0") {
            bail!("disabled by {NO_GPU_ENV}");
        }
        // Vulkan only: the kernels need storage atomics, and probing GL through EGL makes
        // Mesa print a Wayland "XDG_RUNTIME_DIR is invalid" error on headless machines.
        // Creating an instance panics only when no backend is compiled in; Vulkan is.
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        if adapters.is_empty() {
            bail!(
                "no wgpu adapter found (no Vulkan driver; install mesa-vulkan-drivers for lavapipe)"
            );
        }
        let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu | wgpu::DeviceType::Other => 2,
            wgpu::DeviceType::Cpu => 3,
        };
        let mut candidates: Vec<&wgpu::Adapter> = adapters
            .iter()
            .filter(|a| match choice {
                AdapterChoice::Auto => true,
                AdapterChoice::Gpu => !is_cpu(&a.get_info()),
                AdapterChoice::Lavapipe => is_cpu(&a.get_info()),
            })
            .collect();
        candidates.sort_by_key(|a| rank(a));
        let has_hardware = adapters.iter().any(|a| !is_cpu(&a.get_info()));
        let Some(adapter) = candidates.first() else {
            let seen: Vec<String> = adapters.iter().map(|a| describe(&a.get_info())).collect();
            bail!(
                "no Vulkan adapter of the requested kind ({choice:?}); adapters seen: {}",
                seen.join(", ")
            );
        };
        let info = adapter.get_info();
        let float_atomics = adapter
            .features()
            .contains(wgpu::Features::SHADER_FLOAT32_ATOMIC);
        let required_features = if float_atomics {
            wgpu::Features::SHADER_FLOAT32_ATOMIC
        } else {
            wgpu::Features::empty()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("objectsplat"),
            required_features,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .with_context(|| format!("requesting a device on {}", describe(&info)))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            // A poisoned lock only means another thread panicked while pushing; keep recording.
            sink.lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(e.to_string());
        }));
        let why = if is_cpu(&info) {
            let reason = match choice {
                AdapterChoice::Lavapipe => "CPU adapter requested",
                _ if has_hardware => "hardware adapter not usable",
                _ => "no hardware GPU adapter",
            };
            format!("wgpu on {} (lavapipe, CPU Vulkan): {reason}", info.name)
        } else {
            format!("wgpu on {}", describe(&info))
        };
        Ok((
            Arc::new(GpuContext {
                device,
                queue,
                adapter_info: info,
                float_atomics,
                errors,
            }),
            why,
        ))
    }

    /// The per-process context for `choice`, created on first use. A failure
    /// is remembered too, so a missing adapter is probed once.
    pub fn shared(choice: AdapterChoice) -> Result<(Arc<GpuContext>, String)> {
        type Slot = OnceLock<std::result::Result<(Arc<GpuContext>, String), String>>;
        static AUTO: Slot = OnceLock::new();
        static GPU: Slot = OnceLock::new();
        static LAVAPIPE: Slot = OnceLock::new();
        let slot = match choice {
            AdapterChoice::Auto => &AUTO,
            AdapterChoice::Gpu => &GPU,
            AdapterChoice::Lavapipe => &LAVAPIPE,
        };
        slot.get_or_init(|| Self::acquire(choice).map_err(|e| format!("{e:#}")))
            .clone()
            .map_err(|e| anyhow!(e))
    }

    /// Returns (and clears) the validation errors reported since the last call.
    pub fn check_errors(&self, what: &str) -> Result<()> {
        let mut errors = self.errors.lock().unwrap_or_else(|p| p.into_inner());
        if errors.is_empty() {
            return Ok(());
        }
        let all = std::mem::take(&mut *errors).join("; ");
        bail!("wgpu reported an error during {what}: {all}")
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self, what: &str) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| anyhow!("waiting for the device during {what}: {e}"))?;
        self.check_errors(what)
    }
}

/// On a headless machine (no `XDG_RUNTIME_DIR`), turns off Mesa's Vulkan
/// device-select layer, which otherwise connects to Wayland while adapters are
/// enumerated and prints "error: XDG_RUNTIME_DIR is invalid or not set" to the
/// terminal. It only orders devices for a display; adapter choice here ranks
/// them itself. A variable the user set is left alone.
///
/// # Safety
/// Writes the process environment: call it before any other thread starts
/// (first thing in `main`).
pub unsafe fn quiet_headless_vulkan() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("NODEVICE_SELECT").is_none()
    {
        // SAFETY: the caller guarantees that no other thread reads or writes the environment.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// Parses and validates WGSL with naga (all capabilities wgpu may enable for
/// us); the error names the shader.
pub fn validate_wgsl(name: &str, source: &str) -> Result<()> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| anyhow!("shader {name}: {}", e.emit_to_string(source)))?;
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    );
    validator
        .validate(&module)
        .map_err(|e| anyhow!("shader {name}: {}", e.emit_to_string(source)))?;
    Ok(())
}

/// Size and member (name, offset) list of the WGSL struct `name` in `source`,
/// as naga lays it out for host-shareable memory.
pub fn wgsl_struct_layout(source: &str, name: &str) -> Result<(u32, Vec<(String, u32)>)> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| anyhow!("WGSL source: {}", e.emit_to_string(source)))?;
    for (_, ty) in module.types.iter() {
        if ty.name.as_deref() == Some(name)
            && let naga::TypeInner::Struct { members, span } = &ty.inner
        {
            let members = members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                .collect();
            return Ok((*span, members));
        }
    }
    bail!("no struct {name} in the WGSL source")
}

/// Checks that a Rust mirror of a WGSL struct has its size and member offsets
/// (`rust`: WGSL member name → Rust byte offset), for the tests of every kernel's host side.
pub fn check_mirrors_wgsl(
    source: &str,
    name: &str,
    size: usize,
    rust: &[(&str, usize)],
) -> Result<()> {
    let (span, members) = wgsl_struct_layout(source, name)?;
    if span as usize != size {
        bail!("{name} is {span} bytes in WGSL but {size} in Rust");
    }
    if members.len() != rust.len() {
        bail!(
            "{name} has members {members:?} in WGSL, {} in Rust",
            rust.len()
        );
    }
    for (member, offset) in members {
        let Some((_, want)) = rust.iter().find(|(n, _)| *n == member) else {
            bail!("{name}.{member} has no Rust counterpart");
        };
        if offset as usize != *want {
            bail!("{name}.{member} is at byte {offset} in WGSL but {want} in Rust");
        }
    }
    Ok(())
}

/// Copies `bytes` bytes of `source` (from offset 0) back to the host.
/// `source` needs `COPY_SRC` usage.
pub fn read_buffer(ctx: &GpuContext, source: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>> {
    let mut all = read_buffers(ctx, &[(source, bytes)])?;
    Ok(all.pop().unwrap_or_default())
}

/// Copies several buffers back with one submission and one wait (each
/// `(buffer, bytes)` from offset 0; buffers need `COPY_SRC` usage).
pub fn read_buffers(ctx: &GpuContext, sources: &[(&wgpu::Buffer, u64)]) -> Result<Vec<Vec<u8>>> {
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    let mut staged = Vec::with_capacity(sources.len());
    for &(source, bytes) in sources {
        if bytes == 0 {
            staged.push(None);
            continue;
        }
        let size = bytes.div_ceil(wgpu::COPY_BUFFER_ALIGNMENT) * wgpu::COPY_BUFFER_ALIGNMENT;
        if size > source.size() {
            bail!(
                "readback of {bytes} bytes from a buffer of {} bytes",
                source.size()
            );
        }
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        encoder.copy_buffer_to_buffer(source, 0, &staging, 0, size);
        staged.push(Some((staging, bytes)));
    }
    ctx.queue.submit([encoder.finish()]);
    staged
        .into_iter()
        .map(|s| match s {
            Some((staging, bytes)) => map_and_copy(ctx, &staging, bytes),
            None => Ok(Vec::new()),
        })
        .collect()
}

/// A readback buffer kept between readbacks (grown, never shrunk): several
/// buffers come back with one submission, one wait and no new buffer once it
/// has grown to the largest readback.
#[derive(Default)]
pub struct Readback {
    staging: Option<wgpu::Buffer>,
    /// Buffers it created (for the pooling checks).
    pub created: u64,
}

impl Readback {
    /// Copies `bytes` bytes of each source (from offset 0; `COPY_SRC` usage)
    /// back to the host.
    pub fn read(
        &mut self,
        ctx: &GpuContext,
        sources: &[(&wgpu::Buffer, u64)],
    ) -> Result<Vec<Vec<u8>>> {
        let align = wgpu::COPY_BUFFER_ALIGNMENT;
        let mut offsets = Vec::with_capacity(sources.len());
        let mut total = 0u64;
        for &(source, bytes) in sources {
            let size = bytes.div_ceil(align) * align;
            if size > source.size() {
                bail!(
                    "readback of {bytes} bytes from a buffer of {} bytes",
                    source.size()
                );
            }
            offsets.push(total);
            total += size;
        }
        if total == 0 {
            return Ok(vec![Vec::new(); sources.len()]);
        }
        if self.staging.as_ref().is_none_or(|b| b.size() < total) {
            self.created += 1;
            self.staging = Some(ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size: (total + total / 4).div_ceil(align) * align,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let Some(staging) = &self.staging else {
            unreachable!("the staging buffer was created above");
        };
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        for (&(source, bytes), &at) in sources.iter().zip(&offsets) {
            if bytes > 0 {
                encoder.copy_buffer_to_buffer(
                    source,
                    0,
                    staging,
                    at,
                    bytes.div_ceil(align) * align,
                );
            }
        }
        ctx.queue.submit([encoder.finish()]);
        let all = map_and_copy(ctx, staging, total)?;
        Ok(sources
            .iter()
            .zip(&offsets)
            .map(|(&(_, bytes), &at)| all[at as usize..(at + bytes) as usize].to_vec())
            .collect())
    }
}

/// Maps a `MAP_READ` buffer (after the work writing it was submitted) and copies it out.
pub fn map_and_copy(ctx: &GpuContext, staging: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>> {
    if bytes == 0 {
        return Ok(Vec::new());
    }
    let size = bytes.div_ceil(wgpu::COPY_BUFFER_ALIGNMENT) * wgpu::COPY_BUFFER_ALIGNMENT;
    let (tx, rx) = std::sync::mpsc::channel();
    staging
        .slice(..size)
        .map_async(wgpu::MapMode::Read, move |r| {
            // The receiver lives until after the poll below; a failed send changes nothing.
            let _ = tx.send(r);
        });
    ctx.wait("readback")?;
    rx.recv()
        .map_err(|_| anyhow!("readback callback never ran"))?
        .map_err(|e| anyhow!("mapping a readback buffer failed: {e}"))?;
    let out = {
        let view = staging
            .slice(..size)
            .get_mapped_range()
            .map_err(|e| anyhow!("reading a mapped buffer failed: {e:?}"))?;
        view[..bytes as usize].to_vec()
    };
    staging.unmap();
    Ok(out)
}

/// Reads `count` plain values of type `T` back from `source`.
pub fn read_values<T: bytemuck::Pod>(
    ctx: &GpuContext,
    source: &wgpu::Buffer,
    count: usize,
) -> Result<Vec<T>> {
    let bytes = read_buffer(ctx, source, (count * std::mem::size_of::<T>()) as u64)?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}
