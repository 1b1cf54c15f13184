//! The packet layouts: CCSDS space packets with PUS-C secondary headers, the ballistometer's
//! application data, encoded (on board) and decoded (on the ground) by the same definitions.
//! `docs/telemetry.md` describes every byte for a ground segment that does not read Rust.
//!
//! All multi-byte fields are big-endian (network order, as CCSDS); reals are IEEE-754 `f32`.

use estimator_core::linalg::Sym3;
use estimator_core::{Estimate, Flags};
use spacepackets::ecss::tm::PusTmReader;
use spacepackets::CcsdsPacket;

use crate::estimation::Motion;
use crate::sampler::{LoopHealth, PartHealth};
use crate::time::Nanos;

/// Application process identifier of the ballistometer (telemetry and telecommands).
pub const APID: u16 = 0x0BA;

/// CUC P-field: agency-defined epoch (time since boot), 4 coarse octets (s), 3 fine (2⁻²⁴ s).
pub const CUC_P_FIELD: u8 = 0x2F;
/// Length of the TM time field: the P-field and the 7-octet T-field.
pub const TIME_LEN: usize = 8;

/// Longest telemetry packet the unit sends (the housekeeping report), octets.
pub const TM_MAX: usize = 320;
// The longest packet (housekeeping) fits the telemetry buffer.
const _: () = assert!(6 + 7 + TIME_LEN + HOUSEKEEPING_LEN + 2 <= TM_MAX);

/// Longest telecommand packet the unit accepts (a 24-channel arrangement), octets.
pub const TC_MAX: usize = 704;

/// PUS service types used.
pub mod service {
    /// ST[01] request verification.
    pub const VERIFICATION: u8 = 1;
    /// ST[03] housekeeping.
    pub const HOUSEKEEPING: u8 = 3;
    /// ST[05] event reporting.
    pub const EVENT: u8 = 5;
    /// ST[17] test.
    pub const TEST: u8 = 17;
    /// ST[200] ballistometer (mission-specific).
    pub const BALLISTOMETER: u8 = 200;
}

/// Message subtypes.
pub mod subtype {
    /// TM[1,1] successful acceptance.
    pub const ACCEPTED: u8 = 1;
    /// TM[1,2] failed acceptance.
    pub const NOT_ACCEPTED: u8 = 2;
    /// TM[1,7] successful completion.
    pub const COMPLETED: u8 = 7;
    /// TM[1,8] failed completion.
    pub const NOT_COMPLETED: u8 = 8;
    /// TM[3,25] housekeeping parameter report.
    pub const HK_REPORT: u8 = 25;
    /// TC[3,27] generate a one-shot report of housekeeping structures.
    pub const HK_ONE_SHOT: u8 = 27;
    /// TC[17,1] are-you-alive connection test.
    pub const ARE_YOU_ALIVE: u8 = 1;
    /// TM[17,2] are-you-alive connection report.
    pub const ALIVE: u8 = 2;
    /// TC[200,1] set mode.
    pub const SET_MODE: u8 = 1;
    /// TC[200,2] set model.
    pub const SET_MODEL: u8 = 2;
    /// TC[200,3] set the rate hint.
    pub const SET_HINT: u8 = 3;
    /// TC[200,4] exclude a channel.
    pub const EXCLUDE: u8 = 4;
    /// TC[200,5] include a channel.
    pub const INCLUDE: u8 = 5;
    /// TC[200,6] load an arrangement.
    pub const LOAD_ARRANGEMENT: u8 = 6;
    /// TC[200,7] set the telemetry rates.
    pub const SET_RATES: u8 = 7;
}

/// Housekeeping structure identifiers (TM[3,25]).
pub mod sid {
    /// The motion report, one per sample set (or per decimation).
    pub const MOTION: u16 = 1;
    /// The housekeeping report.
    pub const HOUSEKEEPING: u16 = 2;
}

