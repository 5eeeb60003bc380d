// Exclusive prefix sum across a workgroup of one u32 total per thread
// (Hillis–Steele over `thread_totals`), shared by the prefix sum and the radix
// sort. The program it is prepended to declares GROUP_THREADS, its workgroup size.

var<workgroup> thread_totals: array<u32, GROUP_THREADS>;

// The sum of the totals of the threads before `lid`; afterwards
// `thread_totals[lid]` holds the inclusive sum (the last thread's: the workgroup's).
fn workgroup_exclusive_scan(lid: u32, total: u32) -> u32 {
    thread_totals[lid] = total;
    workgroupBarrier();
    for (var offset = 1u; offset < GROUP_THREADS; offset <<= 1u) {
        var add = 0u;
        if (lid >= offset) {
            add = thread_totals[lid - offset];
        }
        workgroupBarrier();
        thread_totals[lid] += add;
        workgroupBarrier();
    }
    return thread_totals[lid] - total;
}
