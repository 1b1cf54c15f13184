//! Building a telemetry packet: CCSDS primary header, PUS-C TM secondary header with the CUC
//! time, the application data (encoded in place by the caller) and the packet error control.

use arbitrary_int::{u11, u14};
use spacepackets::crc::CRC_CCITT_FALSE;
use spacepackets::{CcsdsPacket, SpHeader};

use crate::cuc::{cuc, TIME_LEN};
use crate::ids::{APID, TM_MAX};

/// Primary header, PUS-C TM secondary header and time field.
pub const HEADERS_LEN: usize = 6 + 7 + TIME_LEN;
/// The packet error control field.
pub const CRC_LEN: usize = 2;

/// Writes the primary header (`spacepackets`' field layout for an unsegmented TM packet of
/// `len` octets) and the PUS-C TM secondary header with the time field, octets
/// `0..HEADERS_LEN`. Written here rather than by `PusTmCreatorWithReservedSourceData`, whose
/// internal `unwrap`s link `core::fmt`'s `Debug` machinery (3.9 KB more flash with the
/// creator).
fn write_headers(
    packet: &mut [u8; TM_MAX],
    sequence: u16,
    counter: u16,
    len: usize,
    service: u8,
    subtype: u8,
    stamp: &[u8; TIME_LEN],
) {
    // `len` ≤ TM_MAX: the data length field (total − 7) fits its 16 bits.
    let data_len = (len - 7) as u16;
    let mut header =
        SpHeader::new_for_unseg_tm(u11::new(APID), u14::new(sequence & 0x3FFF), data_len);
    header.set_sec_header_flag();
    let [id0, id1] = header.packet_id().raw().to_be_bytes();
    let [sc0, sc1] = header.psc().raw().to_be_bytes();
    let [dl0, dl1] = header.data_len().to_be_bytes();
    let [t0, t1, t2, t3, t4, t5, t6, t7] = *stamp;
    let [c0, c1] = counter.to_be_bytes();
    // PUS version 2 (PUS-C), time reference status 0; the message type counter; destination 0.
    let headers: [u8; HEADERS_LEN] = [
        id0, id1, sc0, sc1, dl0, dl1, 0x20, service, subtype, c0, c1, 0, 0, t0, t1, t2, t3, t4, t5,
        t6, t7,
    ];
    packet[..HEADERS_LEN].copy_from_slice(&headers);
}

/// Builds packet TM[`service`,`subtype`] with sequence count `sequence` and message type
/// counter `counter` (the count of packets of this type before it since boot), stamped `t`
/// (nanoseconds since boot), in `packet`: the application data is written in place by `encode`
/// (given the room after the headers; it returns the length it wrote), then the headers and the
/// CRC around it. Returns the packet length, or `None` if the data did not fit.
pub fn build(
    packet: &mut [u8; TM_MAX],
    sequence: u16,
    counter: u16,
    service: u8,
    subtype: u8,
    t: u64,
    encode: impl FnOnce(&mut [u8]) -> Option<usize>,
) -> Option<usize> {
    let n = encode(packet.get_mut(HEADERS_LEN..TM_MAX - CRC_LEN)?)?;
    let len = HEADERS_LEN + n + CRC_LEN;
    write_headers(packet, sequence, counter, len, service, subtype, &cuc(t));
    let crc = CRC_CCITT_FALSE.checksum(&packet[..len - CRC_LEN]);
    packet[len - CRC_LEN..len].copy_from_slice(&crc.to_be_bytes());
    Some(len)
}
