//! GPU stable LSD radix sort of (u32 key, u32 value) pairs, 4 bits per pass,
//! only over the key bits the caller says are in use.

use crate::kernels::{
    Kernel, Pooled, Recorder, UniformArena, compile_kernels, groups_for, storage, storage_from,
};
use crate::scan::{GpuScan, ScanScratch};
use anyhow::{Result, bail};
use objectsplat_gpu::{GpuContext, read_values};

pub const SORT_WGSL: &str = concat!(
    include_str!("workgroup_scan.wgsl"),
    include_str!("sort.wgsl")
);
const BLOCK: usize = 2048;
const RADIX: usize = 16;
const BITS_PER_PASS: u32 = 4;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SortParams {
    n: u32,
    shift: u32,
    blocks: u32,
    _pad: u32,
}

/// Number of bits needed to hold every value ≤ `max_key`.
pub fn key_bits(max_key: u32) -> u32 {
    32 - max_key.leading_zeros()
}

/// The sort kernels, compiled once per context.
pub struct GpuSort {
    count_digits: Kernel,
    scatter: Kernel,
}

/// Two (key, value) buffer pairs the sort ping-pongs between; the result
/// ends in `keys`/`values`.
pub struct SortBuffers<'a> {
    pub keys: &'a wgpu::Buffer,
    pub values: &'a wgpu::Buffer,
    pub scratch_keys: &'a wgpu::Buffer,
    pub scratch_values: &'a wgpu::Buffer,
}

impl GpuSort {
    pub fn new(ctx: &GpuContext) -> Self {
        let [count_digits, scatter] =
            compile_kernels(ctx, "sort.wgsl", SORT_WGSL, ["count_digits", "scatter"]);
        GpuSort {
            count_digits,
            scatter,
        }
    }

    /// Records a stable sort of the first `n` pairs by the low `bits` key bits
    /// (higher bits must be zero, or they are ignored), with its histogram and
    /// scan sums in `scratch`.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        rec: &mut Recorder<'_>,
        scan: &GpuScan,
        buffers: &SortBuffers<'_>,
        n: usize,
        bits: u32,
        scratch: &mut SortScratch,
    ) {
        if n <= 1 || bits == 0 {
            return;
        }
        let blocks = n.div_ceil(BLOCK);
        scratch
            .histogram
            .ensure(rec.ctx(), (blocks * RADIX * 4) as u64, &mut scratch.created);
        let passes = bits.min(32).div_ceil(BITS_PER_PASS);
        let pairs = [
            (buffers.keys, buffers.values),
            (buffers.scratch_keys, buffers.scratch_values),
        ];
        for pass in 0..passes {
            let (src, dst) = (pairs[pass as usize % 2], pairs[(pass as usize + 1) % 2]);
            let params = SortParams {
                n: n as u32,
                shift: pass * BITS_PER_PASS,
                blocks: blocks as u32,
                _pad: 0,
            };
            let histogram = scratch.histogram.buffer();
            rec.dispatch(
                &self.count_digits,
                &params,
                &[(1, src.0), (5, histogram)],
                groups_for(n, BLOCK),
            );
            scan.encode(rec, histogram, blocks * RADIX, &mut scratch.scan);
            let histogram = scratch.histogram.buffer();
            rec.dispatch(
                &self.scatter,
                &params,
                &[
                    (1, src.0),
                    (2, src.1),
                    (3, dst.0),
                    (4, dst.1),
                    (5, histogram),
                ],
                groups_for(n, BLOCK),
            );
        }
        if passes % 2 == 1 {
            let bytes = (n * 4) as u64;
            rec.enc
                .copy_buffer_to_buffer(buffers.scratch_keys, 0, buffers.keys, 0, bytes);
            rec.enc
                .copy_buffer_to_buffer(buffers.scratch_values, 0, buffers.values, 0, bytes);
        }
    }

    /// Uploads the pairs, sorts them by the low `bits` key bits and reads them back (tests, tools).
    pub fn sort_pairs(
        &self,
        ctx: &GpuContext,
        scan: &GpuScan,
        keys: &[u32],
        values: &[u32],
        bits: u32,
    ) -> Result<(Vec<u32>, Vec<u32>)> {
        if keys.len() != values.len() {
            bail!("sort got {} keys but {} values", keys.len(), values.len());
        }
        let n = keys.len();
        let k = storage_from(ctx, "sort keys", keys);
        let v = storage_from(ctx, "sort values", values);
        let sk = storage(ctx, "sort scratch keys", (n * 4) as u64);
        let sv = storage(ctx, "sort scratch values", (n * 4) as u64);
        let buffers = SortBuffers {
            keys: &k,
            values: &v,
            scratch_keys: &sk,
            scratch_values: &sv,
        };
        let mut uniforms = UniformArena::default();
        let mut scratch = SortScratch::new(ctx);
        let mut rec = Recorder::new(ctx, &mut uniforms);
        self.encode(&mut rec, scan, &buffers, n, bits, &mut scratch);
        rec.submit();
        ctx.check_errors("radix sort")?;
        Ok((read_values(ctx, &k, n)?, read_values(ctx, &v, n)?))
    }
}

/// A sort's digit histogram and the scan's block sums, kept between sorts.
pub struct SortScratch {
    histogram: Pooled,
    scan: ScanScratch,
    created: u64,
}

impl SortScratch {
    pub fn new(ctx: &GpuContext) -> Self {
        let mut created = 0;
        SortScratch {
            histogram: Pooled::new(ctx, "sort histogram", &mut created),
            scan: ScanScratch::new(ctx),
            created,
        }
    }

    /// Buffers created so far (the pooling checks).
    pub fn created(&self) -> u64 {
        self.created + self.scan.created
    }
}