/// Time field of a packet stamped `t` (ns since boot): CUC 4+3 with its P-field.
pub fn cuc(t: Nanos) -> [u8; TIME_LEN] {
    let coarse = (t / 1_000_000_000) as u32;
    let sub = t % 1_000_000_000;
    let fine = ((sub << 24) + 500_000_000) / 1_000_000_000;
    // Rounding can carry into the next second.
    let (coarse, fine) = if fine >> 24 != 0 {
        (coarse.wrapping_add(1), 0)
    } else {
        (coarse, fine as u32)
    };
    let c = coarse.to_be_bytes();
    let f = fine.to_be_bytes();
    [CUC_P_FIELD, c[0], c[1], c[2], c[3], f[1], f[2], f[3]]
}

/// Seconds since boot of a CUC time field, or `None` if it is not the unit's format.
pub fn cuc_seconds(field: &[u8]) -> Option<f64> {
    if field.len() != TIME_LEN || field[0] != CUC_P_FIELD {
        return None;
    }
    let coarse = u32::from_be_bytes([field[1], field[2], field[3], field[4]]);
    let fine = u32::from_be_bytes([0, field[5], field[6], field[7]]);
    Some(f64::from(coarse) + f64::from(fine) / f64::from(1u32 << 24))
}

/// Writes big-endian fields into a buffer (the caller sizes the buffer for the layout).
pub struct Put<'a> {
    buf: &'a mut [u8],
    n: usize,
}

impl<'a> Put<'a> {
    /// Writing from the start of `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Put { buf, n: 0 }
    }

    /// Octets written; `None` if the buffer was too small for what was put.
    pub fn finish(self) -> Option<usize> {
        (self.n <= self.buf.len()).then_some(self.n)
    }

    /// Raw octets.
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        if let Some(dst) = self.buf.get_mut(self.n..self.n + b.len()) {
            dst.copy_from_slice(b);
        }
        self.n += b.len();
        self
    }

    /// One octet.
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.bytes(&[v])
    }

    /// A 16-bit unsigned integer.
    pub fn u16(&mut self, v: u16) -> &mut Self {
        self.bytes(&v.to_be_bytes())
    }

    /// A 32-bit unsigned integer.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.bytes(&v.to_be_bytes())
    }

    /// An IEEE-754 single.
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.bytes(&v.to_be_bytes())
    }

    /// Several singles.
    pub fn f32s(&mut self, v: &[f32]) -> &mut Self {
        for x in v {
            self.f32(*x);
        }
        self
    }
}

/// Reads big-endian fields; every read past the end gives `None`.
pub struct Get<'a> {
    buf: &'a [u8],
    n: usize,
}

impl<'a> Get<'a> {
    /// Reading from the start of `buf`.
    pub fn new(buf: &'a [u8]) -> Self {
        Get { buf, n: 0 }
    }

    /// Octets not read yet.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.n
    }

    /// The next `N` octets.
    pub fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        let a = self.buf.get(self.n..self.n + N)?.try_into().ok()?;
        self.n += N;
        Some(a)
    }

    /// One octet.
    pub fn u8(&mut self) -> Option<u8> {
        self.array::<1>().map(|a| a[0])
    }

    /// A 16-bit unsigned integer.
    pub fn u16(&mut self) -> Option<u16> {
        self.array().map(u16::from_be_bytes)
    }

    /// A 32-bit unsigned integer.
    pub fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_be_bytes)
    }

    /// An IEEE-754 single.
    pub fn f32(&mut self) -> Option<f32> {
        self.array().map(f32::from_be_bytes)
    }

    /// `N` singles.
    pub fn f32s<const N: usize>(&mut self) -> Option<[f32; N]> {
        let mut out = [0.0; N];
        for x in out.iter_mut() {
            *x = self.f32()?;
        }
        Some(out)
    }
}

/// The motion report (TM[3,25], SID 1): one estimate and what it was computed from.
#[derive(Clone, Copy, Debug)]
pub struct MotionReport {
    /// Sample set index.
    pub k: u32,
    /// The estimate (every field the estimates file has).
    pub estimate: Estimate<f32>,
    /// Parts without a value in this set (bit per part).
    pub missing_parts: u8,
    /// Parts excluded automatically (bit per part).
    pub excluded_parts: u8,
    /// Channels not in the solve, commanded or automatic (bit per channel).
    pub excluded_channels: u32,
}

