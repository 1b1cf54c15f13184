//! Telecommands: a received packet → a [`Command`], or the reason it is rejected.
//!
//! Parsing is the PUS acceptance check: everything that can be said about a command without
//! executing it is checked here (header, length, CRC, APID, service, application data
//! length, every field's range), so that a command is either accepted whole or refused
//! with a [`FailureCode`] and nothing is touched. What only execution can find out (the
//! estimator refusing a geometry or a mask) is reported by the application as a completion
//! failure, and the estimator then keeps its previous configuration.
//!
//! [`build`] is the other side: a telecommand packet as the ground sends it, and
//! [`build_command`] the packet of a [`Command`] (its application data by
//! [`Command::encode`], the inverse of parsing).
//!
//! Application data layouts are in `docs/telemetry.md`.

use estimator_core::{Arrangement, Model};
use spacepackets::crc::CRC_CCITT_FALSE;
use spacepackets::ecss::tc::PusTcReader;
use spacepackets::ecss::PusError;

use crate::codec::{Get, Put};
use crate::identification;
use crate::ids::{service, sid, subtype, APID, MAX_CHANNELS};
use crate::mode::{Mode, ModelCode};
use crate::verification::{config_error_code, FailureCode, RequestId};

/// Largest rate-hint component accepted, rad/s.
pub const HINT_MAX: f32 = 50.0;
/// Largest position component accepted in a loaded arrangement, m.
pub const POSITION_MAX: f32 = 10.0;
/// Largest channel noise accepted in a loaded arrangement, m/s².
pub const NOISE_MAX: f32 = 10.0;
/// Most sample sets per motion report.
pub const MOTION_EVERY_MAX: u16 = 10_000;

/// Octets per channel in TC[200,6]: position (3 × f32), axis (3 × f32), noise (f32).
pub const CHANNEL_LEN: usize = 28;

