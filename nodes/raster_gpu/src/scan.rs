//! GPU exclusive prefix sum of u32 values (wrapping on overflow, like the
//! WGSL `+`): blocks of 1024 scanned in workgroup memory, block totals scanned
//! recursively, offsets added back.

use crate::kernels::{
    Kernel, Pooled, Recorder, UniformArena, compile_kernels, groups_for, storage_from,
};
use anyhow::Result;
use objectsplat_gpu::{GpuContext, read_values};

pub const SCAN_WGSL: &str = concat!(
    include_str!("workgroup_scan.wgsl"),
    include_str!("scan.wgsl")
);
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
        let [scan_blocks, add_block_offsets] = compile_kernels(
            ctx,
            "scan.wgsl",
            SCAN_WGSL,
            ["scan_blocks", "add_block_offsets"],
        );
        GpuScan {
            scan_blocks,
            add_block_offsets,
        }
    }

    /// Records an in-place exclusive scan of the first `n` u32 of `data`,
    /// with the block sums in `scratch` (grown as needed).
    pub fn encode(
        &self,
        rec: &mut Recorder<'_>,
        data: &wgpu::Buffer,
        n: usize,
        scratch: &mut ScanScratch,
    ) {
        self.encode_level(rec, data, n, &mut scratch.levels, &mut scratch.created);
    }

    fn encode_level(
        &self,
        rec: &mut Recorder<'_>,
        data: &wgpu::Buffer,
        n: usize,
        levels: &mut [Pooled],
        created: &mut u64,
    ) {
        if n == 0 {
            return;
        }
        let blocks = n.div_ceil(BLOCK);
        let params = ScanParams {
            n: n as u32,
            _pad: [0; 3],
        };
        let Some((sums, deeper)) = levels.split_first_mut() else {
            // ScanScratch holds more levels than any u32 count needs (checked there).
            unreachable!("prefix sum deeper than its scratch levels");
        };
        sums.ensure(rec.ctx(), (blocks * 4) as u64, created);
        let sums = &*sums;
        rec.dispatch(
            &self.scan_blocks,
            &params,
            &[(1, data), (2, sums.buffer())],
            groups_for(n, BLOCK),
        );
        if blocks == 1 {
            return;
        }
        self.encode_level(rec, sums.buffer(), blocks, deeper, created);
        rec.dispatch(
            &self.add_block_offsets,
            &params,
            &[(1, data), (2, sums.buffer())],
            groups_for(n, BLOCK),
        );
    }

    /// Uploads `values`, scans them and reads the result back (tests, tools).
    pub fn exclusive_scan(&self, ctx: &GpuContext, values: &[u32]) -> Result<Vec<u32>> {
        let data = storage_from(ctx, "scan data", values);
        let mut uniforms = UniformArena::default();
        let mut scratch = ScanScratch::new(ctx);
        let mut rec = Recorder::new(ctx, &mut uniforms);
        self.encode(&mut rec, &data, values.len(), &mut scratch);
        rec.submit();
        ctx.check_errors("prefix sum")?;
        read_values(ctx, &data, values.len())
    }
}

/// The block sums of every level of a prefix sum, kept between scans.
pub struct ScanScratch {
    levels: Vec<Pooled>,
    pub created: u64,
}

impl ScanScratch {
    pub fn new(ctx: &GpuContext) -> Self {
        let mut created = 0;
        // Each level divides the count by 1024: four levels cover any u32 count.
        let levels = (0..4)
            .map(|_| Pooled::new(ctx, "scan block sums", &mut created))
            .collect();
        ScanScratch { levels, created }
    }
}
