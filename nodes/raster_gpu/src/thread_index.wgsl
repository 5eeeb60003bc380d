// The global thread of a 1D kernel of 256-thread workgroups dispatched as a 2D
// grid (65535 groups per axis at most): groups are numbered row-major.
fn thread_index(wid: vec3<u32>, groups: vec3<u32>, lid: u32) -> u32 {
    return (wid.y * groups.x + wid.x) * 256u + lid;
}
