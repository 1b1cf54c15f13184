//! The calibration record: a calibrated arrangement (every channel's position, axis, noise,
//! bias and scale, and the frame's uncertainty) with a monotonic calibration id, in a versioned
//! little-endian layout closed by a CRC-32.
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | magic `BCAL` |
//! | 4 | 2 | format version ([`FORMAT_VERSION`]) |
//! | 6 | 1 | channels N (1 ..= [`MAX_CHANNELS`]) |
//! | 7 | 1 | reserved, 0 |
//! | 8 | 4 | calibration id (u32, > 0, increasing with every commit) |
//! | 12 | 32 | frame uncertainty: rotation, translation, size, relative rotation (f64) |
//! | 44 | 72 N | per channel: position (3 × f64, m), axis (3 × f64), noise, bias, scale (f64) |
//! | 44 + 72 N | 24 N | per channel: temperature coefficients t_ref (°C), bias_tc (m/s² per °C), scale_tc (1/°C) (f64; all three 0: none) |
//! | 44 + 96 N | 4 | CRC-32 (ISO-HDLC, the zip/Ethernet one) of everything before it |
//!
//! f64 throughout, so a record holds exactly what `ballisto calibrate` wrote (2 352 octets at
//! N = 24: the two 128 KiB sectors of the store hold about 107 of them between erases). Version 1
//! (72 octets per channel, no temperature coefficients) is still read: a calibration stored by
//! an earlier firmware survives the update.

use ballisto_link::ids::MAX_CHANNELS;
use crc::{Crc, NoTable, CRC_32_ISO_HDLC};
use estimator_core::thermal::Thermal;
use estimator_core::{Arrangement, ConfigError, FrameUncertainty};

/// The layout's version (2: with temperature coefficients).
pub const FORMAT_VERSION: u16 = 2;
/// The earlier version still read.
const VERSION_1: u16 = 1;
/// The magic number at offset 0.
pub const MAGIC: [u8; 4] = *b"BCAL";
/// Octets before the channels.
const HEADER: usize = 44;
/// Octets per channel.
const PER_CHANNEL: usize = 96;
/// Octets per channel in version 1.
const PER_CHANNEL_V1: usize = 72;
/// The longest record (N = [`MAX_CHANNELS`]).
pub const MAX_RECORD: usize = HEADER + PER_CHANNEL * MAX_CHANNELS + 4;

/// Reads fixed-size fields in order, every access checked.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Option<[u8; N]> {
        let field = self.bytes.get(self.at..self.at.checked_add(N)?)?;
        self.at += N;
        field.try_into().ok()
    }
}

// Bitwise, without the 1 KiB table: a record is checked once per boot and commit.
const CRC32: Crc<u32, NoTable> = Crc::<u32, NoTable>::new(&CRC_32_ISO_HDLC);

/// The CRC-32 of the records (ISO-HDLC) of any octets: also the identity of an arrangement
/// loaded by command (of the command's application data).
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

/// A calibration: the calibrated arrangement and its id.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrationRecord {
    /// Monotonic calibration id (> 0).
    pub id: u32,
    /// The calibrated arrangement.
    pub arrangement: Arrangement<MAX_CHANNELS>,
}

/// What is wrong with a stored record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RecordError {
    /// Shorter than its header or than its channels need.
    Truncated {
        /// Octets present.
        len: usize,
    },
    /// Not a calibration record.
    Magic,
    /// A layout this firmware does not know.
    Version {
        /// The record's version.
        found: u16,
    },
    /// No channel, or more than the firmware holds.
    Channels {
        /// The record's count.
        found: u8,
    },
    /// Calibration id 0 (ids start at 1).
    IdZero,
    /// The CRC does not match the contents.
    Crc {
        /// CRC stored in the record.
        stored: u32,
        /// CRC of the contents.
        computed: u32,
    },
    /// The contents are not a valid arrangement (estimator-core's check, naming the channel).
    Invalid(ConfigError),
}

