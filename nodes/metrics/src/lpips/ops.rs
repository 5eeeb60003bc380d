//! The few CNN operations AlexNet needs, on single CHW f32 tensors.

/// One image's activations, channel-major (C×H×W), like a torch tensor with batch 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Tensor {
    pub channels: usize,
    pub height: usize,
    pub width: usize,
    pub data: Vec<f32>,
}

/// A 2-D convolution with torch's weight layout `[out, in, k, k]`, square kernel,
/// equal stride and zero padding on both axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Conv2d {
    pub out_channels: usize,
    pub in_channels: usize,
    pub kernel: usize,
    pub stride: usize,
    pub padding: usize,
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
}

impl Conv2d {
    pub fn output_size(&self, height: usize, width: usize) -> Option<(usize, usize)> {
        let span = |n: usize| {
            (n + 2 * self.padding)
                .checked_sub(self.kernel)
                .map(|d| d / self.stride + 1)
        };
        Some((span(height)?, span(width)?))
    }

    /// Convolution followed by ReLU (AlexNet never taps a pre-activation).
    /// The caller guarantees the input is large enough (`output_size` is `Some`).
    pub fn forward_relu(&self, x: &Tensor) -> Tensor {
        assert_eq!(x.channels, self.in_channels, "conv input channels");
        // Invariant: callers check the size through `output_size` first.
        let (oh, ow) = self
            .output_size(x.height, x.width)
            .expect("input smaller than the kernel");
        let k = self.kernel;
        let rows = self.in_channels * k * k;
        let n = oh * ow;
        // im2col: row (c, ky, kx) holds the input sample under that kernel tap for every output pixel.
        let mut cols = vec![0.0f32; rows * n];
        for c in 0..self.in_channels {
            let plane = &x.data[c * x.height * x.width..(c + 1) * x.height * x.width];
            for ky in 0..k {
                for kx in 0..k {
                    let row = &mut cols[((c * k + ky) * k + kx) * n..][..n];
                    for oy in 0..oh {
                        let Some(iy) = (oy * self.stride + ky)
                            .checked_sub(self.padding)
                            .filter(|&v| v < x.height)
                        else {
                            continue;
                        };
                        let src = &plane[iy * x.width..(iy + 1) * x.width];
                        let dst = &mut row[oy * ow..(oy + 1) * ow];
                        for (ox, d) in dst.iter_mut().enumerate() {
                            if let Some(ix) = (ox * self.stride + kx)
                                .checked_sub(self.padding)
                                .filter(|&v| v < x.width)
                            {
                                *d = src[ix];
                            }
                        }
                    }
                }
            }
        }
        let mut out = vec![0.0f32; self.out_channels * n];
        // SAFETY: the slices hold exactly m·k, k·n and m·n elements in row-major
        // order with the strides given, so every access stays in bounds.
        unsafe {
            matrixmultiply::sgemm(
                self.out_channels,
                rows,
                n,
                1.0,
                self.weight.as_ptr(),
                rows as isize,
                1,
                cols.as_ptr(),
                n as isize,
                1,
                0.0,
                out.as_mut_ptr(),
                n as isize,
                1,
            );
        }
        for (plane, &b) in out.chunks_exact_mut(n).zip(&self.bias) {
            plane.iter_mut().for_each(|v| *v = (*v + b).max(0.0));
        }
        Tensor {
            channels: self.out_channels,
            height: oh,
            width: ow,
            data: out,
        }
    }
}

/// 3×3 max pooling with stride 2, no padding, floor rounding (torchvision AlexNet).
/// The caller guarantees at least 3×3 input.
pub fn max_pool_3x3_s2(x: &Tensor) -> Tensor {
    let (oh, ow) = ((x.height - 3) / 2 + 1, (x.width - 3) / 2 + 1);
    let mut data = Vec::with_capacity(x.channels * oh * ow);
    for c in 0..x.channels {
        let plane = &x.data[c * x.height * x.width..(c + 1) * x.height * x.width];
        for oy in 0..oh {
            for ox in 0..ow {
                let mut m = f32::NEG_INFINITY;
                for dy in 0..3 {
                    for dx in 0..3 {
                        m = m.max(plane[(oy * 2 + dy) * x.width + ox * 2 + dx]);
                    }
                }
                data.push(m);
            }
        }
    }
    Tensor {
        channels: x.channels,
        height: oh,
        width: ow,
        data,
    }
}
