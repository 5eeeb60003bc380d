//! COCO run-length encoding (as written by pycocotools, SAM and Grounded-SAM-2).
//!
//! `{"size": [h, w], "counts": …}`: pixels in column-major order (index `x·h + y`),
//! runs alternating 0s and 1s starting with 0s. `counts` is a list of ints
//! (uncompressed) or pycocotools' compressed string: each count (after index 2,
//! the difference to the count two before) in 5-bit groups, least significant first,
//! `0x20` = more groups follow, `0x10` on the last group = negative, each group + 48.

use anyhow::{Result, bail};
use serde_json::Value;

/// A decoded binary mask, row-major (`y·w + x`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BinaryMask {
    pub width: u32,
    pub height: u32,
    pub data: Vec<bool>,
}

impl BinaryMask {
    pub fn area(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }
}

/// Decodes pycocotools' compressed counts string.
pub fn decode_counts_string(s: &str) -> Result<Vec<u64>> {
    let bytes = s.as_bytes();
    let mut counts: Vec<u64> = Vec::new();
    let mut p = 0;
    while p < bytes.len() {
        let start = p;
        let mut x: i64 = 0;
        let mut k = 0u32;
        loop {
            let Some(&b) = bytes.get(p) else {
                bail!("RLE counts string ends inside the count starting at character {start}");
            };
            if !(48..48 + 64).contains(&b) {
                bail!(
                    "RLE counts string has character {:?} at {p}, outside the encoding's range",
                    b as char
                );
            }
            // 12 groups carry 60 bits; anything longer cannot be a pixel count.
            if k >= 12 {
                bail!("RLE count starting at character {start} is too long");
            }
            let c = (b - 48) as i64;
            x |= (c & 0x1f) << (5 * k);
            p += 1;
            k += 1;
            if c & 0x20 == 0 {
                if c & 0x10 != 0 {
                    x |= -1i64 << (5 * k);
                }
                break;
            }
        }
        let m = counts.len();
        if m > 2 {
            x = x
                .checked_add(counts[m - 2] as i64)
                .ok_or_else(|| anyhow::anyhow!("RLE count {m} overflows"))?;
        }
        if x < 0 {
            bail!("RLE count {m} decodes to a negative run length {x}");
        }
        counts.push(x as u64);
    }
    Ok(counts)
}

/// Decodes `{"size": [h, w], "counts": …}`; the runs must cover exactly h·w pixels.
pub fn decode(rle: &Value) -> Result<BinaryMask> {
    let size = rle.get("size").and_then(Value::as_array);
    let (h, w) = match size.map(|s| s.as_slice()) {
        Some([h, w]) => match (h.as_u64(), w.as_u64()) {
            (Some(h), Some(w)) if h <= u32::MAX as u64 && w <= u32::MAX as u64 => {
                (h as u32, w as u32)
            }
            _ => bail!("RLE size {:?} is not two pixel counts", size),
        },
        _ => bail!("RLE has no \"size\": [height, width]"),
    };
    let counts = match rle.get("counts") {
        Some(Value::String(s)) => decode_counts_string(s)?,
        Some(Value::Array(list)) => list
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v.as_u64().ok_or_else(|| {
                    anyhow::anyhow!("RLE count {i} ({v}) is not a non-negative integer")
                })
            })
            .collect::<Result<Vec<_>>>()?,
        _ => bail!("RLE has no \"counts\" string or list"),
    };
    let total = h as u64 * w as u64;
    let sum = counts.iter().try_fold(0u64, |a, &c| a.checked_add(c));
    if sum != Some(total) {
        bail!(
            "RLE runs cover {} pixels but its size is {h}×{w} = {total}",
            sum.map_or("too many".to_string(), |s| s.to_string())
        );
    }
    let mut data = vec![false; total as usize];
    let mut i = 0usize;
    for (r, &c) in counts.iter().enumerate() {
        if r % 2 == 1 {
            for j in i..i + c as usize {
                // Column-major source index → row-major destination.
                let (x, y) = (j / h as usize, j % h as usize);
                data[y * w as usize + x] = true;
            }
        }
        i += c as usize;
    }
    Ok(BinaryMask {
        width: w,
        height: h,
        data,
    })
}