/// Application data length of the motion report.
pub const MOTION_LEN: usize = 142;

impl MotionReport {
    /// The report of one output of the estimation.
    pub fn of(motion: &Motion, excluded_channels: u32) -> Self {
        MotionReport {
            k: motion.k,
            estimate: motion.estimate,
            missing_parts: motion.missing as u8,
            excluded_parts: motion.excluded as u8,
            excluded_channels,
        }
    }

    /// Encodes the application data; returns its length ([`MOTION_LEN`]).
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let e = &self.estimate;
        let mut p = Put::new(out);
        p.u16(sid::MOTION)
            .u32(self.k)
            .f32s(&e.sigma0)
            .f32s(&e.domega)
            .f32s(&e.omega)
            .f32s(&e.field.0)
            .u16(e.flags.0)
            .f32(e.chi2)
            .u8(e.dof)
            .u8(e.branches)
            .u8(e.frame)
            .u8(e.epsilon as u8)
            .f32s(&e.sd_sigma0)
            .f32s(&e.sd_domega)
            .f32s(&e.sd_omega)
            .f32s(&e.sd_field.0)
            .u8(self.missing_parts)
            .u8(self.excluded_parts)
            .u32(self.excluded_channels);
        p.finish()
    }

    /// Decodes the application data after the SID.
    fn decode(g: &mut Get) -> Option<Self> {
        let mut e = Estimate::<f32> {
            sigma0: g.f32s()?,
            domega: g.f32s()?,
            omega: g.f32s()?,
            field: Sym3(g.f32s()?),
            flags: Flags(g.u16()?),
            chi2: g.f32()?,
            dof: g.u8()?,
            branches: g.u8()?,
            frame: g.u8()?,
            ..Estimate::default()
        };
        e.epsilon = g.u8()? as i8;
        e.sd_sigma0 = g.f32s()?;
        e.sd_domega = g.f32s()?;
        e.sd_omega = g.f32s()?;
        e.sd_field = Sym3(g.f32s()?);
        Some(MotionReport {
            k: 0,
            estimate: e,
            missing_parts: g.u8()?,
            excluded_parts: g.u8()?,
            excluded_channels: g.u32()?,
        })
    }
}

/// State of one part in the housekeeping report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum PartState {
    /// No part configured in this slot.
    #[default]
    Absent = 0,
    /// Configured and being read.
    Running = 1,
    /// Configured, not answering (marked down, restarted periodically).
    Down = 2,
}

impl PartState {
    /// The state of a part slot: absent, or running / down by its health.
    pub fn of(part: Option<&PartHealth>) -> Self {
        match part {
            None => PartState::Absent,
            Some(p) if p.running => PartState::Running,
            Some(_) => PartState::Down,
        }
    }
}

/// The housekeeping report (TM[3,25], SID 2).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Housekeeping {
    /// Firmware version (major, minor, patch).
    pub version: [u8; 3],
    /// 0 standby, 1 operate.
    pub mode: u8,
    /// 0 general (G), 1 free float (F).
    pub model: u8,
    /// Channels in the arrangement.
    pub channels: u8,
    /// Sample rate, Hz.
    pub rate_hz: f32,
    /// Motion reports: one per this many sample sets.
    pub motion_every: u16,
    /// Housekeeping reports: one per this many sample sets.
    pub housekeeping_every: u16,
    /// The sampling loop's counters: sets, instants skipped, sets dropped, SYNC failures.
    pub sampling: LoopHealth,
    /// Estimates computed.
    pub estimates: u32,
    /// Parts excluded automatically (bit per part).
    pub excluded_parts: u8,
    /// Channels excluded by command (bit per channel).
    pub commanded_out: u32,
    /// Channels not in the solve, commanded or automatic (bit per channel).
    pub excluded_channels: u32,
    /// Telecommands accepted (their execution may still fail: TM[1,8]).
    pub tc_accepted: u32,
    /// Telecommands refused at acceptance (TM[1,2] sent, or a frame too short to answer).
    pub tc_rejected: u32,
    /// Frames on the command link that were not a packet (noise, overlong, truncated).
    pub frames_garbage: u32,
    /// Telemetry packets the link failed to take.
    pub tm_lost: u32,
    /// Per part slot: its counters, `None` if no part is configured there. On the link each
    /// slot is a [`PartState`] (absent, or running / down by `running`) and six counters.
    pub parts: [Option<PartHealth>; crate::config::MAX_PARTS],
}

