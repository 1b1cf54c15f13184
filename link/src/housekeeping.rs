//! The housekeeping report, TM[3,25] SID 2: mode, model, rates, the loop's and every part's
//! counters, the link's counters, the identity of the calibration in use, and the
//! boot count, the reset cause and the time correlation (telemetry format 2). Each addition is
//! at the end; the decoder still reads the layouts before it.

use crate::codec::{Get, Put};
use crate::ids::{sid, PART_SLOTS};
use crate::masks::{ChannelSet, PartSet};

/// State of one part in the housekeeping report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PartState {
    /// No part configured in this slot.
    #[default]
    Absent = 0,
    /// Configured and being read.
    Running = 1,
    /// Configured, not answering (marked down, restarted periodically).
    Down = 2,
}

impl TryFrom<u8> for PartState {
    type Error = u8;

    fn try_from(v: u8) -> Result<Self, u8> {
        match v {
            0 => Ok(PartState::Absent),
            1 => Ok(PartState::Running),
            2 => Ok(PartState::Down),
            _ => Err(v),
        }
    }
}

/// Where the calibration in use comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationSource {
    /// The built-in arrangement: no stored calibration is in use.
    #[default]
    Builtin = 0,
    /// The newest calibration record in flash.
    Flash = 1,
    /// An arrangement loaded by command (TC[200,6]); its CRC is the CRC-32 of the command's
    /// application data.
    Commanded = 2,
}

impl TryFrom<u8> for CalibrationSource {
    type Error = u8;

    fn try_from(v: u8) -> Result<Self, u8> {
        match v {
            0 => Ok(CalibrationSource::Builtin),
            1 => Ok(CalibrationSource::Flash),
            2 => Ok(CalibrationSource::Commanded),
            _ => Err(v),
        }
    }
}

/// The identity of the calibration in use: its source, calibration id and the CRC-32 its
/// record carries (id and CRC 0 for the built-in one; id 0 and the CRC-32 of the command's data
/// for a commanded one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationId {
    /// Where it comes from.
    pub source: CalibrationSource,
    /// Calibration id (monotonic; 0: built-in).
    pub id: u32,
    /// CRC-32 of its record (0: built-in).
    pub crc: u32,
}

/// Why the unit last started (the board reads it from its reset controller).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResetCause {
    /// The board cannot tell.
    #[default]
    Unknown = 0,
    /// Power was applied (power-on or brown-out reset): nothing in RAM survived.
    PowerOn = 1,
    /// The reset pin.
    Pin = 2,
    /// Software: the unit reset itself (after a calibration commit, or a debugger).
    Software = 3,
    /// A watchdog expired.
    Watchdog = 4,
    /// Another cause (low-power management, lockup).
    Other = 5,
}

impl ResetCause {
    /// The name used in decoded logs.
    pub fn name(self) -> &'static str {
        match self {
            ResetCause::Unknown => "unknown",
            ResetCause::PowerOn => "power-on",
            ResetCause::Pin => "pin",
            ResetCause::Software => "software",
            ResetCause::Watchdog => "watchdog",
            ResetCause::Other => "other",
        }
    }
}

impl TryFrom<u8> for ResetCause {
    type Error = u8;

    fn try_from(v: u8) -> Result<Self, u8> {
        use ResetCause::*;
        [Unknown, PowerOn, Pin, Software, Watchdog, Other]
            .into_iter()
            .find(|c| *c as u8 == v)
            .ok_or(v)
    }
}

/// The consistency test the fault monitor runs on the readings (issue 17: "say when no test is
/// possible"). Where there is none, nothing checks the estimate against the readings'
/// redundancy: a part's fault that its bus and its own signal do not show goes through.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConsistencyTest {
    /// No test possible with the channels in use (model F on nine channels).
    #[default]
    None = 0,
    /// The parity space (13 channels or more): tests, and isolates a part.
    Parity = 1,
    /// Model G's consistency with the known Γ (12 channels): tests.
    KnownField = 2,
    /// Model F's own residual, windowed (10–12 channels): tests.
    OwnResidual = 3,
    /// The image carries no fault monitor (images before the one build; kept so that
    /// their telemetry still decodes).
    NotBuilt = 255,
}

impl ConsistencyTest {
    /// The name used in decoded logs.
    pub fn name(self) -> &'static str {
        match self {
            ConsistencyTest::None => "none-possible",
            ConsistencyTest::Parity => "parity",
            ConsistencyTest::KnownField => "known-field",
            ConsistencyTest::OwnResidual => "own-residual",
            ConsistencyTest::NotBuilt => "not-built",
        }
    }
}

impl TryFrom<u8> for ConsistencyTest {
    type Error = u8;

