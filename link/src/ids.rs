//! Identifiers of the link: the APID, the PUS services and subtypes, the housekeeping
//! structure IDs, the largest packets, the capacities the layouts are sized for.

/// Application process identifier of the ballistometer (telemetry and telecommands).
pub const APID: u16 = 0x0BA;

/// Longest telemetry packet the unit sends (the housekeeping report), octets.
pub const TM_MAX: usize = 344;
// The longest packet (housekeeping) fits the telemetry buffer.
const _: () =
    assert!(6 + 7 + crate::cuc::TIME_LEN + crate::housekeeping::HOUSEKEEPING_LEN + 2 <= TM_MAX);

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
    /// ST[09] time management.
    pub const TIME: u8 = 9;
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
    /// TC[9,128] set the unit's time correlation: the spacecraft time now (mission-specific
    /// subtype).
    pub const SET_TIME: u8 = 128;
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
    /// TC[200,8] start an identification window.
    pub const START_IDENTIFICATION: u8 = 8;
    /// TC[200,9] reference rate points.
    pub const REFERENCE_RATE: u8 = 9;
    /// TC[200,10] solve the identification and report it.
    pub const REPORT_IDENTIFICATION: u8 = 10;
    /// TC[200,11] commit a reported solution to the calibration store.
    pub const COMMIT_CALIBRATION: u8 = 11;
    /// TM[200,128] identification summary.
    pub const IDENTIFICATION_SUMMARY: u8 = 128;
    /// TM[200,129] one identified channel.
    pub const IDENTIFIED_CHANNEL: u8 = 129;
    /// TM[200,130] one channel's bias against temperature across the solved windows.
    pub const THERMAL_TRACK: u8 = 130;
}

/// Housekeeping structure identifiers (TM[3,25]).
pub mod sid {
    /// The motion report, one per sample set (or per decimation).
    pub const MOTION: u16 = 1;
    /// The housekeeping report.
    pub const HOUSEKEEPING: u16 = 2;
}

/// Part slots in the housekeeping report.
pub const PART_SLOTS: usize = 8;

/// Most channels an arrangement on the link has (TC[200,6]; channel masks are 32 bits).
pub const MAX_CHANNELS: usize = 24;

/// The telemetry format, carried in the boot event: 6 since the in-flight tracking (a
/// thermal track report TM[200,130] per channel after each solution); 5 since issue 50 (each
/// part's temperature at the end of housekeeping); 4 since issue 49 (the identification
/// summary's vector is ρ of paper eq. 12, the origin from the centre of mass, flagged in its
/// octet 3; it was the centre of mass from the origin); 3 since issue 48 (the protection levels at
/// the end of the motion report); 2 since the ground segment's list of issue 16 (the message
/// type counter, the boot count and reset cause, the time correlation, the mode and model in
/// the motion report, the commanded-exclusion event). Streams before 2 are format 1 (their
/// boot event has 0 in that octet).
pub const FORMAT_VERSION: u8 = 6;

/// Every telemetry message type the unit sends (service, subtype), in the order of its message
/// type counters (PUS-C TM secondary header, octets 9–10: one counter per type, from 0 at
/// boot, so the ground sees the loss of each kind of report).
pub const TM_TYPES: [(u8, u8); 13] = [
    (service::VERIFICATION, subtype::ACCEPTED),
    (service::VERIFICATION, subtype::NOT_ACCEPTED),
    (service::VERIFICATION, subtype::COMPLETED),
    (service::VERIFICATION, subtype::NOT_COMPLETED),
    (service::HOUSEKEEPING, subtype::HK_REPORT),
    (service::EVENT, 1),
    (service::EVENT, 2),
    (service::EVENT, 3),
    (service::EVENT, 4),
    (service::TEST, subtype::ALIVE),
    (service::BALLISTOMETER, subtype::IDENTIFICATION_SUMMARY),
    (service::BALLISTOMETER, subtype::IDENTIFIED_CHANNEL),
    (service::BALLISTOMETER, subtype::THERMAL_TRACK),
];

/// The index of a telemetry message type in [`TM_TYPES`] (its message type counter), or
/// `None` for a type the unit does not send.
pub fn tm_type_index(service: u8, subtype: u8) -> Option<usize> {
    TM_TYPES.iter().position(|&t| t == (service, subtype))
}
