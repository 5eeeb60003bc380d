//! Bounds-checked little-endian reading of untrusted binary files.
//!
//! Every read names the file, the byte offset and what was being read; counts
//! read from the file are checked against the bytes left before anything is
//! allocated for them.

use anyhow::{Result, bail};
use std::path::Path;

pub struct ByteReader<'a> {
    data: &'a [u8],
    pos: usize,
    file: &'a Path,
}

impl<'a> ByteReader<'a> {
    pub fn new(data: &'a [u8], file: &'a Path) -> ByteReader<'a> {
        ByteReader { data, pos: 0, file }
    }

    pub fn position(&self) -> usize {
        self.pos
    }

    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    pub fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if n > self.remaining() {
            bail!(
                "{}: byte {}: file ends while reading {what} (needs {n} bytes, {} remain)",
                self.file.display(),
                self.pos,
                self.remaining()
            );
        }
        let bytes = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(bytes)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N]> {
        let bytes = self.take(N, what)?;
        // `take` returned exactly N bytes.
        Ok(bytes.try_into().expect("take returns the requested length"))
    }

    pub fn u8(&mut self, what: &str) -> Result<u8> {
        Ok(self.array::<1>(what)?[0])
    }

    pub fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub fn i32(&mut self, what: &str) -> Result<i32> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    pub fn u64(&mut self, what: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    pub fn i64(&mut self, what: &str) -> Result<i64> {
        Ok(i64::from_le_bytes(self.array(what)?))
    }

    pub fn f64(&mut self, what: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }

    pub fn f64s<const N: usize>(&mut self, what: &str) -> Result<[f64; N]> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64(what)?;
        }
        Ok(out)
    }

    /// A `u64` count of records that each take at least `min_record_bytes`; refused
    /// when the rest of the file cannot hold that many.
    pub fn count(&mut self, what: &str, min_record_bytes: usize) -> Result<usize> {
        let at = self.pos;
        let n = self.u64(what)?;
        let fits = (n as u128) * (min_record_bytes as u128) <= self.remaining() as u128;
        if !fits {
            bail!(
                "{}: byte {at}: {what} is {n}, but {n} records of at least {min_record_bytes} bytes do not fit in the {} bytes left",
                self.file.display(),
                self.remaining()
            );
        }
        Ok(n as usize)
    }

    /// A count (checked as by [`count`](Self::count)), then that many items read by `item`.
    pub fn list<T>(
        &mut self,
        what: &str,
        min_item_bytes: usize,
        mut item: impl FnMut(&mut Self) -> Result<T>,
    ) -> Result<Vec<T>> {
        let n = self.count(what, min_item_bytes)?;
        let mut items = Vec::with_capacity(n);
        for _ in 0..n {
            items.push(item(self)?);
        }
        Ok(items)
    }

    /// A NUL-terminated UTF-8 string.
    pub fn c_string(&mut self, what: &str) -> Result<String> {
        let at = self.pos;
        let Some(len) = self.data[self.pos..].iter().position(|&b| b == 0) else {
            bail!(
                "{}: byte {at}: {what} has no terminating NUL before the end of the file",
                self.file.display()
            );
        };
        let bytes = self.take(len, what)?;
        self.pos += 1;
        match std::str::from_utf8(bytes) {
            Ok(s) => Ok(s.to_string()),
            Err(_) => bail!("{}: byte {at}: {what} is not UTF-8", self.file.display()),
        }
    }

    /// Fails unless the whole file was consumed (trailing bytes mean a misread layout).
    pub fn finish(&self) -> Result<()> {
        if self.remaining() != 0 {
            bail!(
                "{}: byte {}: {} unexpected bytes after the last record",
                self.file.display(),
                self.pos,
                self.remaining()
            );
        }
        Ok(())
    }
}
