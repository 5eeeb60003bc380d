// Shared by the per-tile kernels (forward and backward), which both declare
// `frame` (the frame record, read-only) and `background`: one workgroup per
// 16×16 tile of the frame record's region (row-major over its tiles; the
// surplus groups of the 2D grid's last row have none), pixels addressed
// row-major within the region.

struct RegionTile {
    // The rendered region [x0, x1) × [y0, y1).
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    // The tile's column and row in the whole image's tile grid, and its index there.
    tx: u32,
    ty: u32,
    index: u32,
    // False for a surplus workgroup past the region's last tile.
    exists: bool,
}

fn region_tile(wid: vec3<u32>, groups: vec3<u32>) -> RegionTile {
    var rt: RegionTile;
    let r = wid.y * groups.x + wid.x;
    rt.x0 = frame[FRAME_X0];
    rt.y0 = frame[FRAME_Y0];
    rt.x1 = frame[FRAME_X1];
    rt.y1 = frame[FRAME_Y1];
    let region_tiles_x = (rt.x1 - rt.x0 + TILE - 1u) / TILE;
    let region_tiles_y = (rt.y1 - rt.y0 + TILE - 1u) / TILE;
    rt.exists = r < region_tiles_x * region_tiles_y;
    if (!rt.exists) {
        return rt;
    }
    rt.tx = rt.x0 / TILE + r % region_tiles_x;
    rt.ty = rt.y0 / TILE + r / region_tiles_x;
    rt.index = rt.ty * params.tiles_x + rt.tx;
    return rt;
}

// Image coordinates of the tile's pixel `local` (row-major in the tile).
fn tile_pixel(rt: RegionTile, local: u32) -> vec2<u32> {
    return vec2<u32>(rt.tx * TILE + local % TILE, rt.ty * TILE + local / TILE);
}

fn in_region(rt: RegionTile, x: u32, y: u32) -> bool {
    return x < rt.x1 && y < rt.y1;
}

// Index of the region's pixel (x, y) (image coordinates) among the region's pixels.
fn region_pixel(rt: RegionTile, x: u32, y: u32) -> u32 {
    return (y - rt.y0) * (rt.x1 - rt.x0) + x - rt.x0;
}

fn background_at(pix: u32) -> vec3<f32> {
    if (params.uniform_background != 0u) {
        return params.background_color.xyz;
    }
    return vec3<f32>(background[3u * pix], background[3u * pix + 1u], background[3u * pix + 2u]);
}
