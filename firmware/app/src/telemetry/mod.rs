//! Telemetry on the spacecraft bus: PUS packets (`ballisto_link`'s layouts) framed for a serial
//! link, written by [`Telemetry`] with one contiguous CCSDS sequence count and a PUS message
//! type counter per kind of report.
//!
//! Every packet carries the PUS packet error control (CRC-16-CCITT), a CUC time stamp (time
//! since boot) and the next sequence count, so the ground sees corruption and loss. The
//! layouts are described for ground segments in `docs/telemetry.md`.

use ballisto_link::framing;
use ballisto_link::ids::{tm_type_index, TM_MAX, TM_TYPES};
use ballisto_link::tm;
use embedded_io_async::Write;

use crate::time::Nanos;

/// The telemetry writer: builds, frames and sends packets on a link.
pub struct Telemetry<W> {
    link: W,
    sequence: u16,
    /// Packets sent of each type in `ballisto_link::ids::TM_TYPES`.
    counters: [u16; TM_TYPES.len()],
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
            counters: [0; TM_TYPES.len()],
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
    /// data did not fit. Takes the next sequence count and the type's next message type
    /// counter either way (a type outside `TM_TYPES`, which the unit does not send, counts 0).
    pub fn stage(
        &mut self,
        t: Nanos,
        service: u8,
        subtype: u8,
        encode: impl FnOnce(&mut [u8]) -> Option<usize>,
    ) -> Option<usize> {
        let sequence = self.sequence;
        self.sequence = (self.sequence + 1) & 0x3FFF;
        let counter = match tm_type_index(service, subtype) {
            Some(i) => {
                let c = self.counters[i];
                self.counters[i] = c.wrapping_add(1);
                c
            }
            None => 0,
        };
        // The application data is encoded in place, after the headers; the headers and the
        // CRC are then written around it.
        let len = tm::build(
            &mut self.packet,
            sequence,
            counter,
            service,
            subtype,
            t,
            encode,
        )?;
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