/// Application data length of the housekeeping report.
pub const HOUSEKEEPING_LEN: usize = 2 + 6 + 4 + 4 + 20 + 1 + 8 + 16 + 8 * 25;

impl Housekeeping {
    /// Encodes the application data; returns its length ([`HOUSEKEEPING_LEN`]).
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let mut p = Put::new(out);
        p.u16(sid::HOUSEKEEPING)
            .bytes(&self.version)
            .u8(self.mode)
            .u8(self.model)
            .u8(self.channels)
            .f32(self.rate_hz)
            .u16(self.motion_every)
            .u16(self.housekeeping_every)
            .u32(self.sampling.sets)
            .u32(self.sampling.skipped)
            .u32(self.sampling.dropped)
            .u32(self.sampling.sync_errors)
            .u32(self.estimates)
            .u8(self.excluded_parts)
            .u32(self.commanded_out)
            .u32(self.excluded_channels)
            .u32(self.tc_accepted)
            .u32(self.tc_rejected)
            .u32(self.frames_garbage)
            .u32(self.tm_lost);
        for part in &self.parts {
            let c = part.unwrap_or_default();
            p.u8(PartState::of(part.as_ref()) as u8)
                .u32(c.reads)
                .u32(c.bus_errors)
                .u32(c.implausible)
                .u32(c.missed)
                .u32(c.failed_starts)
                .u32(c.resyncs);
        }
        p.finish()
    }

    fn decode(g: &mut Get) -> Option<Self> {
        let mut h = Housekeeping {
            version: g.array()?,
            mode: g.u8()?,
            model: g.u8()?,
            channels: g.u8()?,
            rate_hz: g.f32()?,
            motion_every: g.u16()?,
            housekeeping_every: g.u16()?,
            sampling: LoopHealth {
                sets: g.u32()?,
                skipped: g.u32()?,
                dropped: g.u32()?,
                sync_errors: g.u32()?,
            },
            estimates: g.u32()?,
            excluded_parts: g.u8()?,
            commanded_out: g.u32()?,
            excluded_channels: g.u32()?,
            tc_accepted: g.u32()?,
            tc_rejected: g.u32()?,
            frames_garbage: g.u32()?,
            tm_lost: g.u32()?,
            ..Housekeeping::default()
        };
        for slot in h.parts.iter_mut() {
            let state = g.u8()?;
            let c = PartHealth {
                reads: g.u32()?,
                bus_errors: g.u32()?,
                implausible: g.u32()?,
                missed: g.u32()?,
                failed_starts: g.u32()?,
                resyncs: g.u32()?,
                running: state == PartState::Running as u8,
            };
            *slot = match state {
                0 => None,
                1 | 2 => Some(c),
                _ => return None,
            };
        }
        Some(h)
    }
}

/// Event identifiers (TM[5,x]); the subtype is the severity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum EventId {
    /// The unit started: `a` = version (major·2¹⁶ + minor·2⁸ + patch), `b` = channels.
    Boot = 1,
    /// Mode changed: `a` = old mode, `b` = new mode.
    ModeChanged = 2,
    /// A part stopped answering and was marked down: `a` = part.
    PartDown = 3,
    /// A part answers again: `a` = part.
    PartUp = 4,
    /// Parts were excluded from the solve: `a` = excluded parts, `b` = channels out.
    PartsExcluded = 5,
    /// Parts were included again: `a` = excluded parts, `b` = channels out.
    PartsIncluded = 6,
    /// Arrangement or model changed by command: `a` = channels, `b` = model.
    Reconfigured = 7,
    /// A command-link frame was not a packet: `a` = reason (1 not COBS or too long,
    /// 2 shorter than a packet header), `b` = such frames so far.
    FrameRejected = 8,
    /// Sample sets were lost since the last report: `a` = instants skipped, `b` = sets dropped
    /// (both since boot).
    SetsLost = 9,
}

