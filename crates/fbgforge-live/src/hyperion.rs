//! The Luna (Micron Optics) Hyperion peak stream: its framing, decoded and encoded.
//!
//! Protocol facts, from Luna's public Hyperion API (the MIT-licensed Python module
//! `hyperion.py` version 2.0, class `HACQPeaksData` and `HCommTCPStreamer`, and the
//! C++ header `hCommLibrary.h`; see `docs/live.md` for where to read them):
//!
//! * the instrument streams peaks on TCP port **51972** (commands 51971, spectra
//!   51973, sensors 51974);
//! * every message starts with an 8-byte response header, little-endian:
//!   `status: u8` (0 = success), `type: u8` (request option echo),
//!   `message_length: u16`, `content_length: u32`; then `message_length` bytes of
//!   ASCII message, then `content_length` bytes of content;
//! * a peaks content starts with a 24-byte header: `length: u16` (bytes of this header
//!   *including* the peak-count array that follows), `version: u16`, `reserved: u32`,
//!   `serial_number: u64` (consecutive frames count up by one), `timestamp_s: u32`,
//!   `timestamp_ns: u32` (the acquisition time, seconds and nanoseconds of the Unix
//!   epoch); then one `i16` peak count per channel up to `length`; then the peak
//!   wavelengths as `f64` nm, channel after channel.
//!
//! This module is written from those facts, not from the API's code. Decoding never
//! panics: a message that cannot be a peaks frame is an error naming what is wrong,
//! and [`StreamDecoder`] keeps its place in the stream whenever the response header is
//! intact (so one bad frame costs one frame).

use std::fmt;

/// The Hyperion peak-streaming TCP port.
pub const PEAK_STREAM_PORT: u16 = 51972;
/// Bytes of the response header before every message.
pub(crate) const RESPONSE_HEADER_BYTES: usize = 8;
/// Bytes of the peaks header before the peak counts.
pub(crate) const PEAKS_HEADER_BYTES: usize = 24;
/// The largest content accepted, bytes: far above any real frame (16 channels × a few
/// hundred peaks), small enough that a corrupted length cannot exhaust memory.
pub(crate) const MAX_CONTENT_BYTES: usize = 1 << 20;

/// One decoded peaks frame.
#[derive(Debug, Clone, PartialEq)]
pub struct PeaksFrame {
    /// The instrument's frame counter.
    pub serial_number: u64,
    /// Acquisition time, s since 1970-01-01 (instrument clock).
    pub timestamp_s: f64,
    /// Peaks per channel, as the instrument counts them.
    pub peak_counts: Vec<u16>,
    /// Every peak wavelength, nm, channel after channel.
    pub peaks_nm: Vec<f64>,
}

impl PeaksFrame {
    /// The channel (from 0) of each peak.
    #[cfg(test)]
    pub(crate) fn peak_channels(&self) -> Vec<u16> {
        self.peak_counts
            .iter()
            .enumerate()
            .flat_map(|(c, &n)| std::iter::repeat_n(c as u16, n as usize))
            .collect()
    }
}

/// What is wrong with one message of the stream.
#[derive(Debug, Clone, PartialEq)]
pub enum FrameError {
    /// The instrument reported a non-zero status (its message is kept).
    Status {
        /// Status byte.
        status: u8,
        /// The instrument's message.
        message: String,
    },
    /// The content is not a well-formed peaks frame (framing intact, frame lost).
    Malformed {
        /// What is wrong.
        message: String,
        /// The frame's serial number, when its header could be read: the frame is
        /// then counted once, as bad, and not again as a gap in the serials.
        serial: Option<u64>,
    },
    /// The response header announces an impossible length: the stream's framing is lost
    /// and the connection must be reopened.
    FramingLost(String),
    /// The sender says the stream has ended (its message is kept): a finite stream
    /// such as `fbgforge synth-stream` after its duration ([`encode_end_of_stream`]).
    /// A Hyperion streams until it is switched off and never sends it.
    EndOfStream(String),
}

impl FrameError {
    /// Warning kind used when counting bad frames.
    pub fn kind(&self) -> &'static str {
        match self {
            FrameError::Status { .. } => "instrument_status",
            FrameError::Malformed { .. } => "malformed_frame",
            FrameError::FramingLost(_) => "framing_lost",
            FrameError::EndOfStream(_) => "end_of_stream",
        }
    }
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::Status { status, message } => {
                write!(f, "instrument status {status}: {message}")
            }
            FrameError::Malformed { message: m, .. }
            | FrameError::FramingLost(m)
            | FrameError::EndOfStream(m) => f.write_str(m),
        }
    }
}

