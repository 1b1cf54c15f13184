//! The ground decoder (feature `ground`): one telemetry packet → its report, every check made
//! (length, CRC, APID, time field, layout).

use spacepackets::ecss::tm::{GenericPusTmSecondaryHeader, PusTmReader};
use spacepackets::CcsdsPacket;

use crate::codec::Get;
use crate::cuc::{cuc_seconds, TIME_LEN};
use crate::event::{Event, EventId, EVENT_LEN};
use crate::housekeeping::{
    Housekeeping, HOUSEKEEPING_LEN, HOUSEKEEPING_LEN_NO_BOOT, HOUSEKEEPING_LEN_NO_CALIBRATION,
    HOUSEKEEPING_LEN_NO_TEMPERATURE, HOUSEKEEPING_LEN_NO_TEST,
};
use crate::identification::{IdentificationSummary, IdentifiedChannel, ThermalTrack};
use crate::ids::{service, sid, subtype, APID};
use crate::motion::{
    MotionReport, MOTION_LEN, MOTION_LEN_NO_CONTEXT, MOTION_LEN_NO_MARGIN, MOTION_LEN_NO_PROTECTION,
};
use crate::verification::{FailureCode, RequestId, Verification};

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
    /// TM[200,128].
    IdentificationSummary(IdentificationSummary),
    /// TM[200,129].
    IdentifiedChannel(IdentifiedChannel),
    /// TM[200,130].
    ThermalTrack(ThermalTrack),
}

/// A decoded packet: header fields and content.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// CCSDS sequence count (14 bits).
    pub sequence: u16,
    /// PUS message type counter: packets of this service and subtype before it since boot
    /// (telemetry format 2; always 0 in streams before it).
    pub type_counter: u16,
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
            sid::MOTION
                if [
                    MOTION_LEN,
                    MOTION_LEN_NO_PROTECTION,
                    MOTION_LEN_NO_CONTEXT,
                    MOTION_LEN_NO_MARGIN,
                ]
                .contains(&data.len()) =>
            {
                let k = g.u32().ok_or(bad)?;
                let mut m = MotionReport::decode(&mut g, data.len()).ok_or(bad)?;
                m.k = k;
                Report::Motion(m)
            }
            sid::HOUSEKEEPING
                if [
                    HOUSEKEEPING_LEN,
                    HOUSEKEEPING_LEN_NO_TEMPERATURE,
                    HOUSEKEEPING_LEN_NO_TEST,
                    HOUSEKEEPING_LEN_NO_BOOT,
                    HOUSEKEEPING_LEN_NO_CALIBRATION,
                ]
                .contains(&data.len()) =>
            {
                Report::Housekeeping(Housekeeping::decode(&mut g, data.len()).ok_or(bad)?)
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
        (service::BALLISTOMETER, subtype::IDENTIFICATION_SUMMARY) => {
            Report::IdentificationSummary(IdentificationSummary::decode(data).ok_or(bad)?)
        }
        (service::BALLISTOMETER, subtype::IDENTIFIED_CHANNEL) => {
            Report::IdentifiedChannel(IdentifiedChannel::decode(data).ok_or(bad)?)
        }
        (service::BALLISTOMETER, subtype::THERMAL_TRACK) => {
            Report::ThermalTrack(ThermalTrack::decode(data).ok_or(bad)?)
        }
        (service::TEST, subtype::ALIVE) if data.is_empty() => Report::Alive,
        (service::TEST, subtype::ALIVE) => return Err(bad),
        _ => return Err(DecodeError::Unknown(s, st)),
    };
    Ok(Decoded {
        sequence: tm.seq_count().value(),
        type_counter: tm.msg_type_counter(),
        t,
        service: (s, st),
        report,
    })
}