    fn try_from(v: u8) -> Result<Self, u8> {
        use ConsistencyTest::*;
        [None, Parity, KnownField, OwnResidual, NotBuilt]
            .into_iter()
            .find(|c| *c as u8 == v)
            .ok_or(v)
    }
}

/// The unit's boots: how many since power was applied, and why the last one happened.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BootInfo {
    /// Boots since power was applied, this one included (1 after a power-on; kept in RAM that
    /// survives a reset, not a power loss).
    pub count: u32,
    /// Why this boot happened.
    pub cause: ResetCause,
}

/// What the time stamps of the unit's packets (CUC, seconds since its boot) are correlated to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimeCorrelation {
    /// `true` once TC[9,128] has set it; `false`: the unit's own scale only (`epoch` 0).
    pub set: bool,
    /// The spacecraft time of the unit's boot as a CUC 4+3 T-field (4 octets of seconds, 3 of
    /// 2⁻²⁴ s, big-endian): a packet stamped `t` (since boot) was made at spacecraft time
    /// [`Self::epoch_seconds`] + `t`. Kept as the octets sent (no conversion on board).
    pub epoch: [u8; 7],
}

impl TimeCorrelation {
    /// The correlation of a boot at spacecraft time `ticks` (2⁻²⁴ s; the low 56 bits).
    pub fn at(ticks: u64) -> Self {
        let [_, t @ ..] = ticks.to_be_bytes();
        TimeCorrelation {
            set: true,
            epoch: t,
        }
    }

    /// The spacecraft time of the unit's boot, 2⁻²⁴ s ticks.
    pub fn epoch_ticks(&self) -> u64 {
        let [e0, e1, e2, e3, e4, e5, e6] = self.epoch;
        u64::from_be_bytes([0, e0, e1, e2, e3, e4, e5, e6])
    }

    /// The spacecraft time of the unit's boot, seconds.
    pub fn epoch_seconds(&self) -> f64 {
        self.epoch_ticks() as f64 / f64::from(1u32 << 24)
    }
}

/// The sampling loop's counters (since boot).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoopCounters {
    /// Sample sets produced.
    pub sets: u32,
    /// Instants skipped (a set overran its period).
    pub skipped: u32,
    /// Sets dropped (the estimation queue was full).
    pub dropped: u32,
    /// SYNC line failures.
    pub sync_errors: u32,
}

/// One part slot's state and counters (since boot).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PartCounters {
    /// Absent, running or down.
    pub state: PartState,
    /// Reads.
    pub reads: u32,
    /// Bus errors.
    pub bus_errors: u32,
    /// Implausible transfers (bits that always read zero were not).
    pub implausible: u32,
    /// Sample sets without a new value.
    pub missed: u32,
    /// Failed starts.
    pub failed_starts: u32,
    /// Conversion-clock resynchronisations.
    pub resyncs: u32,
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
    pub sampling: LoopCounters,
    /// Estimates computed.
    pub estimates: u32,
    /// Parts excluded automatically.
    pub excluded_parts: PartSet,
    /// Channels excluded by command.
    pub commanded_out: ChannelSet,
    /// Channels not in the solve, commanded or automatic.
    pub excluded_channels: ChannelSet,
    /// Telecommands accepted (their execution may still fail: TM[1,8]).
    pub tc_accepted: u32,
    /// Telecommands refused at acceptance (TM[1,2] sent, or a frame too short to answer).
    pub tc_rejected: u32,
    /// Frames on the command link that were not a packet (noise, overlong, truncated).
    pub frames_garbage: u32,
    /// Telemetry packets the link failed to take.
    pub tm_lost: u32,
    /// Per part slot: its state and counters.
    pub parts: [PartCounters; PART_SLOTS],
    /// The calibration in use (`None` when decoded from the layout before it).
    pub calibration: Option<CalibrationId>,
    /// Boot count and reset cause, and the time correlation (`None` when decoded from a layout
    /// before telemetry format 2).
    pub boot: Option<(BootInfo, TimeCorrelation)>,
    /// The consistency test on the readings (`None` when decoded from the layout before it).
    pub test: Option<ConsistencyTest>,
    /// Per part slot, the part's last temperature read (°C; NaN where none: no part, not
    /// read yet); `None` when decoded from a layout before telemetry format 5.
    pub temperatures: Option<[f32; PART_SLOTS]>,
}