fn u16_at(b: &[u8], i: usize) -> u16 {
    u16::from_le_bytes([b[i], b[i + 1]])
}

fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

/// Decode the content of one peaks message.
pub(crate) fn decode_peaks(content: &[u8]) -> Result<PeaksFrame, FrameError> {
    let bad = |message: String| {
        // The serial number sits at bytes 8..16 of an intact header.
        let serial = (content.len() >= PEAKS_HEADER_BYTES).then(|| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&content[8..16]);
            u64::from_le_bytes(b)
        });
        Err(FrameError::Malformed { message, serial })
    };
    if content.len() < PEAKS_HEADER_BYTES {
        return bad(format!(
            "peaks content of {} bytes is shorter than the {PEAKS_HEADER_BYTES}-byte peaks header",
            content.len()
        ));
    }
    let length = u16_at(content, 0) as usize;
    if length < PEAKS_HEADER_BYTES
        || length > content.len()
        || !(length - PEAKS_HEADER_BYTES).is_multiple_of(2)
    {
        return bad(format!(
            "peaks header length {length} is impossible (content {} bytes; expected 24 + 2 per channel)",
            content.len()
        ));
    }
    let mut serial = [0u8; 8];
    serial.copy_from_slice(&content[8..16]);
    let serial_number = u64::from_le_bytes(serial);
    let timestamp_s = u32_at(content, 16) as f64 + u32_at(content, 20) as f64 * 1e-9;
    let channels = (length - PEAKS_HEADER_BYTES) / 2;
    let mut peak_counts = Vec::with_capacity(channels);
    for c in 0..channels {
        let n = i16::from_le_bytes([
            content[PEAKS_HEADER_BYTES + 2 * c],
            content[PEAKS_HEADER_BYTES + 2 * c + 1],
        ]);
        if n < 0 {
            return bad(format!(
                "serial {serial_number}: channel {} reports {n} peaks",
                c + 1
            ));
        }
        peak_counts.push(n as u16);
    }
    let announced: usize = peak_counts.iter().map(|&n| n as usize).sum();
    let data = &content[length..];
    if data.len() != announced * 8 {
        return bad(format!(
            "serial {serial_number}: the peak counts announce {announced} peaks but the frame carries {} bytes ({} peaks)",
            data.len(),
            data.len() as f64 / 8.0
        ));
    }
    let mut peaks_nm = Vec::with_capacity(announced);
    for (i, chunk) in data.chunks_exact(8).enumerate() {
        let mut v = [0u8; 8];
        v.copy_from_slice(chunk);
        let w = f64::from_le_bytes(v);
        if !w.is_finite() {
            return bad(format!(
                "serial {serial_number}: peak {} is {w}, not a wavelength",
                i + 1
            ));
        }
        peaks_nm.push(w);
    }
    Ok(PeaksFrame {
        serial_number,
        timestamp_s,
        peak_counts,
        peaks_nm,
    })
}

/// How the message that ends a finite stream begins ([`encode_end_of_stream`]).
pub const END_OF_STREAM: &str = "end of stream";

