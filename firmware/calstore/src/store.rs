//! The calibration store: the newest calibration record in a flash range, through
//! `sequential-storage`'s map (one key; every commit appends a new item and the map returns the
//! newest whole one, so a commit cut by power loss leaves the previous record in use), and the
//! choice at boot between it and the built-in arrangement.

use core::ops::Range;

use embedded_storage_async::nor_flash::NorFlash;
use estimator_core::Arrangement;
use sequential_storage::cache::{Cache, Uncached};
use sequential_storage::map::{MapConfig, MapConfigError, MapStorage};

use crate::record::{CalibrationRecord, RecordError, MAX_RECORD};
use ballisto_link::ids::MAX_CHANNELS;
use ballisto_link::{CalibrationId, CalibrationSource};

/// The map key of the active calibration.
const KEY: u8 = 1;
/// The store's working buffer: a record, its key and the item header, word-aligned.
const BUFFER: usize = MAX_RECORD + 64;

/// What went wrong in the store.
#[derive(Debug)]
pub enum StoreError<E> {
    /// The flash range cannot hold a map (not whole sectors, or fewer than two).
    Range(MapConfigError),
    /// The flash or the map failed (power loss, a full store, corruption it could not repair).
    Flash(sequential_storage::Error<E>),
    /// The stored record is damaged or not for this firmware.
    Record(RecordError),
    /// A commit must carry a calibration id above the stored one.
    IdNotNewer {
        /// The stored record's id.
        stored: u32,
        /// The id offered.
        offered: u32,
    },
    /// The record cannot be encoded (id 0 or no channel).
    Unencodable,
}

impl<E: core::fmt::Debug> core::fmt::Display for StoreError<E> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            StoreError::Range(e) => write!(f, "calibration store range: {e:?}"),
            StoreError::Flash(e) => write!(f, "calibration store flash: {e:?}"),
            StoreError::Record(e) => write!(f, "{e}"),
            StoreError::IdNotNewer { stored, offered } => write!(
                f,
                "calibration id {offered} is not above the stored one ({stored})"
            ),
            StoreError::Unencodable => write!(f, "calibration record cannot be encoded"),
        }
    }
}

/// The newest calibration in a flash range.
pub struct CalibrationStore<F: NorFlash> {
    map: MapStorage<u8, F, Cache<Uncached, Uncached, Uncached, u8>>,
    buf: [u8; BUFFER],
    record: [u8; MAX_RECORD],
}

impl<F: NorFlash> CalibrationStore<F> {
    /// A store over `range` of `flash` (whole sectors, at least two).
    pub fn new(flash: F, range: Range<u32>) -> Result<Self, StoreError<F::Error>> {
        let config = MapConfig::try_new(range).map_err(StoreError::Range)?;
        Ok(CalibrationStore {
            map: MapStorage::new(flash, config, Cache::new_uncached()),
            buf: [0; BUFFER],
            record: [0; MAX_RECORD],
        })
    }

    /// The newest complete record, if any, with its stored CRC.
    pub async fn newest(
        &mut self,
    ) -> Result<Option<(CalibrationRecord, u32)>, StoreError<F::Error>> {
        let item = self
            .map
            .fetch_item::<&[u8]>(&mut self.buf, &KEY)
            .await
            .map_err(StoreError::Flash)?;
        match item {
            None => Ok(None),
            Some(bytes) => {
                let record = CalibrationRecord::decode(bytes).map_err(StoreError::Record)?;
                // A decoded record has a complete encoding: its CRC is there.
                let crc = CalibrationRecord::stored_crc(bytes).unwrap_or(0);
                Ok(Some((record, crc)))
            }
        }
    }

    /// Stores `record` as the newest, if its id is above the stored one's. Cut by power loss,
    /// the store keeps the previous record (or none): never a part of this one.
    pub async fn commit(&mut self, record: &CalibrationRecord) -> Result<(), StoreError<F::Error>> {
        if let Some((stored, _)) = self.newest().await? {
            if record.id <= stored.id {
                return Err(StoreError::IdNotNewer {
                    stored: stored.id,
                    offered: record.id,
                });
            }
        }
        let len = record
            .encode(&mut self.record)
            .ok_or(StoreError::Unencodable)?;
        self.map
            .store_item(&mut self.buf, &KEY, &&self.record[..len])
            .await
            .map_err(StoreError::Flash)
    }

    /// Gives the flash back.
    pub fn into_flash(self) -> F {
        self.map.destroy().0
    }
}

/// Why the stored calibration was not used at boot (the built-in one was).
#[derive(Debug)]
pub enum NotUsed<E> {
    /// Nothing is stored.
    Empty,
    /// The store could not be read, or its record is damaged.
    Store(StoreError<E>),
    /// The record is for another number of channels than the parts feed.
    Channels {
        /// Channels in the record.
        stored: usize,
        /// Channels of the configuration.
        configured: usize,
    },
}

/// The arrangement to run at boot: the newest stored calibration if it is whole and fits the
/// configured channels, else `builtin`; with its identity (for `App::set_calibration` and
/// housekeeping) and, if the stored one was not used, why.
pub async fn select_at_boot<F: NorFlash>(
    store: &mut CalibrationStore<F>,
    builtin: &Arrangement<MAX_CHANNELS>,
) -> (
    Arrangement<MAX_CHANNELS>,
    CalibrationId,
    Option<NotUsed<F::Error>>,
) {
    let why = match store.newest().await {
        Ok(Some((r, crc))) if r.arrangement.len() == builtin.len() => {
            let active = CalibrationId {
                source: CalibrationSource::Flash,
                id: r.id,
                crc,
            };
            return (r.arrangement, active, None);
        }
        Ok(Some((r, _))) => NotUsed::Channels {
            stored: r.arrangement.len(),
            configured: builtin.len(),
        },
        Ok(None) => NotUsed::Empty,
        Err(e) => NotUsed::Store(e),
    };
    (builtin.clone(), CalibrationId::default(), Some(why))
}