impl core::fmt::Display for RecordError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RecordError::Truncated { len } => write!(f, "calibration record truncated ({len} octets)"),
            RecordError::Magic => write!(f, "not a calibration record (magic)"),
            RecordError::Version { found } => write!(
                f,
                "calibration record version {found}, this firmware reads {VERSION_1} and {FORMAT_VERSION}"
            ),
            RecordError::Channels { found } => write!(
                f,
                "calibration record has {found} channels (1 ..= {MAX_CHANNELS})"
            ),
            RecordError::IdZero => write!(f, "calibration id 0"),
            RecordError::Crc { stored, computed } => write!(
                f,
                "calibration record CRC {stored:#010x} does not match its contents ({computed:#010x})"
            ),
            RecordError::Invalid(e) => write!(f, "calibration record: {e}"),
        }
    }
}

impl CalibrationRecord {
    /// Length of the encoding for N channels.
    pub fn encoded_len(channels: usize) -> usize {
        HEADER + PER_CHANNEL * channels + 4
    }

    /// Length of a record of layout `version` (one this firmware reads) with N channels.
    fn len_of(version: u16, channels: usize) -> usize {
        if version == VERSION_1 {
            HEADER + PER_CHANNEL_V1 * channels + 4
        } else {
            Self::encoded_len(channels)
        }
    }

