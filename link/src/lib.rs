//! # ballisto-link
//!
//! The spacecraft link of the ballistometer, written once for both sides (as sat-rs shares its
//! models crate): the firmware encodes with it, the ground (`ballisto decode`) decodes with it,
//! and both test it. `no_std`, no allocation. `docs/telemetry.md` describes every byte for a
//! ground segment that does not read Rust; `tests/tests/telemetry_doc.rs` checks it against
//! these layouts.
//!
//! - [`ids`]: APID, services, subtypes, structure IDs, packet and layout capacities.
//! - [`mode`]: the mode and model codes; [`masks`]: sets of part slots and of channels.
//! - [`cuc`]: the time field (CUC 4+3, epoch = boot).
//! - [`codec`]: big-endian field writer and reader.
//! - One module per report: [`motion`], [`housekeeping`], [`event`], [`verification`],
//!   [`identification`] (with the reference points of TC[200,9]).
//! - [`tm`]: a telemetry packet around its application data (headers, CRC).
//! - [`telecommand`]: acceptance (parse) and construction (build) of telecommands.
//! - [`framing`]: COBS frames between zero delimiters.
//! - `decode` (feature `ground`): a telemetry packet → its report.
//!
//! All multi-byte fields are big-endian (network order, as CCSDS); reals are IEEE-754 `f32`.
//!
//! A packet framed for the line and received again, byte by byte, with garbage before it (the
//! receiver resynchronises at the next delimiter):
//!
//! ```
//! use ballisto_link::framing::{encode, max_encoded_len, Deframed, Deframer};
//!
//! let packet = [0x08, 0x01, 0x00, 0x00, 0x12, 0x34]; // any octets, zeros included
//! let mut line = [0u8; max_encoded_len(6)];
//! let n = encode(&packet, &mut line).expect("room for the frame");
//! let mut receiver = Deframer::<64>::new();
//! let mut received = None;
//! for byte in [0x41, 0x42].iter().chain(&line[..n]) {
//!     if let Deframed::Packet(len) = receiver.push(*byte) {
//!         received = Some(receiver.packet(len).to_vec());
//!     }
//! }
//! assert_eq!(received.as_deref(), Some(&packet[..]));
//! ```
#![no_std]
#![deny(missing_docs)]
// `!(x >= y)` rejects NaN along with the out-of-range values: intentional.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod codec;
pub mod cuc;
#[cfg(feature = "ground")]
pub mod decode;
pub mod event;
pub mod framing;
pub mod housekeeping;
pub mod identification;
pub mod ids;
pub mod masks;
pub mod mode;
pub mod motion;
pub mod telecommand;
pub mod tm;
pub mod verification;

pub use event::{BootEvent, Event, EventId};
pub use housekeeping::{
    BootInfo, CalibrationId, CalibrationSource, ConsistencyTest, Housekeeping, LoopCounters,
    PartCounters, PartState, ResetCause, TimeCorrelation,
};
pub use ids::{service, sid, subtype, APID, FORMAT_VERSION};
pub use masks::{ChannelSet, PartSet};
pub use mode::{Mode, ModelCode};
pub use motion::MotionReport;
pub use verification::{FailureCode, RequestId, Verification};
