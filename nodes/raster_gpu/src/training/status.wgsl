// Shared by the training kernels: the bits of a step's status word (one word
// per step slot, collected by the host with the step's loss; the host's
// STATUS_BITS names them) and the per-pixel flags of a view.
const STATUS_RENDER: u32 = 1u;
const STATUS_LOSS: u32 = 2u;
// Adam raises `grad_bit` (4, 16, 64 for positions, SH, opacity logits) for a
// non-finite gradient and `grad_bit << 1` for a non-finite result.
const STATUS_DEPTH: u32 = 256u;
// The render needed more tile entries than the buffers held: its image is
// wrong, and the face statistics and Adam leave this step out.
const STATUS_OVERFLOW: u32 = 512u;

const FLAG_BACKGROUND: u32 = 1u;
const FLAG_OWN: u32 = 2u;
// A FLAG_BACKGROUND pixel under frozen neighbours: its target is the target
// colour (what they draw) plus the background colour times the share in the
// high bits, in units of 1 / SHARE_ONE.
const FLAG_LAYERED: u32 = 4u;
const SHARE_SHIFT: u32 = 16u;
const SHARE_ONE: f32 = 65535.0;
