//! Framing: `0x00, COBS(postcard(message) ++ crc32_le(postcard(message))), 0x00`.
//!
//! - postcard serialises the message (serde); CRC-32/ISO-HDLC (the `crc` crate)
//!   covers those bytes and is appended little-endian; COBS (the `cobs` crate)
//!   removes every zero byte, so 0x00 delimits frames.
//! - The leading 0x00 isolates garbage sent before a frame; an empty chunk (two
//!   0x00 in a row) is ignored.
//! - At most [`MAX_FRAME_BYTES`] encoded bytes between delimiters; a longer chunk
//!   is reported once as [`FrameError::Oversize`] at its closing 0x00 and its bytes
//!   are dropped meanwhile, so the decoder never stalls and never allocates.

use crc::{CRC_32_ISO_HDLC, Crc};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The most encoded bytes between two delimiters.
pub const MAX_FRAME_BYTES: usize = 320;
/// Bytes of the CRC trailer.
pub const CRC_BYTES: usize = 4;
/// The most payload (postcard) bytes a frame can carry: COBS adds at least one
/// byte, and one per 254.
pub const MAX_PAYLOAD_BYTES: usize = MAX_FRAME_BYTES - 2 - CRC_BYTES;
/// The longest wire frame, both delimiters included.
pub const MAX_WIRE_BYTES: usize = MAX_FRAME_BYTES + 2;

/// The frame check: CRC-32/ISO-HDLC (the CRC of Ethernet and zlib).
const CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

/// Why a received frame could not be turned into a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// More than [`MAX_FRAME_BYTES`] (or the decoder's capacity) between delimiters.
    Oversize,
    /// Not valid COBS.
    Cobs,
    /// The CRC does not match the payload.
    Crc,
    /// Shorter than the CRC.
    Truncated,
    /// The payload is not a postcard-encoded message of the expected type, or it
    /// has bytes left over.
    Decode,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FrameError::Oversize => "frame longer than the limit",
            FrameError::Cobs => "invalid COBS encoding",
            FrameError::Crc => "CRC mismatch",
            FrameError::Truncated => "frame shorter than its CRC",
            FrameError::Decode => "payload is not a valid message",
        })
    }
}

impl core::error::Error for FrameError {}

/// Why a message could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The output buffer is shorter than the wire frame.
    BufferTooSmall,
    /// The message does not fit in [`MAX_FRAME_BYTES`] or postcard failed.
    TooLong,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            EncodeError::BufferTooSmall => "output buffer too small for the frame",
            EncodeError::TooLong => "message longer than a frame can carry",
        })
    }
}

impl core::error::Error for EncodeError {}

/// Writes the whole wire frame of `message` (both 0x00 delimiters) to `out` and
/// returns its length. `out` of [`MAX_WIRE_BYTES`] always suffices.
pub fn encode<M: Serialize>(message: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
    let mut payload = [0u8; MAX_PAYLOAD_BYTES + CRC_BYTES];
    let length = postcard::to_slice(message, &mut payload[..MAX_PAYLOAD_BYTES])
        .map_err(|_| EncodeError::TooLong)?
        .len();
    // Every slice taken with `get`: no index can panic (the frame path's
    // answers are encoded here; firmware/README.md, "No panic in flight").
    let body = payload.get(..length).ok_or(EncodeError::TooLong)?;
    let crc = crc32(body).to_le_bytes();
    payload
        .get_mut(length..length + CRC_BYTES)
        .ok_or(EncodeError::TooLong)?
        .copy_from_slice(&crc);
    let raw = payload
        .get(..length + CRC_BYTES)
        .ok_or(EncodeError::TooLong)?;
    let encoded_max = cobs::max_encoding_length(raw.len());
    if encoded_max > MAX_FRAME_BYTES {
        return Err(EncodeError::TooLong);
    }
    let frame = out
        .get_mut(..encoded_max + 2)
        .ok_or(EncodeError::BufferTooSmall)?;
    let (start, rest) = frame.split_first_mut().ok_or(EncodeError::BufferTooSmall)?;
    *start = 0;
    let encoded = cobs::try_encode(
        raw,
        rest.get_mut(..encoded_max)
            .ok_or(EncodeError::BufferTooSmall)?,
    )
    .map_err(|_| EncodeError::BufferTooSmall)?;
    *rest.get_mut(encoded).ok_or(EncodeError::BufferTooSmall)? = 0;
    Ok(encoded + 2)
}

