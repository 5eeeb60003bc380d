//! GPU exclusive prefix sum of u32 values (wrapping on overflow, like the
//! WGSL `+`): blocks of 1024 scanned in workgroup memory, block totals scanned
//! recursively, offsets added back.

use crate::device::{GpuContext, read_values};
use crate::kernels::{Kernel, groups_for, shader, storage, storage_from, uniform};
use anyhow::Result;

pub const SCAN_WGSL: &str = include_str!("scan.wgsl");
const BLOCK: usize = 1024;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ScanParams {
    n: u32,
    _pad: [u32; 3],
}

/// The scan kernels, compiled once per context.
pub struct GpuScan {
    scan_blocks: Kernel,
    add_block_offsets: Kernel,
}

impl GpuScan {
    pub fn new(ctx: &GpuContext) -> Self {
        let module = shader(ctx, "scan.wgsl", SCAN_WGSL);
        GpuScan {
            scan_blocks: Kernel::new(ctx, &module, "scan_blocks"),
            add_block_offsets: Kernel::new(ctx, &module, "add_block_offsets"),
        }
    }

    /// Records an in-place exclusive scan of the first `n` u32 of `data`.
    pub fn encode(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        data: &wgpu::Buffer,
        n: usize,
    ) {
        if n == 0 {
            return;
        }
        let blocks = n.div_ceil(BLOCK);
        let params = uniform(
            ctx,
            "scan params",
            &ScanParams {
                n: n as u32,
                _pad: [0; 3],
            },
        );
        let sums = storage(ctx, "scan block sums", (blocks * 4) as u64);
        self.scan_blocks.dispatch(
            ctx,
            encoder,
            &[(0, &params), (1, data), (2, &sums)],
            groups_for(n, BLOCK),
        );
        if blocks == 1 {
            return;
        }
        self.encode(ctx, encoder, &sums, blocks);
        self.add_block_offsets.dispatch(
            ctx,
            encoder,
            &[(0, &params), (1, data), (2, &sums)],
            groups_for(n, BLOCK),
        );
    }

    /// Uploads `values`, scans them and reads the result back (tests, tools).
    pub fn exclusive_scan(&self, ctx: &GpuContext, values: &[u32]) -> Result<Vec<u32>> {
        let data = storage_from(ctx, "scan data", values);
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        self.encode(ctx, &mut encoder, &data, values.len());
        ctx.queue.submit([encoder.finish()]);
        ctx.check_errors("prefix sum")?;
        read_values(ctx, &data, values.len())
    }
}