/// One accepted command (borrowing the received packet), or one the ground builds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command<'a> {
    /// TC[200,1].
    SetMode(Mode),
    /// TC[200,2].
    SetModel(Model),
    /// TC[200,3]: Ω to settle sign and branch, rad/s (body frame).
    SetHint([f32; 3]),
    /// TC[200,4]: take a channel out of the solve.
    Exclude(u8),
    /// TC[200,5]: put a commanded-out channel back.
    Include(u8),
    /// TC[200,6]: a new geometry for the same channels (the application data, already
    /// checked; [`arrangement`] builds it).
    LoadArrangement(&'a [u8]),
    /// TC[200,7]: one motion report per `motion_every` sets, one housekeeping report per
    /// `housekeeping_every` sets.
    SetRates {
        /// Sets per motion report (1 = every set).
        motion_every: u16,
        /// Sets per housekeeping report.
        housekeeping_every: u16,
    },
    /// TC[200,8]: start accumulating an identification window (paper §6) with the field from
    /// a reference rate (TC[200,9]), or, with the body's inertia, from the motion of a
    /// torque-free tumble (source 2); what was accumulated before is dropped.
    StartIdentification {
        /// With a reference, its period as the bus sends it, ms (a longer interval between
        /// two points is a gap, not covered); in a tumble, the interval averaged into one kept set.
        period_ms: u16,
        /// The window's length from now, ms.
        window_ms: u32,
        /// Source 2: the body's inertia in the body frame, `[xx, yy, zz, xy, xz, yz]` (any unit:
        /// only the ratios matter); `None`: source 1, the reference.
        inertia: Option<[f32; 6]>,
    },
    /// TC[200,9]: reference rate points (the application data, already checked;
    /// [`crate::identification::points`] reads them).
    ReferenceRate(&'a [u8]),
    /// TC[200,10]: solve the window and report the solution (TM[200,128], TM[200,129] × N).
    ReportIdentification,
    /// TC[200,11]: commit the reported solution `solution` to the calibration store.
    CommitCalibration {
        /// The number TM[200,128] gave it.
        solution: u16,
    },
    /// TC[3,27] for the housekeeping structure (SID 2).
    ReportHousekeeping,
    /// TC[9,128]: the spacecraft time at the command's reception, a CUC 4+3 T-field read as
    /// one number of 2⁻²⁴ s ticks: the unit correlates its own time to it.
    SetTime(u64),
    /// TC[17,1].
    AreYouAlive,
}

impl Command<'_> {
    /// Its service and subtype: TC[s,st].
    pub fn kind(&self) -> (u8, u8) {
        let b = service::BALLISTOMETER;
        match self {
            Command::SetMode(_) => (b, subtype::SET_MODE),
            Command::SetModel(_) => (b, subtype::SET_MODEL),
            Command::SetHint(_) => (b, subtype::SET_HINT),
            Command::Exclude(_) => (b, subtype::EXCLUDE),
            Command::Include(_) => (b, subtype::INCLUDE),
            Command::LoadArrangement(_) => (b, subtype::LOAD_ARRANGEMENT),
            Command::SetRates { .. } => (b, subtype::SET_RATES),
            Command::StartIdentification { .. } => (b, subtype::START_IDENTIFICATION),
            Command::ReferenceRate(_) => (b, subtype::REFERENCE_RATE),
            Command::ReportIdentification => (b, subtype::REPORT_IDENTIFICATION),
            Command::CommitCalibration { .. } => (b, subtype::COMMIT_CALIBRATION),
            Command::ReportHousekeeping => (service::HOUSEKEEPING, subtype::HK_ONE_SHOT),
            Command::SetTime(_) => (service::TIME, subtype::SET_TIME),
            Command::AreYouAlive => (service::TEST, subtype::ARE_YOU_ALIVE),
        }
    }

    /// Writes its application data into `out` as [`parse`] reads it (the ground's side);
    /// returns the length, or `None` if `out` is too small. Whether the unit accepts it is
    /// [`parse`]'s to say: encoding checks nothing.
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let mut p = Put::new(out);
        match *self {
            Command::SetMode(m) => p.u8(m as u8),
            Command::SetModel(m) => p.u8(ModelCode::from(m) as u8),
            Command::SetHint(w) => p.f32s(&w),
            Command::Exclude(c) | Command::Include(c) => p.u8(c),
            Command::LoadArrangement(data) | Command::ReferenceRate(data) => p.bytes(data),
            Command::SetRates {
                motion_every,
                housekeeping_every,
            } => p.u16(motion_every).u16(housekeeping_every),
            Command::StartIdentification {
                period_ms,
                window_ms,
                inertia: None,
            } => p
                .u8(identification::SOURCE_REFERENCE)
                .u16(period_ms)
                .u32(window_ms),
            Command::StartIdentification {
                period_ms,
                window_ms,
                inertia: Some(j),
            } => p
                .u8(identification::SOURCE_TUMBLE)
                .u16(period_ms)
                .u32(window_ms)
                .f32s(&j),
            Command::CommitCalibration { solution } => p.u16(solution),
            Command::ReportHousekeeping => p.u8(1).u16(sid::HOUSEKEEPING),
            Command::SetTime(ticks) => p.bytes(&ticks.to_be_bytes()[1..]),
            Command::ReportIdentification | Command::AreYouAlive => &mut p,
        };
        p.finish()
    }
}

/// The application data of TC[200,6] for `channels` (position m, axis, noise m/s² each; the
/// inverse of [`arrangement`]) into `out`; `None` if `out` is too small or there are more
/// than [`MAX_CHANNELS`].
pub fn arrangement_data(
    channels: impl ExactSizeIterator<Item = ([f64; 3], [f64; 3], f64)>,
    out: &mut [u8],
) -> Option<usize> {
    let n = u8::try_from(channels.len())
        .ok()
        .filter(|n| usize::from(*n) <= MAX_CHANNELS)?;
    let mut p = Put::new(out);
    p.u8(n);
    for (position, axis, noise) in channels {
        p.f32s(&position.map(|v| v as f32))
            .f32s(&axis.map(|v| v as f32))
            .f32(noise as f32);
    }
    p.finish()
}

