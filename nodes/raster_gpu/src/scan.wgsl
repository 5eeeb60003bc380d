// Exclusive prefix sum of u32, in place, in blocks of 1024 (256 threads × 4
// items). `scan_blocks` scans each block and writes its total to `block_sums`;
// the host scans `block_sums` recursively, then `add_block_offsets` adds each
// block's offset back. Dispatches are 2D (65535 groups per axis at most):
// block = wid.y·groups.x + wid.x, surplus groups of the last row return.

struct ScanParams {
    n: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

const GROUP_THREADS: u32 = 256u;
const SCAN_ITEMS: u32 = 4u;
const SCAN_BLOCK: u32 = 1024u;

@group(0) @binding(0) var<uniform> params: ScanParams;
@group(0) @binding(1) var<storage, read_write> data: array<u32>;
@group(0) @binding(2) var<storage, read_write> block_sums: array<u32>;

@compute @workgroup_size(256)
fn scan_blocks(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let block = wid.y * groups.x + wid.x;
    if (block * SCAN_BLOCK >= params.n) {
        return;
    }
    let base = block * SCAN_BLOCK + lid * SCAN_ITEMS;
    var items: array<u32, 4>;
    var running = 0u;
    for (var k = 0u; k < SCAN_ITEMS; k++) {
        let i = base + k;
        var v = 0u;
        if (i < params.n) {
            v = data[i];
        }
        items[k] = running;
        running += v;
    }
    let before = workgroup_exclusive_scan(lid, running);
    for (var k = 0u; k < SCAN_ITEMS; k++) {
        let i = base + k;
        if (i < params.n) {
            data[i] = before + items[k];
        }
    }
    if (lid == GROUP_THREADS - 1u) {
        block_sums[block] = thread_totals[lid];
    }
}

@compute @workgroup_size(256)
fn add_block_offsets(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let block = wid.y * groups.x + wid.x;
    if (block * SCAN_BLOCK >= params.n) {
        return;
    }
    let offset = block_sums[block];
    let base = block * SCAN_BLOCK + lid * SCAN_ITEMS;
    for (var k = 0u; k < SCAN_ITEMS; k++) {
        let i = base + k;
        if (i < params.n) {
            data[i] += offset;
        }
    }
}