impl EventId {
    /// The event of a raw identifier.
    pub fn from_u16(v: u16) -> Option<Self> {
        use EventId::*;
        [
            Boot,
            ModeChanged,
            PartDown,
            PartUp,
            PartsExcluded,
            PartsIncluded,
            Reconfigured,
            FrameRejected,
            SetsLost,
        ]
        .into_iter()
        .find(|e| *e as u16 == v)
    }

    /// Severity = the TM[5,x] subtype: 1 informative, 2 low, 3 medium, 4 high.
    pub fn severity(self) -> u8 {
        match self {
            EventId::PartDown | EventId::FrameRejected | EventId::SetsLost => 2,
            EventId::PartsExcluded => 3,
            _ => 1,
        }
    }

    /// The name used in decoded logs.
    pub fn name(self) -> &'static str {
        match self {
            EventId::Boot => "boot",
            EventId::ModeChanged => "mode-changed",
            EventId::PartDown => "part-down",
            EventId::PartUp => "part-up",
            EventId::PartsExcluded => "parts-excluded",
            EventId::PartsIncluded => "parts-included",
            EventId::Reconfigured => "reconfigured",
            EventId::FrameRejected => "frame-rejected",
            EventId::SetsLost => "sets-lost",
        }
    }
}

/// An event report (TM[5,x]): identifier and two auxiliary words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Event {
    /// What happened.
    pub id: EventId,
    /// First auxiliary word.
    pub a: u32,
    /// Second auxiliary word.
    pub b: u32,
}

/// Application data length of an event report.
pub const EVENT_LEN: usize = 10;

impl Event {
    /// Encodes the application data.
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let mut p = Put::new(out);
        p.u16(self.id as u16).u32(self.a).u32(self.b);
        p.finish()
    }
}

/// Why a telecommand was rejected (the failure code of TM[1,2] / TM[1,8]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
pub enum FailureCode {
    /// Shorter than its headers, or than its packet length field says.
    Truncated = 1,
    /// Octets after the end the packet length field gives.
    TrailingOctets = 2,
    /// The packet error control (CRC-16-CCITT) does not match.
    Checksum = 3,
    /// Not a telecommand: packet type TM, no secondary header, or segmented.
    NotTelecommand = 4,
    /// PUS version other than PUS-C (2).
    PusVersion = 5,
    /// Addressed to another application process.
    WrongApid = 6,
    /// Service or subtype not implemented: data = service·2⁸ + subtype.
    UnknownCommand = 7,
    /// Application data of the wrong length: data = the expected length.
    DataLength = 8,
    /// A field out of range: data = the field index (from 0).
    OutOfRange = 9,
    /// A real field is NaN or infinite: data = the field index.
    NotFinite = 10,
    /// The estimator refused the new configuration (it keeps the old one): data = the
    /// reason (see [`config_error_code`]).
    Refused = 11,
}

impl FailureCode {
    /// The code of a raw value.
    pub fn from_u16(v: u16) -> Option<Self> {
        use FailureCode::*;
        [
            Truncated,
            TrailingOctets,
            Checksum,
            NotTelecommand,
            PusVersion,
            WrongApid,
            UnknownCommand,
            DataLength,
            OutOfRange,
            NotFinite,
            Refused,
        ]
        .into_iter()
        .find(|c| *c as u16 == v)
    }

    /// Short description for decoded logs.
    pub fn describe(self) -> &'static str {
        match self {
            FailureCode::Truncated => "truncated",
            FailureCode::TrailingOctets => "octets after the packet",
            FailureCode::Checksum => "checksum mismatch",
            FailureCode::NotTelecommand => "not an unsegmented telecommand",
            FailureCode::PusVersion => "not PUS-C",
            FailureCode::WrongApid => "wrong APID",
            FailureCode::UnknownCommand => "unknown service or subtype",
            FailureCode::DataLength => "wrong application data length",
            FailureCode::OutOfRange => "field out of range",
            FailureCode::NotFinite => "field not finite",
            FailureCode::Refused => "refused by the estimator",
        }
    }
}