/// A command that passed acceptance.
#[derive(Clone, Copy, Debug)]
pub struct Accepted<'a> {
    /// Identifier for its verification reports.
    pub request: RequestId,
    /// Report successful acceptance (ack flag bit 3).
    pub ack_acceptance: bool,
    /// Report successful completion (ack flag bit 0).
    pub ack_completion: bool,
    /// What to do.
    pub command: Command<'a>,
}

/// A command refused at acceptance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rejected {
    /// Its identifier, if at least the primary header arrived.
    pub request: Option<RequestId>,
    /// Why.
    pub code: FailureCode,
    /// Detail (field index, expected length, ...; see [`FailureCode`]).
    pub data: u32,
}

/// What the unit is configured with, which the ranges of some fields depend on.
#[derive(Clone, Copy, Debug)]
pub struct Context {
    /// Channels the parts feed (an arrangement must have exactly these).
    pub channels: usize,
}

const PRIMARY_LEN: usize = 6;
const SECONDARY_LEN: usize = 5;
const CRC_LEN: usize = 2;

/// Acceptance of one received packet.
pub fn parse(raw: &[u8], ctx: Context) -> Result<Accepted<'_>, Rejected> {
    let reject = |request, code, data| Rejected {
        request,
        code,
        data,
    };
    if raw.len() < PRIMARY_LEN {
        return Err(reject(None, FailureCode::Truncated, raw.len() as u32));
    }
    let request = RequestId::of(raw);
    let fail = |code, data| Err(reject(request, code, data));
    let id = request.unwrap_or_default();
    let version = id.packet_id >> 13;
    let is_tc = id.packet_id & 0x1000 != 0;
    let has_secondary = id.packet_id & 0x0800 != 0;
    let unsegmented = id.sequence >> 14 == 0b11;
    if version != 0 || !is_tc || !has_secondary || !unsegmented {
        return fail(FailureCode::NotTelecommand, 0);
    }
    let length = PRIMARY_LEN + usize::from(u16::from_be_bytes([raw[4], raw[5]])) + 1;
    if raw.len() < length || length < PRIMARY_LEN + SECONDARY_LEN + CRC_LEN {
        return fail(FailureCode::Truncated, length as u32);
    }
    if raw.len() > length {
        return fail(FailureCode::TrailingOctets, length as u32);
    }
    let tc = match PusTcReader::new(raw) {
        Ok(tc) => tc,
        Err(PusError::ChecksumFailure(_)) => return fail(FailureCode::Checksum, 0),
        Err(_) => return fail(FailureCode::Truncated, length as u32),
    };
    if raw[PRIMARY_LEN] >> 4 != 2 {
        return fail(FailureCode::PusVersion, u32::from(raw[PRIMARY_LEN] >> 4));
    }
    if id.packet_id & 0x07FF != APID {
        return fail(FailureCode::WrongApid, u32::from(id.packet_id & 0x07FF));
    }
    let ack = raw[PRIMARY_LEN] & 0x0F;
    let (s, st) = (raw[PRIMARY_LEN + 1], raw[PRIMARY_LEN + 2]);
    let command = command(s, st, tc.app_data(), ctx).map_err(|(code, data)| Rejected {
        request,
        code,
        data,
    })?;
    Ok(Accepted {
        request: id,
        ack_acceptance: ack & 0b1000 != 0,
        ack_completion: ack & 0b0001 != 0,
        command,
    })
}

type Refusal = (FailureCode, u32);