    /// Writes the record into `out` and returns the octets used. `out` must hold
    /// [`CalibrationRecord::encoded_len`] octets ([`MAX_RECORD`] always does); `None` if not, or
    /// if the id is 0.
    #[inline(never)]
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let a = &self.arrangement;
        let n = a.len();
        let len = Self::encoded_len(n);
        if self.id == 0 || n == 0 || out.len() < len {
            return None;
        }
        let out = &mut out[..len];
        out[0..4].copy_from_slice(&MAGIC);
        out[4..6].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
        out[6] = n as u8;
        out[7] = 0;
        out[8..12].copy_from_slice(&self.id.to_le_bytes());
        let fr = a.frame_uncertainty();
        let mut at = 12;
        let mut put = |out: &mut [u8], v: f64| {
            out[at..at + 8].copy_from_slice(&v.to_le_bytes());
            at += 8;
        };
        for v in [fr.rotation, fr.translation, fr.size, fr.relative_rotation] {
            put(out, v);
        }
        for c in a.channels() {
            for v in c.position.iter().chain(c.axis.iter()) {
                put(out, *v);
            }
            for v in [c.noise, c.bias, c.scale] {
                put(out, v);
            }
        }
        for channel in 0..n {
            let th = a.thermal(channel);
            let v = th.map_or([0.0; 3], |t| [t.t_ref, t.bias_tc, t.scale_tc]);
            for v in v {
                put(out, v);
            }
        }
        let crc = CRC32.checksum(&out[..len - 4]);
        out[len - 4..].copy_from_slice(&crc.to_le_bytes());
        Some(len)
    }

    /// Reads a record, checking everything; the error names what is wrong. No panic path
    /// (every access is checked: in the STM32 image, one indexing panic would also bring in
    /// `core::fmt`'s integer formatting, ≈ 0.6 KiB).
    #[inline(never)]
    pub fn decode(bytes: &[u8]) -> Result<Self, RecordError> {
        let truncated = RecordError::Truncated { len: bytes.len() };
        let mut r = Reader { bytes, at: 0 };
        let [m0, m1, m2, m3, v0, v1, count, _, i0, i1, i2, i3] = r.take::<12>().ok_or(truncated)?;
        if [m0, m1, m2, m3] != MAGIC {
            return Err(RecordError::Magic);
        }
        let version = u16::from_le_bytes([v0, v1]);
        if version != FORMAT_VERSION && version != VERSION_1 {
            return Err(RecordError::Version { found: version });
        }
        let n = usize::from(count);
        if n == 0 || n > MAX_CHANNELS {
            return Err(RecordError::Channels { found: count });
        }
        let len = Self::len_of(version, n);
        let (body, crc) = match (bytes.get(..len - 4), bytes.get(len - 4..len)) {
            (Some(body), Some(crc)) => (body, crc),
            _ => return Err(truncated),
        };
        let stored = u32::from_le_bytes(crc.try_into().map_err(|_| truncated)?);
        let computed = CRC32.checksum(body);
        if stored != computed {
            return Err(RecordError::Crc { stored, computed });
        }
        let id = u32::from_le_bytes([i0, i1, i2, i3]);
        if id == 0 {
            return Err(RecordError::IdZero);
        }
        // Fields read in loops, not one by one: 0.3 KiB less in the STM32 image.
        let mut read = |out: &mut [f64]| -> Result<(), RecordError> {
            for v in out.iter_mut() {
                *v = f64::from_le_bytes(r.take::<8>().ok_or(truncated)?);
            }
            Ok(())
        };
        let mut fr = [0.0; 4];
        read(&mut fr)?;
        let frame = FrameUncertainty {
            rotation: fr[0],
            translation: fr[1],
            size: fr[2],
            relative_rotation: fr[3],
        };
        let mut arrangement = Arrangement::new();
        for channel in 0..n {
            let mut c = [0.0; 9];
            read(&mut c)?;
            arrangement
                .push([c[0], c[1], c[2]], [c[3], c[4], c[5]], c[6])
                .map_err(RecordError::Invalid)?;
            arrangement
                .set_calibration(channel, c[7], c[8])
                .map_err(RecordError::Invalid)?;
        }
        if version == FORMAT_VERSION {
            for channel in 0..n {
                let mut t = [0.0; 3];
                read(&mut t)?;
                let thermal = if t == [0.0; 3] {
                    None
                } else {
                    Some(Thermal::new(t[0], t[1], t[2]).map_err(|_| {
                        RecordError::Invalid(ConfigError::CalibrationInvalid { channel })
                    })?)
                };
                arrangement
                    .set_thermal(channel, thermal)
                    .map_err(RecordError::Invalid)?;
            }
        }
        arrangement
            .set_frame_uncertainty(frame)
            .map_err(RecordError::Invalid)?;
        Ok(CalibrationRecord { id, arrangement })
    }

    /// The CRC a valid encoding carries (its last four octets): with the id, the record's
    /// identity in housekeeping. (Decoding normalises the axes again, which may move their
    /// last bit: re-encoding a decoded record need not give the stored CRC, so the stored one
    /// is the identity.)
    pub fn stored_crc(bytes: &[u8]) -> Option<u32> {
        let version = u16::from_le_bytes([*bytes.get(4)?, *bytes.get(5)?]);
        let n = usize::from(*bytes.get(6)?);
        let len = Self::len_of(version, n);
        let b = bytes.get(len - 4..len)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(id: u32, n: usize) -> CalibrationRecord {
        let mut a = Arrangement::new();
        for i in 0..n {
            let x = i as f64;
            a.push([0.01 * x, -0.02 * x, 0.1], [1.0, 0.01 * x, -0.02], 1e-3)
                .unwrap();
            a.set_calibration(i, 0.02 - 0.001 * x, 1.0 + 0.001 * x)
                .unwrap();
            if i % 2 == 0 {
                let th = Thermal::new(20.0 + x, 1e-3 * x - 5e-3, 2e-5 * x).unwrap();
                a.set_thermal(i, Some(th)).unwrap();
            }
        }
        a.set_frame_uncertainty(FrameUncertainty {
            rotation: 1e-4,
            translation: 2e-5,
            size: 3e-5,
            relative_rotation: 4e-4,
        })
        .unwrap();
        CalibrationRecord { id, arrangement: a }
    }

    /// Encoding and decoding give back the record: every number exactly (f64: what the host
    /// wrote) but the axes, which the arrangement normalises again (to within 2 ulp).
    #[test]
    fn round_trip_is_exact() {
        for n in [1, 9, MAX_CHANNELS] {
            let r = record(7, n);
            let mut buf = [0u8; MAX_RECORD];
            let len = r.encode(&mut buf).unwrap();
            assert_eq!(len, CalibrationRecord::encoded_len(n));
            let d = CalibrationRecord::decode(&buf[..len]).unwrap();
            assert_eq!(d.id, r.id);
            let (a, b) = (d.arrangement, r.arrangement);
            assert_eq!(a.frame_uncertainty(), b.frame_uncertainty());
            assert_eq!(a.len(), b.len());
            for (x, y) in a.channels().iter().zip(b.channels()) {
                assert_eq!(
                    (x.position, x.noise, x.bias, x.scale),
                    (y.position, y.noise, y.bias, y.scale)
                );
                for k in 0..3 {
                    assert!(
                        (x.axis[k] - y.axis[k]).abs() <= 2.0 * f64::EPSILON,
                        "{:?} {:?}",
                        x.axis,
                        y.axis
                    );
                }
            }
            for c in 0..n {
                assert_eq!(a.thermal(c), b.thermal(c), "channel {c}");
            }
            let crc = CalibrationRecord::stored_crc(&buf[..len]).unwrap();
            assert_eq!(crc, CRC32.checksum(&buf[..len - 4]));
        }
        assert_eq!(CalibrationRecord::encoded_len(24), 2352);
    }

    /// A version-1 record (an earlier firmware's: no temperature coefficients) is still read,
    /// whole, with none.
    #[test]
    fn version_1_is_read() {
        let r = record(5, 6);
        let mut buf = [0u8; MAX_RECORD];
        let len = r.encode(&mut buf).unwrap();
        let v1_len = HEADER + PER_CHANNEL_V1 * 6 + 4;
        let mut v1 = buf[..v1_len].to_vec();
        v1[4..6].copy_from_slice(&VERSION_1.to_le_bytes());
        let crc = CRC32.checksum(&v1[..v1_len - 4]);
        v1[v1_len - 4..].copy_from_slice(&crc.to_le_bytes());
        let d = CalibrationRecord::decode(&v1).unwrap();
        assert!(len > v1_len);
        assert_eq!(d.arrangement.len(), 6);
        assert_eq!(d.arrangement.channels()[3], r.arrangement.channels()[3]);
        assert!((0..6).all(|c| d.arrangement.thermal(c).is_none()));
        assert_eq!(CalibrationRecord::stored_crc(&v1), Some(crc));
    }

    /// Every kind of damage is refused with its own error, and any flipped bit fails the CRC
    /// (or an earlier check).
    #[test]
    fn damage_is_named() {
        let r = record(3, 12);
        let mut buf = [0u8; MAX_RECORD];
        let len = r.encode(&mut buf).unwrap();
        let good = buf;
        let dec = |b: &[u8]| CalibrationRecord::decode(b);
        assert_eq!(dec(&good[..10]), Err(RecordError::Truncated { len: 10 }));
        assert_eq!(
            dec(&good[..len - 1]),
            Err(RecordError::Truncated { len: len - 1 })
        );
        let mut b = good;
        b[0] = b'X';
        assert_eq!(dec(&b[..len]), Err(RecordError::Magic));
        let mut b = good;
        b[4] = 3;
        assert_eq!(dec(&b[..len]), Err(RecordError::Version { found: 3 }));
        let mut b = good;
        b[6] = 0;
        assert_eq!(dec(&b[..len]), Err(RecordError::Channels { found: 0 }));
        for bit in 0..(8 * len) {
            let mut b = good;
            b[bit / 8] ^= 1 << (bit % 8);
            assert!(dec(&b[..len]).is_err(), "bit {bit} flipped and accepted");
        }
        // A record whose CRC is right but whose contents are not an arrangement.
        let mut b = good;
        b[44 + 6 * 8..44 + 7 * 8].copy_from_slice(&(-1.0f64).to_le_bytes()); // noise of channel 0
        let crc = CRC32.checksum(&b[..len - 4]);
        b[len - 4..len].copy_from_slice(&crc.to_le_bytes());
        assert!(matches!(
            dec(&b[..len]),
            Err(RecordError::Invalid(ConfigError::NoiseInvalid {
                channel: 0
            }))
        ));
        assert_eq!(record(0, 3).encode(&mut [0u8; MAX_RECORD]), None);
    }
}
