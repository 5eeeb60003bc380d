//! Reading 2-D integer arrays from NumPy `.npy` files (format versions 1–3).

use anyhow::{Context, Result};
use std::path::Path;

/// A row-major 2-D array of non-negative integers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IdArray {
    pub height: u32,
    pub width: u32,
    pub data: Vec<u64>,
}

pub fn read(path: &Path) -> Result<IdArray> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    parse(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// Value of `key` in the header dict text (`'descr': '<u2'`, `'shape': (4, 5)`).
fn header_field<'a>(header: &'a str, key: &str) -> Result<&'a str, String> {
    let pat = format!("'{key}':");
    let start = header
        .find(&pat)
        .ok_or_else(|| format!("npy header has no {key}"))?
        + pat.len();
    let rest = header[start..].trim_start();
    let end = if rest.starts_with('(') {
        rest.find(')').map(|i| i + 1)
    } else if let Some(q) = rest.strip_prefix('\'') {
        q.find('\'').map(|i| i + 2)
    } else {
        rest.find([',', '}'])
    };
    Ok(rest[..end.ok_or_else(|| format!("npy header field {key} is not closed"))?].trim())
}

pub fn parse(bytes: &[u8]) -> Result<IdArray, String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a .npy file (bad magic)".into());
    }
    let (header_len, header_start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10usize),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy version {v}")),
    };
    let header = bytes
        .get(header_start..header_start.saturating_add(header_len))
        .ok_or("npy header runs past the end of the file")?;
    let header = std::str::from_utf8(header).map_err(|_| "npy header is not text")?;
    let descr = header_field(header, "descr")?.trim_matches('\'');
    let fortran = header_field(header, "fortran_order")? == "True";
    let shape: Vec<u64> = header_field(header, "shape")?
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<u64>()
                .map_err(|_| format!("npy shape entry {s:?} is not a size"))
        })
        .collect::<Result<_, _>>()?;
    let (h, w) = match shape.as_slice() {
        [h, w] | [1, h, w] | [h, w, 1] => (*h, *w),
        other => return Err(format!("expected a 2-D id map, found shape {other:?}")),
    };
    if h > u32::MAX as u64 || w > u32::MAX as u64 {
        return Err(format!("shape {h}×{w} is too large"));
    }
    let (little, kind, size) = match descr.as_bytes() {
        [
            order @ (b'<' | b'>' | b'|' | b'='),
            kind @ (b'u' | b'i' | b'b'),
            size @ ..,
        ] => {
            let size: usize = std::str::from_utf8(size)
                .ok()
                .and_then(|s| s.parse().ok())
                .unwrap_or(0);
            (*order != b'>', *kind, size)
        }
        _ => return Err(format!("dtype {descr:?} is not an integer type")),
    };
    if !matches!(size, 1 | 2 | 4 | 8) {
        return Err(format!("dtype {descr:?} has an unsupported item size"));
    }
    let body = &bytes[header_start + header_len..];
    let n = h
        .checked_mul(w)
        .and_then(|n| n.checked_mul(size as u64))
        .ok_or("array size overflows")?;
    if body.len() as u64 != n {
        return Err(format!(
            "shape {h}×{w} of {descr} needs {n} data bytes but the file has {}",
            body.len()
        ));
    }
    let mut data = Vec::with_capacity((h * w) as usize);
    for (i, item) in body.chunks_exact(size).enumerate() {
        let mut buf = [0u8; 8];
        if little {
            buf[..size].copy_from_slice(item);
        } else {
            for (k, b) in item.iter().rev().enumerate() {
                buf[k] = *b;
            }
        }
        let signed = kind == b'i' && item[if little { size - 1 } else { 0 }] & 0x80 != 0;
        if signed {
            return Err(format!("item {i} is negative; ids must be ≥ 0"));
        }
        data.push(u64::from_le_bytes(buf));
    }
    if fortran {
        // Column-major on disk: element (y, x) sits at x·h + y.
        let mut rows = vec![0u64; data.len()];
        for x in 0..w as usize {
            for y in 0..h as usize {
                rows[y * w as usize + x] = data[x * h as usize + y];
            }
        }
        data = rows;
    }
    Ok(IdArray {
        height: h as u32,
        width: w as u32,
        data,
    })
}