/// The application data of TC[`s`,`st`].
fn command(s: u8, st: u8, data: &[u8], ctx: Context) -> Result<Command<'_>, Refusal> {
    let length = |n: usize| exact_length(data, n);
    let mut g = Get::new(data);
    match (s, st) {
        (service::BALLISTOMETER, subtype::SET_MODE) => {
            length(1)?;
            Mode::try_from(data[0])
                .map(Command::SetMode)
                .map_err(|_| (FailureCode::OutOfRange, 0))
        }
        (service::BALLISTOMETER, subtype::SET_MODEL) => {
            length(1)?;
            ModelCode::try_from(data[0])
                .map(|m| Command::SetModel(Model::from(m)))
                .map_err(|_| (FailureCode::OutOfRange, 0))
        }
        (service::BALLISTOMETER, subtype::SET_HINT) => {
            length(12)?;
            let w: [f32; 3] = g.f32s().ok_or((FailureCode::DataLength, 12))?;
            for (i, v) in w.iter().enumerate() {
                real(*v, i, HINT_MAX)?;
            }
            Ok(Command::SetHint(w))
        }
        (service::BALLISTOMETER, subtype::EXCLUDE | subtype::INCLUDE) => {
            length(1)?;
            if usize::from(data[0]) >= ctx.channels {
                return Err((FailureCode::OutOfRange, 0));
            }
            Ok(if st == subtype::EXCLUDE {
                Command::Exclude(data[0])
            } else {
                Command::Include(data[0])
            })
        }
        (service::BALLISTOMETER, subtype::LOAD_ARRANGEMENT) => {
            let n = usize::from(*data.first().ok_or((FailureCode::DataLength, 1))?);
            let expected = 1 + CHANNEL_LEN * n;
            if data.len() != expected {
                return Err((FailureCode::DataLength, expected as u32));
            }
            if n != ctx.channels {
                // The parts feed a fixed set of channels: another count cannot apply.
                return Err((FailureCode::OutOfRange, 0));
            }
            arrangement(data)?;
            Ok(Command::LoadArrangement(data))
        }
        (service::BALLISTOMETER, subtype::SET_RATES) => {
            length(4)?;
            let motion_every = g.u16().unwrap_or(0);
            let housekeeping_every = g.u16().unwrap_or(0);
            if !(1..=MOTION_EVERY_MAX).contains(&motion_every) {
                return Err((FailureCode::OutOfRange, 0));
            }
            if housekeeping_every == 0 {
                return Err((FailureCode::OutOfRange, 1));
            }
            Ok(Command::SetRates {
                motion_every,
                housekeeping_every,
            })
        }
        (service::BALLISTOMETER, subtype::START_IDENTIFICATION) => start_identification(data),
        (service::BALLISTOMETER, subtype::REFERENCE_RATE) => reference_rate(data),
        (service::BALLISTOMETER, subtype::REPORT_IDENTIFICATION) => {
            length(0)?;
            Ok(Command::ReportIdentification)
        }
        (service::BALLISTOMETER, subtype::COMMIT_CALIBRATION) => {
            length(2)?;
            Ok(Command::CommitCalibration {
                solution: g.u16().unwrap_or(0),
            })
        }
        (service::HOUSEKEEPING, subtype::HK_ONE_SHOT) => {
            // N, then N structure IDs; this unit has one housekeeping structure.
            let n = g.u8().ok_or((FailureCode::DataLength, 3))?;
            length(1 + 2 * usize::from(n))?;
            if n == 0 {
                return Err((FailureCode::OutOfRange, 0));
            }
            for i in 0..n {
                if g.u16() != Some(sid::HOUSEKEEPING) {
                    return Err((FailureCode::OutOfRange, 1 + u32::from(i)));
                }
            }
            Ok(Command::ReportHousekeeping)
        }
        (service::TIME, subtype::SET_TIME) => {
            // A CUC 4+3 T-field (the unit's P-field implied): every value is a time.
            length(7)?;
            let t: [u8; 7] = g.array().ok_or((FailureCode::DataLength, 7))?;
            let [t0, t1, t2, t3, t4, t5, t6] = t;
            Ok(Command::SetTime(u64::from_be_bytes([
                0, t0, t1, t2, t3, t4, t5, t6,
            ])))
        }
        (service::TEST, subtype::ARE_YOU_ALIVE) => {
            length(0)?;
            Ok(Command::AreYouAlive)
        }
        _ => Err((
            FailureCode::UnknownCommand,
            (u32::from(s) << 8) | u32::from(st),
        )),
    }
}

