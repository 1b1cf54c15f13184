//! # ballisto-calstore
//!
//! Calibration records in flash that survive resets and power loss ("Stored"). Its
//! own crate so that the flight profile builds it for size (the application crate is built for
//! speed for the per-sample path; this runs at boot and on a commit).
//!
//! - [`record`] — the versioned record with its CRC and monotonic calibration id;
//! - [`store`] — the newest record in a flash range (`sequential-storage`'s map over the
//!   `embedded-storage` NOR-flash traits) and the choice at boot between it and the built-in
//!   arrangement, with the identity (id, source, CRC) housekeeping reports;
//! - [`read_only`] — a flash opened for reading only (the boot path);
//! - [`ram_flash`] — a NOR flash in RAM with byte-granular power loss: the QEMU board's flash
//!   and the host tests' (`tests/calstore.rs`: a cut at every octet of a commit and of the
//!   erases it causes leaves the old or the new record in use, never a part of one).

#![no_std]
#![deny(missing_docs)]

pub mod ram_flash;
pub mod read_only;
pub mod record;
pub mod store;

pub use ballisto_link::{CalibrationId, CalibrationSource};
pub use ram_flash::{Programming, RamFlash, RamFlashError};
pub use read_only::{ReadOnly, ReadOnlyError};
pub use record::{CalibrationRecord, RecordError, FORMAT_VERSION, MAX_RECORD};
pub use store::{select_at_boot, CalibrationStore, NotUsed, StoreError};
