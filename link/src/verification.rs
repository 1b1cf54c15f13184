//! Verification reports, TM[1,x], and the failure codes of a refused telecommand.

use crate::codec::{Get, Put};

/// Why a telecommand was rejected (the failure code of TM[1,2] / TM[1,8]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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
    /// The command does not apply in the unit's present state: data = the reason
    /// ([`not_ready`]).
    NotReady = 12,
    /// The calibration store failed; the stored calibration is the previous one: data = the
    /// reason ([`store_failed`]).
    StoreFailed = 13,
}

/// The data of [`FailureCode::NotReady`].
pub mod not_ready {
    /// No identification window was started.
    pub const NO_WINDOW: u32 = 1;
    /// The window's sums cannot be solved: too few sets (low 16 bits: sets).
    pub const TOO_FEW_SETS: u32 = 2 << 16;
    /// A channel's Gauss–Newton did not settle (low 16 bits: channel).
    pub const NOT_CONVERGED: u32 = 3 << 16;
    /// No solution was reported, or the solution named is not the last one reported.
    pub const NO_SUCH_SOLUTION: u32 = 4;
    /// A channel's residual exceeds 3 × its noise: the field does not explain it (a
    /// misaligned reference, a fault); low 16 bits: channel.
    pub const RESIDUAL_HIGH: u32 = 5 << 16;
    /// The unit has no writable calibration store.
    pub const NO_STORE: u32 = 6;
    /// A commit is still in progress.
    pub const STORE_BUSY: u32 = 7;
    /// The solution is not a valid arrangement (low 16 bits: the estimator's check, as
    /// [`super::config_error_code`]'s high half).
    pub const INVALID: u32 = 8 << 16;
    /// TC[9,128]: the spacecraft time given is earlier than the unit's own time since boot
    /// (the boot would precede the spacecraft's epoch).
    pub const TIME_BEFORE_BOOT: u32 = 9;
    /// A commanded configuration change (model, arrangement, channels) is still being built
    /// (the builder task of a board without a double-precision FPU): send it again later.
    pub const CONFIGURATION_BUSY: u32 = 10;
    /// The identification task has not yet taken the orders before this one (a solve under
    /// way, or a TC[200,10] not yet answered): send it again later.
    pub const IDENTIFICATION_BUSY: u32 = 11;
    /// The unit runs no identification task (a board that does not attach one).
    pub const NO_IDENTIFICATION_TASK: u32 = 12;
    /// A torque-free tumble's window does not determine a parameter: the start rate's
    /// uncertainty moves it by more than half its tolerance (bits 8–15: the parameter, as
    /// `estimator_core::identify::Param`; low 8 bits: the channel).
    pub const MOTION_UNCERTAIN: u32 = 13 << 16;
    /// A torque-free tumble's window determines fewer than half of the geometry (low 8 bits:
    /// the channel with the most parameters held; bits 8–15: the first of them, as
    /// `estimator_core::identify::Param`): a longer window, or a motion further from a spin about one axis.
    pub const NOT_EXCITED: u32 = 14 << 16;
    /// A torque-free tumble's window is explained at the noise by two motions whose geometries
    /// are apart by more than half a tolerance in a parameter both determine: it does not
    /// decide between them (a longer window, or another motion).
    pub const MOTION_AMBIGUOUS: u32 = 15 << 16;
    /// A tumble's window would not fit the unit's room for its means at the period given (low
    /// 16 bits: the longest window that fits, s): a shorter window, or a longer period.
    pub const WINDOW_TOO_LONG: u32 = 16 << 16;
}

/// The data of [`FailureCode::StoreFailed`].
pub mod store_failed {
    /// The flash or the map failed.
    pub const FLASH: u32 = 1;
    /// The stored record is damaged or not for this firmware: the newest id is unknown.
    pub const RECORD: u32 = 2;
    /// The record could not be encoded.
    pub const UNENCODABLE: u32 = 3;
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
            NotReady,
            StoreFailed,
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
            FailureCode::NotReady => "not applicable now",
            FailureCode::StoreFailed => "calibration store failed",
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
        E::CalibrationInvalid { channel } => (11, channel),
        E::FrameUncertaintyInvalid => (12, 0),
        E::NotPositive { .. } => (13, 0),
        E::NotProbability { .. } => (14, 0),
    };
    (kind << 16) | (detail as u32 & 0xFFFF)
}

/// Request identifier of a telecommand: its packet ID and sequence control words.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
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
