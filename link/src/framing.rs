//! Framing on the serial link: COBS (consistent overhead byte stuffing, the `cobs` crate) with
//! a `0x00` delimiter before and after every packet.
//!
//! COBS removes every zero byte from the packet, so a zero on the line always ends a frame: a
//! receiver that starts mid-stream, or loses bytes to line noise, is back in step at the next
//! zero. Every frame also starts with a delimiter, so noise on an idle line ends before the
//! frame instead of merging with it. The overhead is the two delimiters plus COBS's own (at
//! least one byte, plus one per run of 254). Integrity is the packet's own CRC (the PUS packet
//! error control field); framing only delimits.

use cobs::{DecodeResult, DecoderState};

/// The frame delimiter.
pub const DELIMITER: u8 = 0;

/// Bytes a frame of an `n`-byte packet takes at most (code bytes and the delimiters).
pub const fn max_encoded_len(n: usize) -> usize {
    n + n / 254 + 3
}

/// Encodes `packet` into `out` between two delimiters; returns the frame length, or `None`
/// if `out` is too small (see [`max_encoded_len`]).
pub fn encode(packet: &[u8], out: &mut [u8]) -> Option<usize> {
    if out.len() < max_encoded_len(packet.len()) {
        return None;
    }
    cobs::try_encode_including_sentinels(packet, out).ok()
}

/// What [`Decoder::push`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Deframed {
    /// Nothing complete yet.
    Pending,
    /// A packet of this length is in the output buffer.
    Packet(usize),
    /// A frame ended but could not be used: too long for the buffer, or not valid COBS.
    Garbage,
}

/// Decodes COBS as the bytes arrive, straight into the caller's buffer (no frame buffer of
/// its own: the `cobs` crate's state machine, the output handled here); resynchronises at
/// every delimiter.
#[derive(Debug, Default)]
pub struct Decoder {
    state: DecoderState,
    /// Octets written to the output so far.
    len: usize,
    /// The frame did not fit the output.
    overflow: bool,
}

impl Decoder {
    /// A decoder waiting for a frame.
    pub const fn new() -> Self {
        Decoder {
            state: DecoderState::Idle,
            len: 0,
            overflow: false,
        }
    }

    /// One byte from the line; decoded octets go to `out` (the same buffer for the whole
    /// frame).
    pub fn push(&mut self, byte: u8, out: &mut [u8]) -> Deframed {
        match self.state.feed(byte) {
            Ok(DecodeResult::NoData) => Deframed::Pending,
            Ok(DecodeResult::DataStart) => {
                self.len = 0;
                self.overflow = false;
                Deframed::Pending
            }
            Ok(DecodeResult::DataContinue(b)) => {
                match out.get_mut(self.len) {
                    Some(slot) => {
                        *slot = b;
                        self.len += 1;
                    }
                    None => self.overflow = true,
                }
                Deframed::Pending
            }
            Ok(DecodeResult::DataComplete) if self.overflow => Deframed::Garbage,
            Ok(DecodeResult::DataComplete) => Deframed::Packet(self.len),
            Err(_) => Deframed::Garbage,
        }
    }
}

/// A [`Decoder`] with a buffer of `N` octets: hands out whole packets.
pub struct Deframer<const N: usize> {
    buf: [u8; N],
    decoder: Decoder,
}

impl<const N: usize> Default for Deframer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Deframer<N> {
    /// An empty receiver (packets longer than `N` octets are dropped as garbage).
    pub const fn new() -> Self {
        Deframer {
            buf: [0; N],
            decoder: Decoder::new(),
        }
    }

    /// One byte from the line.
    pub fn push(&mut self, byte: u8) -> Deframed {
        self.decoder.push(byte, &mut self.buf)
    }

    /// The packet announced by the last [`Deframed::Packet`] (valid until the next `push`).
    pub fn packet(&self, len: usize) -> &[u8] {
        &self.buf[..len.min(N)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn roundtrip(packet: &[u8]) {
        let mut frame = [0u8; 700];
        let n = encode(packet, &mut frame).unwrap();
        assert!(n <= max_encoded_len(packet.len()));
        assert_eq!((frame[0], frame[n - 1]), (DELIMITER, DELIMITER));
        assert!(!frame[1..n - 1].contains(&0), "{packet:?}");
        let mut d = Deframer::<700>::new();
        let mut got = None;
        for &b in &frame[..n] {
            if let Deframed::Packet(len) = d.push(b) {
                got = Some(d.packet(len).to_vec());
            }
        }
        assert_eq!(got.as_deref(), Some(packet));
    }

    extern crate std;
    use std::vec::Vec;

    #[test]
    fn packets_survive_framing() {
        roundtrip(&[1]);
        roundtrip(&[0]);
        roundtrip(&[0, 0, 0]);
        roundtrip(&[1, 0, 2, 0]);
        let long: Vec<u8> = (0..600).map(|i| (i % 256) as u8).collect();
        roundtrip(&long);
        let no_zero: Vec<u8> = (0..600).map(|i| (i % 255 + 1) as u8).collect();
        roundtrip(&no_zero);
        roundtrip(&no_zero[..254]);
        roundtrip(&no_zero[..255]);
    }

    #[test]
    fn garbage_before_a_frame_costs_only_that_frame() {
        let mut frame = [0u8; 64];
        let n = encode(&[7, 0, 9, 11], &mut frame).unwrap();
        let mut d = Deframer::<16>::new();
        // Noise with a zero in it, then a truncated frame, then the real one.
        let mut out = Vec::new();
        for &b in [3u8, 0xAA, 0, 5, 1, 2].iter().chain(frame[..n].iter()) {
            match d.push(b) {
                Deframed::Packet(len) => out.push(Ok(d.packet(len).to_vec())),
                Deframed::Garbage => out.push(Err(())),
                Deframed::Pending => {}
            }
        }
        // "3 AA" is invalid COBS (code 3 runs past the end), "5 1 2" too (ended by the
        // frame's leading delimiter); the frame itself arrives intact.
        assert_eq!(out, [Err(()), Err(()), Ok(std::vec![7, 0, 9, 11])]);
    }

    #[test]
    fn an_overlong_frame_is_garbage_and_the_next_is_received() {
        let mut d = Deframer::<4>::new();
        for b in 1..=10u8 {
            assert_eq!(d.push(b), Deframed::Pending);
        }
        assert_eq!(d.push(0), Deframed::Garbage);
        for b in [2u8, 5] {
            d.push(b);
        }
        assert_eq!(d.push(0), Deframed::Packet(1));
        assert_eq!(d.packet(1), &[5]);
    }
}