/// TC[200,8]'s data: the source (reference or torque-free tumble), the period and window,
/// and for a tumble the inertia (finite, positive definite).
fn start_identification(data: &[u8]) -> Result<Command<'_>, Refusal> {
    let length = |n: usize| exact_length(data, n);
    let mut g = Get::new(data);
    let source = *data.first().ok_or((FailureCode::DataLength, 7))?;
    match source {
        identification::SOURCE_REFERENCE => length(7)?,
        identification::SOURCE_TUMBLE => length(7 + 24)?,
        _ => return Err((FailureCode::OutOfRange, 0)),
    }
    g.u8();
    let period_ms = g.u16().unwrap_or(0);
    let window_ms = g.u32().unwrap_or(0);
    if !(1..=identification::PERIOD_MAX_MS).contains(&period_ms) {
        return Err((FailureCode::OutOfRange, 1));
    }
    if !(1..=identification::WINDOW_MAX_MS).contains(&window_ms) {
        return Err((FailureCode::OutOfRange, 2));
    }
    let inertia = if source == identification::SOURCE_TUMBLE {
        let j: [f32; 6] = g.f32s().unwrap_or([f32::NAN; 6]);
        for (k, v) in j.iter().enumerate() {
            real(*v, 3 + k, f32::MAX)?;
        }
        // Positive definite (Sylvester's leading minors), in f64.
        let [xx, yy, zz, xy, xz, yz] = j.map(f64::from);
        let minor2 = xx * yy - xy * xy;
        let det = xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz);
        if !(xx > 0.0 && minor2 > 0.0 && det > 0.0) {
            return Err((FailureCode::OutOfRange, 3));
        }
        Some(j)
    } else {
        None
    };
    Ok(Command::StartIdentification {
        period_ms,
        window_ms,
        inertia,
    })
}

/// TC[200,9]'s data: N points of a reference rate, their times increasing, their rates
/// finite and within the gyro's range.
fn reference_rate(data: &[u8]) -> Result<Command<'_>, Refusal> {
    let n = usize::from(*data.first().ok_or((FailureCode::DataLength, 1))?);
    let expected = 1 + identification::POINT_LEN * n;
    if data.len() != expected {
        return Err((FailureCode::DataLength, expected as u32));
    }
    if !(1..=identification::MAX_POINTS).contains(&n) {
        return Err((FailureCode::OutOfRange, 0));
    }
    // Field index 1 + 4·point + j: the time (j = 0), then Ω x, y, z.
    let mut last = None;
    for (i, chunk) in data[1..]
        .chunks_exact(identification::POINT_LEN)
        .enumerate()
    {
        let field = |j: usize| 1 + 4 * i + j;
        let mut time = [0u8; crate::cuc::TIME_LEN];
        time.copy_from_slice(&chunk[..crate::cuc::TIME_LEN]);
        let t = crate::cuc::cuc_nanos(&time).ok_or((FailureCode::OutOfRange, field(0) as u32))?;
        if last.is_some_and(|l| t <= l) {
            return Err((FailureCode::OutOfRange, field(0) as u32));
        }
        last = Some(t);
        let mut w = Get::new(&chunk[crate::cuc::TIME_LEN..]);
        let omega: [f32; 3] = w.f32s().ok_or((FailureCode::DataLength, 0))?;
        for (j, v) in omega.iter().enumerate() {
            real(*v, field(1 + j), identification::REFERENCE_MAX)?;
        }
    }
    Ok(Command::ReferenceRate(data))
}

/// Data of exactly `n` octets, or the refusal that names the length expected.
fn exact_length(data: &[u8], n: usize) -> Result<(), Refusal> {
    if data.len() == n {
        Ok(())
    } else {
        Err((FailureCode::DataLength, n as u32))
    }
}

