//! The command link: its bytes decoded (COBS) as they arrive straight into the free command
//! slot of a zero-copy channel, one packet (or the news of a garbage frame) per slot.

use ballisto_link::framing::{Decoder, Deframed};
use ballisto_link::ids::TC_MAX;
use embassy_sync::blocking_mutex::raw::RawMutex;
use embassy_sync::zerocopy_channel::Sender;
use embedded_io_async::Read;

/// One telecommand packet as received, or the news that a frame was garbage. Filled in place
/// in the slot of a zero-copy channel (a packet is up to [`TC_MAX`] octets).
pub struct Incoming {
    len: u16,
    garbage: bool,
    bytes: [u8; TC_MAX],
}

impl Default for Incoming {
    fn default() -> Self {
        Self::new()
    }
}

impl Incoming {
    /// An empty slot.
    pub const fn new() -> Self {
        Incoming {
            len: 0,
            garbage: false,
            bytes: [0; TC_MAX],
        }
    }

    /// Holds a received packet (one longer than [`TC_MAX`] is garbage).
    pub fn set_packet(&mut self, packet: &[u8]) {
        match self.bytes.get_mut(..packet.len()) {
            Some(dst) => {
                dst.copy_from_slice(packet);
                self.len = packet.len() as u16;
                self.garbage = false;
            }
            None => self.set_garbage(),
        }
    }

    /// Decodes one byte from the line into this slot; true once it holds a whole packet or
    /// the news of a garbage frame.
    pub fn push(&mut self, decoder: &mut Decoder, byte: u8) -> bool {
        match decoder.push(byte, &mut self.bytes) {
            Deframed::Pending => false,
            Deframed::Packet(len) => {
                self.len = len as u16;
                self.garbage = false;
                true
            }
            Deframed::Garbage => {
                self.set_garbage();
                true
            }
        }
    }

    /// Holds the news of a garbage frame.
    pub fn set_garbage(&mut self) {
        self.len = 0;
        self.garbage = true;
    }

    /// The packet, or `None` for a garbage frame.
    pub fn packet(&self) -> Option<&[u8]> {
        (!self.garbage).then(|| &self.bytes[..usize::from(self.len).min(TC_MAX)])
    }
}

/// Slots between the uplink and the application task.
pub const COMMAND_QUEUE: usize = 1;

/// The uplink task: the command link's byte stream, decoded straight into the free command
/// slot, → the application task. While the application still holds the slot, bytes wait in
/// the link's receive buffer. Ends when the link ends (or fails).
pub async fn uplink_task<R: Read, M: RawMutex>(mut link: R, mut commands: Sender<'_, M, Incoming>) {
    let mut decoder = Decoder::new();
    let mut chunk = [0u8; 32];
    loop {
        let n = match link.read(&mut chunk).await {
            Ok(0) | Err(_) => return,
            Ok(n) => n,
        };
        for &b in chunk.iter().take(n) {
            if commands.send().await.push(&mut decoder, b) {
                commands.send_done();
            }
        }
    }
}