/// The failure data of [`FailureCode::Refused`]: which check of the estimator failed
/// (high 16 bits) and the channel or unknown it names (low 16 bits).
pub fn config_error_code(e: &estimator_core::ConfigError) -> u32 {
    use estimator_core::ConfigError as E;
    let (kind, detail): (u32, usize) = match *e {
        E::TooManyChannels { capacity } => (1, capacity),
        E::PositionNotFinite { channel } => (2, channel),
        E::AxisNotFinite { channel } => (3, channel),
        E::AxisZero { channel } => (4, channel),
        E::NoiseInvalid { channel } => (5, channel),
        E::TooFewChannels { have, .. } => (6, have),
        E::NoSuchChannel { channel } => (7, channel),
        E::NotObservable { .. } => (8, 0),
        E::Degenerate { involved, .. } => (9, usize::from(involved)),
        E::NotFinite { .. } => (10, 0),
    };
    (kind << 16) | (detail as u32 & 0xFFFF)
}

/// Request identifier of a telecommand: its packet ID and sequence control words.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RequestId {
    /// Packet version, type, secondary header flag, APID.
    pub packet_id: u16,
    /// Sequence flags and count.
    pub sequence: u16,
}

impl RequestId {
    /// The identifier in the first four octets of a packet, if there are four.
    pub fn of(raw: &[u8]) -> Option<Self> {
        let mut g = Get::new(raw);
        Some(RequestId {
            packet_id: g.u16()?,
            sequence: g.u16()?,
        })
    }
}

/// A verification report (TM[1,x]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Verification {
    /// 1 accepted, 2 not accepted, 7 completed, 8 not completed.
    pub subtype: u8,
    /// The telecommand.
    pub request: RequestId,
    /// Failure code and data (subtypes 2 and 8).
    pub failure: Option<(FailureCode, u32)>,
}

impl Verification {
    /// Encodes the application data.
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let mut p = Put::new(out);
        p.u16(self.request.packet_id).u16(self.request.sequence);
        if let Some((code, data)) = self.failure {
            p.u16(code as u16).u32(data);
        }
        p.finish()
    }
}

/// One decoded telemetry packet.
#[derive(Clone, Debug)]
pub enum Report {
    /// TM[3,25] SID 1.
    Motion(MotionReport),
    /// TM[3,25] SID 2.
    Housekeeping(Housekeeping),
    /// TM[5,x].
    Event(Event),
    /// TM[1,x].
    Verification(Verification),
    /// TM[17,2].
    Alive,
}

/// A decoded packet: header fields and content.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// CCSDS sequence count (14 bits).
    pub sequence: u16,
    /// Time stamp, s since boot.
    pub t: f64,
    /// Service and subtype.
    pub service: (u8, u8),
    /// The content.
    pub report: Report,
}

/// Why a packet could not be decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// Not a PUS-C telemetry packet of its stated length, or the CRC does not match.
    Packet,
    /// Another APID.
    Apid(u16),
    /// The time field is not CUC 4+3 with the unit's P-field.
    Time,
    /// An unknown service, subtype, SID or event.
    Unknown(u8, u8),
    /// Application data of the wrong length or with an invalid field.
    Data(u8, u8),
}

impl core::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            DecodeError::Packet => write!(f, "not a PUS-C TM packet (length or CRC)"),
            DecodeError::Apid(a) => write!(f, "APID {a:#05x} is not the ballistometer's"),
            DecodeError::Time => write!(f, "time field is not CUC 4+3 (P-field 0x2F)"),
            DecodeError::Unknown(s, t) => write!(f, "unknown report TM[{s},{t}]"),
            DecodeError::Data(s, t) => write!(f, "TM[{s},{t}]: malformed application data"),
        }
    }
}