/// A real field: finite and at most `max` in magnitude.
fn real(v: f32, field: usize, max: f32) -> Result<f64, Refusal> {
    if !v.is_finite() {
        return Err((FailureCode::NotFinite, field as u32));
    }
    if !(v.abs() <= max) {
        return Err((FailureCode::OutOfRange, field as u32));
    }
    Ok(f64::from(v))
}

/// The arrangement of TC[200,6] application data: N (u8), then per channel position, axis,
/// noise (7 × f32). Field indices count the reals from 0 after N: channel `c`, value `j` is
/// field `1 + 7c + j`.
pub fn arrangement(data: &[u8]) -> Result<Arrangement<MAX_CHANNELS>, (FailureCode, u32)> {
    let n = usize::from(*data.first().ok_or((FailureCode::DataLength, 1))?);
    let expected = 1 + CHANNEL_LEN * n;
    if data.len() != expected || n > MAX_CHANNELS {
        return Err((FailureCode::DataLength, expected as u32));
    }
    let mut g = Get::new(&data[1..]);
    let mut arr = Arrangement::<MAX_CHANNELS>::new();
    for c in 0..n {
        let v: [f32; 7] = g.f32s().ok_or((FailureCode::DataLength, expected as u32))?;
        let field = |j: usize| 1 + 7 * c + j;
        let mut position = [0.0; 3];
        let mut axis = [0.0; 3];
        for j in 0..3 {
            position[j] = real(v[j], field(j), POSITION_MAX)?;
            axis[j] = real(v[3 + j], field(3 + j), 1.0)?;
        }
        if axis.iter().map(|a| a * a).sum::<f64>() < 0.25 {
            // Not a unit vector by a wide margin (|s| < 0.5): a typo, not a rounding.
            return Err((FailureCode::OutOfRange, field(3) as u32));
        }
        let noise = real(v[6], field(6), NOISE_MAX)?;
        if !(noise > 0.0) {
            return Err((FailureCode::OutOfRange, field(6) as u32));
        }
        arr.push(position, axis, noise)
            .map_err(|e| (FailureCode::Refused, config_error_code(&e)))?;
    }
    Ok(arr)
}

/// Acknowledgement flags of a telecommand (the low nibble of its secondary header's first
/// octet): report successful acceptance.
pub const ACK_ACCEPTANCE: u8 = 0x8;
/// Acknowledgement flag: report successful completion.
pub const ACK_COMPLETION: u8 = 0x1;

/// Builds telecommand TC[`service`,`subtype`] with sequence count `sequence`, acknowledgement
/// flags `ack` ([`ACK_ACCEPTANCE`], [`ACK_COMPLETION`]), source ID 0 and application data
/// `data` into `out`: primary header, PUS-C secondary header, data, CRC. Returns the packet
/// length, or `None` if `out` is too small.
pub fn build(
    out: &mut [u8],
    sequence: u16,
    ack: u8,
    service: u8,
    subtype: u8,
    data: &[u8],
) -> Option<usize> {
    let at = PRIMARY_LEN + SECONDARY_LEN;
    out.get_mut(at..at + data.len())?.copy_from_slice(data);
    frame_packet(out, sequence, ack, (service, subtype), data.len())
}

/// Builds the telecommand packet of `command` ([`build`] with its kind and
/// [`Command::encode`]'s data): the ground's side of [`parse`].
pub fn build_command(out: &mut [u8], sequence: u16, ack: u8, command: &Command) -> Option<usize> {
    let n = command.encode(out.get_mut(PRIMARY_LEN + SECONDARY_LEN..)?)?;
    frame_packet(out, sequence, ack, command.kind(), n)
}

