//! Event reports, TM[5,x]: the subtype is the severity.

use crate::codec::Put;
use crate::housekeeping::ResetCause;

/// Event identifiers (TM[5,x]); the subtype is the severity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u16)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EventId {
    /// The unit started: `a` = telemetry format·2²⁴ + version (major·2¹⁶ + minor·2⁸ + patch;
    /// the format octet is 0 in streams before format 2, [`crate::ids::FORMAT_VERSION`]),
    /// `b` = boot count·2¹⁶ (boots since power-on, at most 65 535; housekeeping has the whole
    /// count) + reset cause·2⁸ (`housekeeping::ResetCause`) + channels (format 2; channels
    /// alone before it).
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
    /// A calibration was committed to the store (TC[200,11]); it is used from the next boot:
    /// `a` = calibration id, `b` = its record's CRC-32.
    CalibrationStored = 10,
    /// Channels were excluded or included by command (TC[200,4/5]; format 2): `a` = the
    /// commanded exclusions before, `b` = after (bit per channel).
    ChannelsCommanded = 11,
    /// The fault monitor isolated a part from the measurements (it is taken out of
    /// the solve: a `parts-excluded` event follows): `a` = part slot, `b` = its channels (bits).
    PartIsolated = 12,
    /// The readings are inconsistent and no part is isolated (flag 64 on the estimates from
    /// here): `a` = 1 when it starts, 0 when it ends; `b` = the window's χ² over its limit, in
    /// thousandths.
    FaultSuspected = 13,
    /// The model in force changed without a command: exclusions left the configured
    /// model G unobservable and the estimate is made in model F, or the channels carry model G
    /// again. `a` = the model before, `b` = after (0 general, 1 free float; the motion reports
    /// and housekeeping carry the model in force).
    ModelSwitched = 14,
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
            CalibrationStored,
            ChannelsCommanded,
            PartIsolated,
            FaultSuspected,
            ModelSwitched,
        ]
        .into_iter()
        .find(|e| *e as u16 == v)
    }

    /// Severity = the TM[5,x] subtype: 1 informative, 2 low, 3 medium, 4 high.
    pub fn severity(self) -> u8 {
        match self {
            EventId::PartDown
            | EventId::FrameRejected
            | EventId::SetsLost
            | EventId::FaultSuspected => 2,
            EventId::PartsExcluded | EventId::PartIsolated | EventId::ModelSwitched => 3,
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
            EventId::CalibrationStored => "calibration-stored",
            EventId::ChannelsCommanded => "channels-commanded",
            EventId::PartIsolated => "part-isolated",
            EventId::FaultSuspected => "fault-suspected",
            EventId::ModelSwitched => "model-switched",
        }
    }
}

/// The boot event's two words ([`EventId::Boot`]), packed by the firmware and unpacked by the
/// ground segment with the same code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BootEvent {
    /// Telemetry format ([`crate::ids::FORMAT_VERSION`]; 0 in streams before format 2).
    pub format: u8,
    /// Software version: major, minor, patch.
    pub version: [u8; 3],
    /// Channels of the arrangement in use.
    pub channels: u8,
    /// Why the unit reset (format 2; [`ResetCause::Unknown`] before it).
    pub cause: ResetCause,
    /// Boots since power-on, this one included, at most 65 535 (format 2; 0 before it;
    /// housekeeping carries the whole count).
    pub count: u16,
}

impl BootEvent {
    /// The event's words `a` and `b`: `a` = format·2²⁴ + major·2¹⁶ + minor·2⁸ + patch, `b` =
    /// count·2¹⁶ + cause·2⁸ + channels.
    pub fn words(&self) -> (u32, u32) {
        let [major, minor, patch] = self.version;
        (
            u32::from_be_bytes([self.format, major, minor, patch]),
            (u32::from(self.count) << 16) | ((self.cause as u32) << 8) | u32::from(self.channels),
        )
    }

    /// The boot event of words `a` and `b`, in the layout of the format `a` names (before
    /// format 2, `b` is the channels alone). An unknown reset cause decodes as
    /// [`ResetCause::Unknown`].
    pub fn from_words(a: u32, b: u32) -> Self {
        let [format, major, minor, patch] = a.to_be_bytes();
        let [count_hi, count_lo, cause, channels] = b.to_be_bytes();
        if format >= 2 {
            BootEvent {
                format,
                version: [major, minor, patch],
                channels,
                cause: ResetCause::try_from(cause).unwrap_or_default(),
                count: u16::from_be_bytes([count_hi, count_lo]),
            }
        } else {
            BootEvent {
                format,
                version: [major, minor, patch],
                channels: u8::try_from(b).unwrap_or(u8::MAX),
                cause: ResetCause::Unknown,
                count: 0,
            }
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

#[cfg(test)]
mod boot_event_tests {
    use super::*;

    #[test]
    fn the_boot_event_round_trips_and_reads_the_older_layout() {
        let e = BootEvent {
            format: 2,
            version: [1, 4, 7],
            channels: 12,
            cause: ResetCause::Software,
            count: 2,
        };
        let (a, b) = e.words();
        assert_eq!((a, b), (0x0201_0407, 0x0002_030C));
        assert_eq!(BootEvent::from_words(a, b), e);
        // Format 1: `b` is the channels alone, no count or cause.
        let old = BootEvent::from_words(0x0001_0407, 24);
        assert_eq!((old.format, old.channels, old.count), (0, 24, 0));
        assert_eq!(old.cause, ResetCause::Unknown);
        // A cause this decoder does not know.
        assert_eq!(
            BootEvent::from_words(a, 0x0002_FF0C).cause,
            ResetCause::Unknown
        );
    }
}
