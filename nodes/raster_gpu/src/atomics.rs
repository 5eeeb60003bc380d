//! WGSL helpers for float accumulation into storage buffers: native
//! `atomic<f32>` adds where the device has `SHADER_FLOAT32_ATOMIC`, a
//! compare-exchange loop on the f32 bits in an `atomic<u32>` otherwise.

/// How kernels add floats into shared accumulators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FloatAtomics {
    Native,
    CompareExchange,
}

/// Declares `var<storage, read_write> {buffer}` at `binding` of group 0 and
/// the functions `add_{name}(i: u32, v: f32)` and `load_{name}(i: u32) -> f32`.
pub fn accumulator_wgsl(mode: FloatAtomics, name: &str, buffer: &str, binding: u32) -> String {
    match mode {
        FloatAtomics::Native => format!(
            "@group(0) @binding({binding}) var<storage, read_write> {buffer}: array<atomic<f32>>;\n\
             fn add_{name}(i: u32, v: f32) {{ atomicAdd(&{buffer}[i], v); }}\n\
             fn load_{name}(i: u32) -> f32 {{ return atomicLoad(&{buffer}[i]); }}\n"
        ),
        FloatAtomics::CompareExchange => format!(
            "@group(0) @binding({binding}) var<storage, read_write> {buffer}: array<atomic<u32>>;\n\
             fn add_{name}(i: u32, v: f32) {{\n\
             \x20   var old = atomicLoad(&{buffer}[i]);\n\
             \x20   loop {{\n\
             \x20       let swapped = atomicCompareExchangeWeak(&{buffer}[i], old, bitcast<u32>(bitcast<f32>(old) + v));\n\
             \x20       if (swapped.exchanged) {{ break; }}\n\
             \x20       old = swapped.old_value;\n\
             \x20   }}\n\
             }}\n\
             fn load_{name}(i: u32) -> f32 {{ return bitcast<f32>(atomicLoad(&{buffer}[i])); }}\n"
        ),
    }
}