/// Writes the headers before and the CRC after `data_len` octets of application data that
/// are already in place in `out`; returns the packet length.
fn frame_packet(
    out: &mut [u8],
    sequence: u16,
    ack: u8,
    (service, subtype): (u8, u8),
    data_len: usize,
) -> Option<usize> {
    let len = PRIMARY_LEN + SECONDARY_LEN + data_len + CRC_LEN;
    let length_field = u16::try_from(len - 7).ok()?;
    let mut p = Put::new(out.get_mut(..PRIMARY_LEN + SECONDARY_LEN)?);
    // Version 0, type TC, secondary header; unsegmented.
    p.u16(0x1800 | APID)
        .u16(0xC000 | (sequence & 0x3FFF))
        .u16(length_field)
        .u8(0x20 | (ack & 0x0F))
        .u8(service)
        .u8(subtype)
        .u16(0);
    p.finish()?;
    let body = len - CRC_LEN;
    let crc = CRC_CCITT_FALSE.checksum(out.get(..body)?);
    out.get_mut(body..len)?.copy_from_slice(&crc.to_be_bytes());
    Some(len)
}

/// Runs the parser on arbitrary octets: the fuzz target's body (and the host tests' own
/// mutation run). Returns whether the packet was accepted.
pub fn fuzz_one(data: &[u8]) -> bool {
    let channels = data.first().map_or(12, |b| usize::from(b % 25));
    parse(data, Context { channels }).is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identification::{points_data, ReferencePoint};

    /// Every command the ground builds is accepted by the unit as that same command, and a
    /// buffer one octet short is refused rather than overrun.
    #[test]
    fn every_command_built_is_parsed_back_as_itself() {
        let mut arrangement = [0u8; 1 + 12 * CHANNEL_LEN];
        let channels = (0..12).map(|i| {
            let s = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]][i % 3];
            ([0.1 * (i / 3) as f64, -0.05, 0.02], s, 2e-3)
        });
        let n = arrangement_data(channels, &mut arrangement).unwrap();
        assert_eq!(n, arrangement.len());
        let points = [
            ReferencePoint {
                t: 1_000_000_000,
                omega: [0.1, -0.2, 0.3],
            },
            ReferencePoint {
                t: 1_050_000_000,
                omega: [0.1, -0.2, 0.35],
            },
        ];
        let mut reference = [0u8; 1 + 2 * identification::POINT_LEN];
        assert_eq!(points_data(&points, &mut reference), Some(reference.len()));
        let commands = [
            Command::SetMode(Mode::Standby),
            Command::SetModel(Model::FreeFloat),
            Command::SetHint([0.5, -1.0, 2.0]),
            Command::Exclude(3),
            Command::Include(11),
            Command::LoadArrangement(&arrangement),
            Command::SetRates {
                motion_every: 10,
                housekeeping_every: 500,
            },
            Command::StartIdentification {
                period_ms: 50,
                window_ms: 20_000,
                inertia: None,
            },
            Command::StartIdentification {
                period_ms: 80,
                window_ms: 20_000,
                inertia: Some([1.0, 1.8, 2.5, 0.0, -0.1, 0.0]),
            },
            Command::ReferenceRate(&reference),
            Command::ReportIdentification,
            Command::CommitCalibration { solution: 7 },
            Command::ReportHousekeeping,
            Command::SetTime(0x0001_0203_0405_0607),
            Command::AreYouAlive,
        ];
        for (i, c) in commands.iter().enumerate() {
            let mut out = [0u8; crate::ids::TC_MAX];
            let n = build_command(&mut out, i as u16, ACK_ACCEPTANCE, c).unwrap();
            let got = parse(&out[..n], Context { channels: 12 }).unwrap();
            assert_eq!(&got.command, c);
            assert_eq!(got.request.sequence & 0x3FFF, i as u16);
            assert!(got.ack_acceptance && !got.ack_completion);
            assert_eq!(build_command(&mut out[..n - 1], 0, 0, c), None);
        }
        // The points come back to the CUC's resolution (2⁻²⁴ s ≈ 60 ns).
        for (got, sent) in identification::points(&reference).zip(points.iter()) {
            assert!(got.t.abs_diff(sent.t) <= 30, "{got:?} {sent:?}");
            assert_eq!(got.omega, sent.omega);
        }
        assert_eq!(identification::points(&reference).count(), 2);
    }
}
