//! The calibration storage task (app → storage): commits a calibration to the store when the
//! application asks, at low priority — an STM32H743 sector erase takes up to seconds and must
//! not hold up the estimate. The application sends the verification of the commit
//! (TC[200,11]) when the reply comes.

use embassy_sync::blocking_mutex::raw::RawMutex;
use embassy_sync::channel::{Channel, Receiver, Sender};
use embedded_storage_async::nor_flash::NorFlash;
use estimator_core::Arrangement;

use ballisto_calstore::record::CalibrationRecord;
use ballisto_calstore::store::{CalibrationStore, StoreError};
use ballisto_link::verification::store_failed;

use crate::config::MAX_CHANNELS;

/// A calibration to store as the newest (its id is the stored one's plus one).
#[derive(Clone, Debug)]
pub struct CommitRequest {
    /// The calibrated arrangement.
    pub arrangement: Arrangement<MAX_CHANNELS>,
}

/// What became of a [`CommitRequest`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CommitReply {
    /// Stored and read back whole: its id and its record's CRC-32.
    Stored {
        /// Calibration id.
        id: u32,
        /// CRC-32 of the stored record.
        crc: u32,
    },
    /// Not stored (the store keeps the previous record): the reason
    /// (`ballisto_link::verification::store_failed`).
    Failed(u32),
}

/// Requests from the application (one at a time).
pub type CommitRequests<M> = Channel<M, CommitRequest, 1>;
/// Replies to it.
pub type CommitReplies<M> = Channel<M, CommitReply, 1>;

/// The application's ends of the storage task's channels.
pub struct StorageLinks<'a, M: RawMutex> {
    /// Where commits go.
    pub requests: Sender<'a, M, CommitRequest, 1>,
    /// Where their outcome comes back.
    pub replies: Receiver<'a, M, CommitReply, 1>,
}

/// Commits `arrangement` as the calibration after the newest stored one, then reads it back.
pub async fn commit_next<F: NorFlash>(
    store: &mut CalibrationStore<F>,
    arrangement: &Arrangement<MAX_CHANNELS>,
) -> CommitReply {
    let code = |e: StoreError<F::Error>| match e {
        StoreError::Record(_) | StoreError::IdNotNewer { .. } => store_failed::RECORD,
        StoreError::Unencodable => store_failed::UNENCODABLE,
        StoreError::Range(_) | StoreError::Flash(_) => store_failed::FLASH,
    };
    let id = match store.newest().await {
        Ok(Some((r, _))) => r.id.saturating_add(1),
        Ok(None) => 1,
        Err(e) => return CommitReply::Failed(code(e)),
    };
    let record = CalibrationRecord {
        id,
        arrangement: arrangement.clone(),
    };
    if let Err(e) = store.commit(&record).await {
        return CommitReply::Failed(code(e));
    }
    // Read back: what the next boot will find.
    match store.newest().await {
        Ok(Some((back, crc))) if back.id == id => CommitReply::Stored { id, crc },
        Ok(_) => CommitReply::Failed(store_failed::FLASH),
        Err(e) => CommitReply::Failed(code(e)),
    }
}

/// The storage task: commits each request and replies. Never returns.
pub async fn storage_task<F: NorFlash, M: RawMutex>(
    store: &mut CalibrationStore<F>,
    requests: Receiver<'_, M, CommitRequest, 1>,
    replies: Sender<'_, M, CommitReply, 1>,
) -> ! {
    loop {
        let request = requests.receive().await;
        let reply = commit_next(store, &request.arrangement).await;
        replies.send(reply).await;
    }
}