/// [`encode`] into a new vector (host only).
#[cfg(feature = "std")]
pub fn encode_vec<M: Serialize>(message: &M) -> Result<std::vec::Vec<u8>, EncodeError> {
    let mut out = [0u8; MAX_WIRE_BYTES];
    let length = encode(message, &mut out)?;
    Ok(out[..length].to_vec())
}

/// Collects received bytes into frames and decodes them; `CAP` bytes of buffer
/// (frames longer than `CAP` or [`MAX_FRAME_BYTES`] are [`FrameError::Oversize`]).
#[derive(Clone, Debug)]
pub struct Decoder<const CAP: usize> {
    buffer: [u8; CAP],
    length: usize,
    oversize: bool,
}

/// The decoder the link uses: room for the longest frame.
pub type FrameDecoder = Decoder<MAX_FRAME_BYTES>;

impl<const CAP: usize> Default for Decoder<CAP> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const CAP: usize> Decoder<CAP> {
    /// An empty decoder.
    pub const fn new() -> Self {
        Decoder {
            buffer: [0; CAP],
            length: 0,
            oversize: false,
        }
    }

    /// Bytes of the chunk received so far (not yet closed by 0x00).
    pub fn pending(&self) -> usize {
        self.length
    }

    /// Feeds one received byte. At a 0x00 that closes a non-empty chunk it returns
    /// the decoded message or the reason it could not be decoded; otherwise `None`.
    pub fn push<M: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<M, FrameError>> {
        if byte != 0 {
            if self.oversize {
                return None;
            }
            if self.length >= CAP.min(MAX_FRAME_BYTES) {
                self.oversize = true;
                self.length = 0;
                return None;
            }
            self.buffer[self.length] = byte;
            self.length += 1;
            return None;
        }
        let (length, oversize) = (self.length, self.oversize);
        self.length = 0;
        self.oversize = false;
        if oversize {
            return Some(Err(FrameError::Oversize));
        }
        if length == 0 {
            return None;
        }
        // length <= CAP by the push above; `get_mut` makes it no panic.
        Some(match self.buffer.get_mut(..length) {
            Some(chunk) => decode_chunk(chunk),
            None => Err(FrameError::Oversize),
        })
    }

    /// Feeds `bytes`, calling `on_frame` for every frame they close.
    pub fn push_slice<M: DeserializeOwned>(
        &mut self,
        bytes: &[u8],
        mut on_frame: impl FnMut(Result<M, FrameError>),
    ) {
        for &byte in bytes {
            if let Some(frame) = self.push(byte) {
                on_frame(frame);
            }
        }
    }
}

/// Decodes one COBS chunk (no delimiters) in place.
fn decode_chunk<M: DeserializeOwned>(chunk: &mut [u8]) -> Result<M, FrameError> {
    let length = cobs::decode_in_place(chunk).map_err(|_| FrameError::Cobs)?;
    let raw = chunk.get(..length).ok_or(FrameError::Cobs)?;
    if raw.len() < CRC_BYTES {
        return Err(FrameError::Truncated);
    }
    let (payload, trailer) = raw.split_at(raw.len() - CRC_BYTES);
    let mut received = [0u8; CRC_BYTES];
    received.copy_from_slice(trailer);
    if u32::from_le_bytes(received) != crc32(payload) {
        return Err(FrameError::Crc);
    }
    match postcard::take_from_bytes::<M>(payload) {
        Ok((message, [])) => Ok(message),
        _ => Err(FrameError::Decode),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_is_iso_hdlc() {
        // The catalogue's check value of CRC-32/ISO-HDLC.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn empty_chunks_are_ignored() {
        let mut d = FrameDecoder::new();
        for _ in 0..10 {
            assert_eq!(d.push::<u32>(0), None);
        }
    }
}
