//! Plain CDR (XCDR1, as ROS 2 writes it through Fast-CDR), little-endian.
//!
//! The rules this writer and reader follow:
//!
//! * a message starts with the 4-byte encapsulation header `00 01 00 00`
//!   (representation `CDR_LE` = 0x0001, options 0);
//! * every primitive of size n (2, 4 or 8 bytes) starts at an offset that is a multiple
//!   of n, **counted from the end of the encapsulation header** (the header's 4 bytes
//!   are not part of the alignment origin); the gap is filled with zero bytes; XCDR1
//!   aligns a `float64` to 8 (XCDR2 would stop at 4: ROS 2 uses XCDR1);
//! * a `string` is a `uint32` length that counts the terminating NUL, the UTF-8 bytes,
//!   then the NUL; the empty string is length 1 and a lone NUL (Fast-CDR's form);
//!   nothing aligns the end of a string, so the next field's own alignment pads;
//! * a sequence (`T[]`) is a `uint32` element count, then the elements, each aligned
//!   as itself (an empty sequence of `float64` adds no padding after its count);
//! * a nested message is its fields in order, with no padding of its own;
//! * no padding is added at the end of a message.

use std::fmt;

/// The encapsulation header of a little-endian plain-CDR message.
pub const ENCAPSULATION_CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Writes one CDR message: the encapsulation header, then fields in order.
#[derive(Debug, Clone)]
pub struct CdrWriter {
    buf: Vec<u8>,
}

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl CdrWriter {
    /// A message holding only its encapsulation header.
    pub fn new() -> Self {
        let mut buf = Vec::with_capacity(64);
        buf.extend_from_slice(&ENCAPSULATION_CDR_LE);
        Self { buf }
    }

    /// Zero bytes up to the next multiple of `size` from the end of the header.
    fn align(&mut self, size: usize) {
        let offset = self.buf.len() - ENCAPSULATION_CDR_LE.len();
        let pad = (size - offset % size) % size;
        self.buf.resize(self.buf.len() + pad, 0);
    }

    /// An `int32`.
    pub fn write_i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `uint32`.
    pub fn write_u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `float64`.
    pub fn write_f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `string`: length with the NUL, bytes, NUL.
    ///
    /// # Panics
    /// When the string is 4 GiB or longer (no ROS 2 string is).
    pub fn write_string(&mut self, s: &str) {
        let len = u32::try_from(s.len() + 1).expect("a CDR string shorter than 4 GiB");
        self.write_u32(len);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// A sequence's element count.
    ///
    /// # Panics
    /// When `n` does not fit a `uint32`.
    pub fn write_sequence_len(&mut self, n: usize) {
        self.write_u32(u32::try_from(n).expect("a CDR sequence of fewer than 2^32 elements"));
    }

    /// A `float64[]`: count, then each value aligned to 8.
    pub fn write_f64_sequence(&mut self, values: &[f64]) {
        self.write_sequence_len(values.len());
        for &v in values {
            self.write_f64(v);
        }
    }

    /// The message's bytes, header included.
    pub fn into_bytes(self) -> Vec<u8> {
        self.buf
    }
}

/// Why CDR bytes could not be read back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CdrError {
    /// Shorter than the field being read (at this offset from the message start).
    Truncated {
        /// Offset from the start of the message, header included.
        offset: usize,
    },
    /// Not the little-endian plain-CDR header `00 01 00 00`.
    Encapsulation([u8; 4]),
    /// A string without its NUL, or not UTF-8.
    BadString {
        /// Offset of the string's length field.
        offset: usize,
    },
    /// Bytes left over after the message's last field.
    TrailingBytes {
        /// How many.
        count: usize,
    },
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CdrError::Truncated { offset } => write!(f, "CDR message truncated at byte {offset}"),
            CdrError::Encapsulation(h) => {
                write!(f, "CDR encapsulation header {h:02x?} is not 00 01 00 00")
            }
            CdrError::BadString { offset } => {
                write!(
                    f,
                    "CDR string at byte {offset} lacks its NUL or is not UTF-8"
                )
            }
            CdrError::TrailingBytes { count } => {
                write!(f, "{count} bytes after the CDR message's last field")
            }
        }
    }
}

impl std::error::Error for CdrError {}

/// Reads a message written by [`CdrWriter`] (or by ROS 2) back, with the same rules.
#[derive(Debug, Clone)]
pub struct CdrReader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> CdrReader<'a> {
    /// Checks the encapsulation header and stands after it.
    pub fn new(data: &'a [u8]) -> Result<Self, CdrError> {
        let head: [u8; 4] = data
            .get(..4)
            .and_then(|h| h.try_into().ok())
            .ok_or(CdrError::Truncated { offset: 0 })?;
        if head != ENCAPSULATION_CDR_LE {
            return Err(CdrError::Encapsulation(head));
        }
        Ok(Self { data, pos: 4 })
    }

    fn align(&mut self, size: usize) {
        let offset = self.pos - ENCAPSULATION_CDR_LE.len();
        self.pos += (size - offset % size) % size;
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        let bytes = self
            .data
            .get(self.pos..self.pos + N)
            .ok_or(CdrError::Truncated { offset: self.pos })?;
        self.pos += N;
        Ok(bytes.try_into().expect("N bytes"))
    }

    /// An `int32`.
    pub fn read_i32(&mut self) -> Result<i32, CdrError> {
        self.align(4);
        Ok(i32::from_le_bytes(self.take()?))
    }

    /// A `uint32`.
    pub fn read_u32(&mut self) -> Result<u32, CdrError> {
        self.align(4);
        Ok(u32::from_le_bytes(self.take()?))
    }

    /// A `float64`.
    pub fn read_f64(&mut self) -> Result<f64, CdrError> {
        self.align(8);
        Ok(f64::from_le_bytes(self.take()?))
    }

    /// A `string` (length 0 is accepted as the empty string too).
    pub fn read_string(&mut self) -> Result<String, CdrError> {
        let at = self.pos;
        let len = self.read_u32()? as usize;
        if len == 0 {
            return Ok(String::new());
        }
        let bytes = self
            .data
            .get(self.pos..self.pos + len)
            .ok_or(CdrError::Truncated { offset: self.pos })?;
        let (nul, text) = bytes.split_last().expect("len >= 1");
        if *nul != 0 {
            return Err(CdrError::BadString { offset: at });
        }
        let s = std::str::from_utf8(text).map_err(|_| CdrError::BadString { offset: at })?;
        self.pos += len;
        Ok(s.to_owned())
    }

    /// A sequence's element count (checked against the bytes left, `min_elem_bytes` each).
    pub fn read_sequence_len(&mut self, min_elem_bytes: usize) -> Result<usize, CdrError> {
        let at = self.pos;
        let n = self.read_u32()? as usize;
        if n.saturating_mul(min_elem_bytes) > self.data.len() - self.pos {
            return Err(CdrError::Truncated { offset: at });
        }
        Ok(n)
    }

    /// A `float64[]`.
    pub fn read_f64_sequence(&mut self) -> Result<Vec<f64>, CdrError> {
        let n = self.read_sequence_len(8)?;
        (0..n).map(|_| self.read_f64()).collect()
    }

    /// Fails when bytes are left after the last field.
    pub fn finish(self) -> Result<(), CdrError> {
        match self.data.len() - self.pos {
            0 => Ok(()),
            count => Err(CdrError::TrailingBytes { count }),
        }
    }
}