/// The message a finite stream ends with: status 0, no content, and an ASCII message
/// `end of stream: <why>`. Not part of Luna's protocol (an instrument streams until it
/// is switched off); `fbgforge synth-stream` sends it after its duration so that a
/// reader can tell a stream that ended from a connection that dropped.
pub fn encode_end_of_stream(why: &str) -> Vec<u8> {
    let text = format!("{END_OF_STREAM}: {why}");
    let text = &text.as_bytes()[..text.len().min(u16::MAX as usize)];
    let mut out = Vec::with_capacity(RESPONSE_HEADER_BYTES + text.len());
    out.extend_from_slice(&[0, 0]);
    out.extend_from_slice(&(text.len() as u16).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(text);
    out
}

/// Encode a peaks frame as one stream message (response header + content), the way
/// the instrument sends it. Used by the simulated interrogator.
pub fn encode_peaks(frame: &PeaksFrame) -> Vec<u8> {
    let channels = frame.peak_counts.len();
    let length = PEAKS_HEADER_BYTES + 2 * channels;
    let content_len = length + 8 * frame.peaks_nm.len();
    let mut out = Vec::with_capacity(RESPONSE_HEADER_BYTES + content_len);
    out.push(0); // status: success
    out.push(0); // request option echo
    out.extend_from_slice(&0u16.to_le_bytes()); // no message
    out.extend_from_slice(&(content_len as u32).to_le_bytes());
    out.extend_from_slice(&(length as u16).to_le_bytes());
    out.extend_from_slice(&1u16.to_le_bytes()); // version
    out.extend_from_slice(&0u32.to_le_bytes()); // reserved
    out.extend_from_slice(&frame.serial_number.to_le_bytes());
    let secs = frame.timestamp_s.max(0.0).floor();
    let nanos = ((frame.timestamp_s.max(0.0) - secs) * 1e9)
        .round()
        .min(999_999_999.0);
    out.extend_from_slice(&(secs as u32).to_le_bytes());
    out.extend_from_slice(&(nanos as u32).to_le_bytes());
    for &n in &frame.peak_counts {
        out.extend_from_slice(&(n as i16).to_le_bytes());
    }
    for &w in &frame.peaks_nm {
        out.extend_from_slice(&w.to_le_bytes());
    }
    out
}

/// Splits a byte stream into messages and decodes each as a peaks frame. Feed it
/// whatever the socket returned; take out every complete message.
#[derive(Debug, Default)]
pub struct StreamDecoder {
    buf: Vec<u8>,
    start: usize,
}

impl StreamDecoder {
    /// An empty decoder (at the start of a connection).
    pub fn new() -> Self {
        StreamDecoder::default()
    }

    /// Append bytes read from the connection.
    pub fn push(&mut self, bytes: &[u8]) {
        if self.start > 0 && self.start == self.buf.len() {
            self.buf.clear();
            self.start = 0;
        } else if self.start > (1 << 16) {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        self.buf.extend_from_slice(bytes);
    }

    /// Bytes received but not yet part of a complete message.
    #[cfg(test)]
    pub(crate) fn pending_bytes(&self) -> usize {
        self.buf.len() - self.start
    }

    /// The next complete message, decoded; `None` when more bytes are needed. After a
    /// [`FrameError::FramingLost`] the decoder must be dropped with the connection.
    pub fn next_frame(&mut self) -> Option<Result<PeaksFrame, FrameError>> {
        let b = &self.buf[self.start..];
        if b.len() < RESPONSE_HEADER_BYTES {
            return None;
        }
        let status = b[0];
        let message_len = u16_at(b, 2) as usize;
        let content_len = u32_at(b, 4) as usize;
        if content_len > MAX_CONTENT_BYTES {
            return Some(Err(FrameError::FramingLost(format!(
                "a message announces {content_len} bytes of content (at most {MAX_CONTENT_BYTES} expected): the stream is not a Hyperion peak stream or lost its framing"
            ))));
        }
        let total = RESPONSE_HEADER_BYTES + message_len + content_len;
        if b.len() < total {
            return None;
        }
        let message = &b[RESPONSE_HEADER_BYTES..RESPONSE_HEADER_BYTES + message_len];
        let content = &b[RESPONSE_HEADER_BYTES + message_len..total];
        let result = if status != 0 {
            Err(FrameError::Status {
                status,
                message: String::from_utf8_lossy(message).trim().to_string(),
            })
        } else if content.is_empty() && message.starts_with(END_OF_STREAM.as_bytes()) {
            Err(FrameError::EndOfStream(
                String::from_utf8_lossy(message).trim().to_string(),
            ))
        } else {
            decode_peaks(content)
        };
        self.start += total;
        Some(result)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> PeaksFrame {
        PeaksFrame {
            serial_number: 123_456_789_012,
            timestamp_s: 1_700_000_000.25,
            peak_counts: vec![2, 0, 1],
            peaks_nm: vec![1520.807, 1523.55, 1550.125],
        }
    }

    #[test]
    fn encoded_layout_matches_the_protocol_byte_for_byte() {
        let b = encode_peaks(&frame());
        // Response header: status 0, echo 0, no message, content length.
        let content_len = 24 + 2 * 3 + 8 * 3;
        assert_eq!(b.len(), 8 + content_len);
        assert_eq!(&b[..4], &[0, 0, 0, 0]);
        assert_eq!(u32_at(&b, 4) as usize, content_len);
        let c = &b[8..];
        assert_eq!(u16_at(c, 0), 30); // 24-byte header + 3 i16 counts
        assert_eq!(&c[8..16], &123_456_789_012u64.to_le_bytes());
        assert_eq!(u32_at(c, 16), 1_700_000_000);
        assert_eq!(u32_at(c, 20), 250_000_000);
        assert_eq!(&c[24..30], &[2, 0, 0, 0, 1, 0]);
        assert_eq!(&c[30..38], &1520.807f64.to_le_bytes());
    }

    #[test]
    fn a_stream_cut_anywhere_decodes_to_the_same_frames() {
        let mut f2 = frame();
        f2.serial_number += 1;
        f2.peak_counts = vec![0, 0, 0];
        f2.peaks_nm.clear();
        let mut bytes = encode_peaks(&frame());
        bytes.extend(encode_peaks(&f2));
        for cut in 0..bytes.len() {
            let mut d = StreamDecoder::new();
            let mut got = Vec::new();
            d.push(&bytes[..cut]);
            while let Some(r) = d.next_frame() {
                got.push(r.unwrap());
            }
            d.push(&bytes[cut..]);
            while let Some(r) = d.next_frame() {
                got.push(r.unwrap());
            }
            assert_eq!(got, vec![frame(), f2.clone()], "cut at {cut}");
            assert_eq!(d.pending_bytes(), 0);
        }
        assert_eq!(frame().peak_channels(), vec![0, 0, 2]);
    }

    #[test]
    fn bad_frames_are_named_and_the_next_frame_still_decodes() {
        // Counts announce 3 peaks, the content holds 2.
        let mut short = encode_peaks(&frame());
        short.truncate(short.len() - 8);
        let len = (u32_at(&short, 4) - 8).to_le_bytes();
        short[4..8].copy_from_slice(&len);
        // A NaN wavelength.
        let mut nan = frame();
        nan.peaks_nm[1] = f64::NAN;
        // A status error with a message.
        let mut status = vec![3u8, 0];
        status.extend_from_slice(&5u16.to_le_bytes());
        status.extend_from_slice(&0u32.to_le_bytes());
        status.extend_from_slice(b"busy!");
        let mut bytes = short;
        bytes.extend(encode_peaks(&nan));
        bytes.extend(status);
        bytes.extend(encode_peaks(&frame()));
        let mut d = StreamDecoder::new();
        d.push(&bytes);
        let e1 = d.next_frame().unwrap().unwrap_err();
        assert!(e1.to_string().contains("announce 3 peaks"), "{e1}");
        let e2 = d.next_frame().unwrap().unwrap_err();
        assert!(e2.to_string().contains("peak 2 is NaN"), "{e2}");
        // Both headers were intact: their serials are known, so neither frame also
        // counts as a gap in the serials.
        for e in [&e1, &e2] {
            assert!(
                matches!(
                    e,
                    FrameError::Malformed {
                        serial: Some(123_456_789_012),
                        ..
                    }
                ),
                "{e:?}"
            );
        }
        let e3 = d.next_frame().unwrap().unwrap_err();
        assert_eq!(e3.to_string(), "instrument status 3: busy!");
        assert_eq!(d.next_frame().unwrap().unwrap(), frame());
        assert!(d.next_frame().is_none());
    }

    #[test]
    fn the_end_of_a_finite_stream_is_told_apart_from_an_empty_frame() {
        let mut bytes = encode_peaks(&frame());
        bytes.extend(encode_end_of_stream("10 s served"));
        // An empty content without the end message is a malformed frame.
        let mut empty = vec![0u8, 0];
        empty.extend_from_slice(&0u16.to_le_bytes());
        empty.extend_from_slice(&0u32.to_le_bytes());
        bytes.extend(&empty);
        let mut d = StreamDecoder::new();
        d.push(&bytes);
        assert_eq!(d.next_frame().unwrap().unwrap(), frame());
        match d.next_frame().unwrap() {
            Err(FrameError::EndOfStream(m)) => assert_eq!(m, "end of stream: 10 s served"),
            other => panic!("{other:?}"),
        }
        let e = d.next_frame().unwrap().unwrap_err();
        assert!(
            matches!(e, FrameError::Malformed { serial: None, .. }),
            "{e:?}"
        );
        assert!(d.next_frame().is_none());
    }

    #[test]
    fn an_absurd_length_loses_the_framing() {
        let mut d = StreamDecoder::new();
        d.push(&[0, 0, 0, 0, 0xff, 0xff, 0xff, 0x7f]);
        let e = d.next_frame().unwrap().unwrap_err();
        assert_eq!(e.kind(), "framing_lost");
        assert!(decode_peaks(&[0u8; 10]).is_err());
        let mut neg = encode_peaks(&frame())[8..].to_vec();
        neg[26..28].copy_from_slice(&(-1i16).to_le_bytes());
        assert!(decode_peaks(&neg)
            .unwrap_err()
            .to_string()
            .contains("channel 2 reports -1 peaks"));
    }
}