/// Application data length of the housekeeping report.
pub const HOUSEKEEPING_LEN: usize = HOUSEKEEPING_LEN_NO_TEMPERATURE + 4 * PART_SLOTS;
/// Application data length of the layout before the temperatures (telemetry format 5, issue
/// 50; still decoded).
pub const HOUSEKEEPING_LEN_NO_TEMPERATURE: usize = HOUSEKEEPING_LEN_NO_TEST + 1;
/// Application data length of the layout before the consistency test (still decoded).
pub const HOUSEKEEPING_LEN_NO_TEST: usize = HOUSEKEEPING_LEN_NO_BOOT + 4 + 1 + 1 + 7;
/// Application data length of the layout before the boot and time fields (format 1).
pub const HOUSEKEEPING_LEN_NO_BOOT: usize = HOUSEKEEPING_LEN_NO_CALIBRATION + 9;
/// Application data length of the layout before the calibration identity (still decoded).
pub const HOUSEKEEPING_LEN_NO_CALIBRATION: usize = 2 + 6 + 4 + 4 + 20 + 1 + 8 + 16 + 8 * 25;

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
            .u8(self.excluded_parts.0)
            .u32(self.commanded_out.0)
            .u32(self.excluded_channels.0)
            .u32(self.tc_accepted)
            .u32(self.tc_rejected)
            .u32(self.frames_garbage)
            .u32(self.tm_lost);
        for c in &self.parts {
            p.u8(c.state as u8)
                .u32(c.reads)
                .u32(c.bus_errors)
                .u32(c.implausible)
                .u32(c.missed)
                .u32(c.failed_starts)
                .u32(c.resyncs);
        }
        let cal = self.calibration.unwrap_or_default();
        p.u8(cal.source as u8).u32(cal.id).u32(cal.crc);
        let (boot, time) = self.boot.unwrap_or_default();
        p.u32(boot.count)
            .u8(boot.cause as u8)
            .u8(u8::from(time.set))
            .bytes(&time.epoch)
            .u8(self.test.unwrap_or_default() as u8)
            .f32s(&self.temperatures.unwrap_or([f32::NAN; PART_SLOTS]));
        p.finish()
    }

    /// Decodes the application data after the SID, of length `len`: [`HOUSEKEEPING_LEN`] or
    /// one of the layouts before it ([`HOUSEKEEPING_LEN_NO_TEMPERATURE`],
    /// [`HOUSEKEEPING_LEN_NO_TEST`], [`HOUSEKEEPING_LEN_NO_BOOT`],
    /// [`HOUSEKEEPING_LEN_NO_CALIBRATION`]), which lack the fields added at their end.
    #[cfg_attr(not(feature = "ground"), allow(dead_code))]
    pub(crate) fn decode(g: &mut Get, len: usize) -> Option<Self> {
        let mut h = Housekeeping {
            version: g.array()?,
            mode: g.u8()?,
            model: g.u8()?,
            channels: g.u8()?,
            rate_hz: g.f32()?,
            motion_every: g.u16()?,
            housekeeping_every: g.u16()?,
            sampling: LoopCounters {
                sets: g.u32()?,
                skipped: g.u32()?,
                dropped: g.u32()?,
                sync_errors: g.u32()?,
            },
            estimates: g.u32()?,
            excluded_parts: PartSet(g.u8()?),
            commanded_out: ChannelSet(g.u32()?),
            excluded_channels: ChannelSet(g.u32()?),
            tc_accepted: g.u32()?,
            tc_rejected: g.u32()?,
            frames_garbage: g.u32()?,
            tm_lost: g.u32()?,
            ..Housekeeping::default()
        };
        for slot in h.parts.iter_mut() {
            *slot = PartCounters {
                state: PartState::try_from(g.u8()?).ok()?,
                reads: g.u32()?,
                bus_errors: g.u32()?,
                implausible: g.u32()?,
                missed: g.u32()?,
                failed_starts: g.u32()?,
                resyncs: g.u32()?,
            };
        }
        if len >= HOUSEKEEPING_LEN_NO_BOOT {
            h.calibration = Some(CalibrationId {
                source: CalibrationSource::try_from(g.u8()?).ok()?,
                id: g.u32()?,
                crc: g.u32()?,
            });
        }
        if len >= HOUSEKEEPING_LEN_NO_TEST {
            let boot = BootInfo {
                count: g.u32()?,
                cause: ResetCause::try_from(g.u8()?).ok()?,
            };
            let set = match g.u8()? {
                0 => false,
                1 => true,
                _ => return None,
            };
            let epoch = g.array::<7>()?;
            h.boot = Some((boot, TimeCorrelation { set, epoch }));
        }
        if len >= HOUSEKEEPING_LEN_NO_TEMPERATURE {
            h.test = Some(ConsistencyTest::try_from(g.u8()?).ok()?);
        }
        if len == HOUSEKEEPING_LEN {
            h.temperatures = Some(g.f32s()?);
        }
        Some(h)
    }
}