/// Decodes one packet (checks length, CRC, APID and layout).
pub fn decode(raw: &[u8]) -> Result<Decoded, DecodeError> {
    let tm = PusTmReader::new(raw, TIME_LEN).map_err(|_| DecodeError::Packet)?;
    if tm.len_packed() != raw.len() || !tm.is_tm() {
        return Err(DecodeError::Packet);
    }
    let apid = tm.apid().value();
    if apid != APID {
        return Err(DecodeError::Apid(apid));
    }
    let t = cuc_seconds(tm.timestamp()).ok_or(DecodeError::Time)?;
    let (s, st) = (tm.service_type_id(), tm.message_subtype_id());
    let data = tm.source_data();
    let mut g = Get::new(data);
    let bad = DecodeError::Data(s, st);
    let report = match (s, st) {
        (service::HOUSEKEEPING, subtype::HK_REPORT) => match g.u16().ok_or(bad)? {
            sid::MOTION if data.len() == MOTION_LEN => {
                let k = g.u32().ok_or(bad)?;
                let mut m = MotionReport::decode(&mut g).ok_or(bad)?;
                m.k = k;
                Report::Motion(m)
            }
            sid::HOUSEKEEPING if data.len() == HOUSEKEEPING_LEN => {
                Report::Housekeeping(Housekeeping::decode(&mut g).ok_or(bad)?)
            }
            sid::MOTION | sid::HOUSEKEEPING => return Err(bad),
            _ => return Err(DecodeError::Unknown(s, st)),
        },
        (service::EVENT, 1..=4) => {
            let id = g.u16().ok_or(bad)?;
            let id = EventId::from_u16(id).ok_or(DecodeError::Unknown(s, st))?;
            if data.len() != EVENT_LEN || id.severity() != st {
                return Err(bad);
            }
            Report::Event(Event {
                id,
                a: g.u32().ok_or(bad)?,
                b: g.u32().ok_or(bad)?,
            })
        }
        (service::VERIFICATION, subtype::ACCEPTED | subtype::COMPLETED)
        | (service::VERIFICATION, subtype::NOT_ACCEPTED | subtype::NOT_COMPLETED) => {
            let request = RequestId::of(data).ok_or(bad)?;
            g = Get::new(&data[4..]);
            let failure = if st == subtype::NOT_ACCEPTED || st == subtype::NOT_COMPLETED {
                let code = FailureCode::from_u16(g.u16().ok_or(bad)?).ok_or(bad)?;
                Some((code, g.u32().ok_or(bad)?))
            } else {
                None
            };
            if g.remaining() != 0 {
                return Err(bad);
            }
            Report::Verification(Verification {
                subtype: st,
                request,
                failure,
            })
        }
        (service::TEST, subtype::ALIVE) if data.is_empty() => Report::Alive,
        (service::TEST, subtype::ALIVE) => return Err(bad),
        _ => return Err(DecodeError::Unknown(s, st)),
    };
    Ok(Decoded {
        sequence: tm.seq_count().value(),
        t,
        service: (s, st),
        report,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cuc_round_trips_to_the_fine_resolution() {
        for t in [
            0u64,
            1,
            999_999_999,
            1_000_000_000,
            12_345_678_901,
            86_400_000_000_017,
        ] {
            let s = cuc_seconds(&cuc(t)).unwrap();
            assert!(
                (s - t as f64 / 1e9).abs() <= 0.5 / f64::from(1u32 << 24) + 1e-12,
                "{t}"
            );
        }
        assert_eq!(cuc(9_999_999_999)[1..], [0, 0, 0, 10, 0, 0, 0]);
        assert_eq!(cuc_seconds(&[0x2E, 0, 0, 0, 1, 0, 0, 0]), None);
    }

    #[test]
    fn layouts_have_their_documented_lengths() {
        let mut buf = [0u8; TM_MAX];
        assert_eq!(
            Housekeeping::default().encode(&mut buf),
            Some(HOUSEKEEPING_LEN)
        );
        let m = MotionReport {
            k: 1,
            estimate: Estimate::default(),
            missing_parts: 0,
            excluded_parts: 0,
            excluded_channels: 0,
        };
        assert_eq!(m.encode(&mut buf), Some(MOTION_LEN));
        let e = Event {
            id: EventId::Boot,
            a: 0,
            b: 0,
        };
        assert_eq!(e.encode(&mut buf), Some(EVENT_LEN));
        assert_eq!(m.encode(&mut buf[..MOTION_LEN - 1]), None);
    }
}
