// One pass of a stable LSD radix sort of (u32 key, u32 value) pairs on the
// 4-bit digit at `shift`. Blocks of 2048 pairs (128 threads × 16 consecutive
// items). `count_digits` writes per-block digit counts digit-major
// (`histogram[digit·blocks + block]`); after an exclusive scan of that array
// they are the global start of each (digit, block); `scatter` ranks every
// pair inside its block (threads in order, items in order: stable) and writes
// it to its global place. Dispatches are 2D: block = wid.y·groups.x + wid.x.

struct SortParams {
    n: u32,
    shift: u32,
    blocks: u32,
    _pad: u32,
}

const GROUP_THREADS: u32 = 128u;
const SORT_ITEMS: u32 = 16u;
const SORT_BLOCK: u32 = 2048u;
const RADIX: u32 = 16u;

@group(0) @binding(0) var<uniform> params: SortParams;
@group(0) @binding(1) var<storage, read> keys_in: array<u32>;
@group(0) @binding(2) var<storage, read> values_in: array<u32>;
@group(0) @binding(3) var<storage, read_write> keys_out: array<u32>;
@group(0) @binding(4) var<storage, read_write> values_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> histogram: array<u32>;

var<workgroup> block_counts: array<atomic<u32>, RADIX>;
// Per-thread digit counts, digit-major: [digit · 128 + thread].
var<workgroup> thread_counts: array<u32, 2048>;

fn digit_of(key: u32) -> u32 {
    return (key >> params.shift) & (RADIX - 1u);
}

@compute @workgroup_size(128)
fn count_digits(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let block = wid.y * groups.x + wid.x;
    if (block >= params.blocks) {
        return;
    }
    if (lid < RADIX) {
        atomicStore(&block_counts[lid], 0u);
    }
    workgroupBarrier();
    let base = block * SORT_BLOCK + lid * SORT_ITEMS;
    for (var k = 0u; k < SORT_ITEMS; k++) {
        let i = base + k;
        if (i < params.n) {
            atomicAdd(&block_counts[digit_of(keys_in[i])], 1u);
        }
    }
    workgroupBarrier();
    if (lid < RADIX) {
        histogram[lid * params.blocks + block] = atomicLoad(&block_counts[lid]);
    }
}

@compute @workgroup_size(128)
fn scatter(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let block = wid.y * groups.x + wid.x;
    if (block >= params.blocks) {
        return;
    }
    let base = block * SORT_BLOCK + lid * SORT_ITEMS;
    var counts: array<u32, 16>;
    for (var k = 0u; k < SORT_ITEMS; k++) {
        let i = base + k;
        if (i < params.n) {
            counts[digit_of(keys_in[i])] += 1u;
        }
    }
    for (var d = 0u; d < RADIX; d++) {
        thread_counts[d * GROUP_THREADS + lid] = counts[d];
    }
    workgroupBarrier();
    // Exclusive scan of the 2048 digit-major counts: each thread owns 16 in a row.
    var own: array<u32, 16>;
    var sum = 0u;
    for (var k = 0u; k < 16u; k++) {
        own[k] = sum;
        sum += thread_counts[lid * 16u + k];
    }
    let before = workgroup_exclusive_scan(lid, sum);
    for (var k = 0u; k < 16u; k++) {
        thread_counts[lid * 16u + k] = before + own[k];
    }
    workgroupBarrier();
    // Position = global start of (digit, block) + pairs of that digit in earlier threads + earlier items here.
    var next: array<u32, 16>;
    for (var d = 0u; d < RADIX; d++) {
        next[d] = histogram[d * params.blocks + block] + thread_counts[d * GROUP_THREADS + lid]
            - thread_counts[d * GROUP_THREADS];
    }
    for (var k = 0u; k < SORT_ITEMS; k++) {
        let i = base + k;
        if (i < params.n) {
            let key = keys_in[i];
            let d = digit_of(key);
            let at = next[d];
            next[d] = at + 1u;
            keys_out[at] = key;
            values_out[at] = values_in[i];
        }
    }
}
