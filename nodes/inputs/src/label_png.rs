//! Reading label PNGs as stored values: palette *indices* of indexed PNGs (never their
//! colours), grey values of 8/16-bit grey PNGs.

use anyhow::{Context, Result, bail};
use std::path::Path;

/// A PNG's stored values, row-major.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Labels {
    pub width: u32,
    pub height: u32,
    pub data: Vec<u16>,
    /// True when the values are palette indices.
    pub indexed: bool,
}

pub fn read(path: &Path) -> Result<Labels> {
    let file =
        std::fs::File::open(path).with_context(|| format!("{}: cannot open", path.display()))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder
        .read_info()
        .with_context(|| format!("{}: not a PNG", path.display()))?;
    let size = reader
        .output_buffer_size()
        .with_context(|| format!("{}: image too large", path.display()))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .with_context(|| format!("{}: cannot decode", path.display()))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let depth = info.bit_depth as usize;
    let indexed = match info.color_type {
        png::ColorType::Indexed => true,
        png::ColorType::Grayscale => false,
        other => bail!(
            "{}: is {other:?}; a label map must be an indexed (palette) or grey PNG",
            path.display()
        ),
    };
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        let row = &buf[y * info.line_size..(y + 1) * info.line_size];
        for x in 0..w {
            let v = match depth {
                16 => u16::from_be_bytes([row[2 * x], row[2 * x + 1]]),
                8 => row[x] as u16,
                // Sub-byte depths pack pixels from the most significant bits.
                d => {
                    let per_byte = 8 / d;
                    let byte = row[x / per_byte];
                    let shift = 8 - d * (x % per_byte + 1);
                    ((byte >> shift) & ((1u8 << d) - 1)) as u16
                }
            };
            data.push(v);
        }
    }
    Ok(Labels {
        width: info.width,
        height: info.height,
        data,
        indexed,
    })
}
