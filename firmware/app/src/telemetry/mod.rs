//! Telemetry on the spacecraft bus: PUS packets ([`packets`]) framed for a serial link
//! ([`framing`]), written by [`Telemetry`] with one contiguous CCSDS sequence count.
//!
//! Every packet carries the PUS packet error control (CRC-16-CCITT), a CUC time stamp (time
//! since boot) and the next sequence count, so the ground sees corruption and loss. The
//! layouts are described for ground segments in `docs/telemetry.md`.

pub mod framing;
pub mod packets;

use arbitrary_int::{u11, u14};
use embedded_io_async::Write;
use spacepackets::crc::CRC_CCITT_FALSE;
use spacepackets::{CcsdsPacket, SpHeader};

use crate::time::Nanos;
use packets::{cuc, APID, TIME_LEN, TM_MAX};

/// Primary header, PUS-C TM secondary header and time field.
const HEADERS_LEN: usize = 6 + 7 + TIME_LEN;
/// The packet error control field.
const CRC_LEN: usize = 2;

/// Writes the primary header (`spacepackets`' field layout for an unsegmented TM packet of
/// `len` octets) and the PUS-C TM secondary header with the time field, octets
/// `0..HEADERS_LEN`. Written here rather than by `PusTmCreatorWithReservedSourceData`, whose
/// internal `unwrap`s link `core::fmt`'s `Debug` machinery (3.9 KB more flash with the
/// creator).
fn write_headers(
    packet: &mut [u8; TM_MAX],
    sequence: u16,
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
    // PUS version 2 (PUS-C), time reference status 0; message counter and destination 0.
    let headers: [u8; HEADERS_LEN] = [
        id0, id1, sc0, sc1, dl0, dl1, 0x20, service, subtype, 0, 0, 0, 0, t0, t1, t2, t3, t4, t5,
        t6, t7,
    ];
    packet[..HEADERS_LEN].copy_from_slice(&headers);
}

/// The telemetry writer: builds, frames and sends packets on a link.
pub struct Telemetry<W> {
    link: W,
    sequence: u16,
    packet: [u8; TM_MAX],
    frame: [u8; framing::max_encoded_len(TM_MAX)],
    sent: u32,
    lost: u32,
}

impl<W: Write> Telemetry<W> {
    /// Telemetry on `link`, sequence count from 0.
    pub fn new(link: W) -> Self {
        Telemetry {
            link,
            sequence: 0,
            packet: [0; TM_MAX],
            frame: [0; framing::max_encoded_len(TM_MAX)],
            sent: 0,
            lost: 0,
        }
    }

    /// Packets handed to the link.
    pub fn sent(&self) -> u32 {
        self.sent
    }

    /// Packets the link failed to take (write error). Their sequence counts are used, so the
    /// ground sees the gap.
    pub fn lost(&self) -> u32 {
        self.lost
    }

    /// The link (to flush or close it).
    pub fn link(&mut self) -> &mut W {
        &mut self.link
    }

    /// Sends one packet TM[`service`,`subtype`] stamped `t` with application data `data`.
    pub async fn send(&mut self, t: Nanos, service: u8, subtype: u8, data: &[u8]) {
        let framed = self.stage(t, service, subtype, |buf| {
            let out = buf.get_mut(..data.len())?;
            out.copy_from_slice(data);
            Some(data.len())
        });
        self.transmit(framed).await;
    }

    /// Builds and frames packet TM[`service`,`subtype`] stamped `t`, its application data
    /// written by `encode` into the writer's own buffer (nothing large is held by the
    /// caller's future); returns the frame length for [`Self::transmit`], or `None` if the
    /// data did not fit. Takes the next sequence count either way.
    pub fn stage(
        &mut self,
        t: Nanos,
        service: u8,
        subtype: u8,
        encode: impl FnOnce(&mut [u8]) -> Option<usize>,
    ) -> Option<usize> {
        let sequence = self.sequence;
        self.sequence = (self.sequence + 1) & 0x3FFF;
        // The application data is encoded in place, after the headers; the headers and the
        // CRC are then written around it.
        let n = encode(self.packet.get_mut(HEADERS_LEN..TM_MAX - CRC_LEN)?)?;
        let len = HEADERS_LEN + n + CRC_LEN;
        write_headers(&mut self.packet, sequence, len, service, subtype, &cuc(t));
        let crc = CRC_CCITT_FALSE.checksum(&self.packet[..len - CRC_LEN]);
        self.packet[len - CRC_LEN..len].copy_from_slice(&crc.to_be_bytes());
        framing::encode(&self.packet[..len], &mut self.frame)
    }

    /// Sends the frame [`Self::stage`] built (`None`: counted as lost).
    pub async fn transmit(&mut self, framed: Option<usize>) {
        let ok = match framed {
            Some(n) => self.link.write_all(&self.frame[..n]).await.is_ok(),
            None => false,
        };
        if ok {
            self.sent = self.sent.wrapping_add(1);
        } else {
            self.lost = self.lost.wrapping_add(1);
        }
    }

    /// Waits until the link has sent everything (end of a run).
    pub async fn flush(&mut self) {
        if self.link.flush().await.is_err() {
            self.lost = self.lost.wrapping_add(1);
        }
    }
}
