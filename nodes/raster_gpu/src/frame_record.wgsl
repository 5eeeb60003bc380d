// Words of the render's frame record (a small storage buffer written on the
// device), read by the raster kernels and the training loss: the tile-entry
// count, the rendered region [x0, x1) × [y0, y1) (tile-aligned x0, y0; clipped
// to the image), and the drawn faces' pixel box as `face_pre` reduces it with
// atomics: !x0, !y0, x1 + 1, y1 + 1 (inclusive box; all 0 when no face is
// drawn), so that a zero-cleared buffer starts it.
const FRAME_ENTRIES: u32 = 0u;
const FRAME_X0: u32 = 1u;
const FRAME_Y0: u32 = 2u;
const FRAME_X1: u32 = 3u;
const FRAME_Y1: u32 = 4u;
const FRAME_FOOTPRINT: u32 = 5u;
