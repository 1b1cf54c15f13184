//! The application task and its links: sample sets and telecommands in, telemetry out, and
//! what an observer may see (the host simulator records every set and estimate; the QEMU
//! board ends its run) published on an embassy-sync `PubSubChannel` — no hooks in the
//! application. With no subscriber (the flight board) nothing is queued.

use embassy_futures::select::{select4, Either4 as Event};
use embassy_sync::blocking_mutex::raw::RawMutex;
use embassy_sync::channel::Receiver;
use embassy_sync::pubsub::PubSubChannel;
use embassy_sync::zerocopy_channel;
use embedded_io_async::Write;

use super::{App, Incoming};
use crate::estimation::SetEstimate;
use crate::sampler::{HealthBoard, LoopHealth, SampleSet};
use crate::storage::StorageLinks;
use crate::supervisor::Liveness;
use crate::telemetry::Telemetry;
use crate::time::TimeBase;

/// The counters an observer sees after each set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Status {
    /// The sampler's loop counters (as of the set).
    pub sampling: LoopHealth,
    /// Estimates computed.
    pub estimates: u32,
    /// Telecommands accepted.
    pub tc_accepted: u32,
    /// Telecommands refused at acceptance.
    pub tc_rejected: u32,
    /// Command-link frames that were garbage.
    pub frames_garbage: u32,
    /// Telemetry packets handed to the link.
    pub tm_sent: u32,
    /// Telemetry packets the link failed to take.
    pub tm_lost: u32,
}

/// One handled sample set as an observer sees it.
#[derive(Clone, Copy, Debug)]
pub struct Observation {
    /// The set.
    pub set: SampleSet,
    /// Its estimate (operate mode).
    pub motion: Option<SetEstimate>,
    /// The counters after it.
    pub status: Status,
}

/// Where the application publishes each [`Observation`]: one slot, one subscriber (the
/// application waits for it to take each one; without a subscriber nothing is kept).
pub type Observations<M> = PubSubChannel<M, Observation, 1, 1, 1>;

/// Everything the application task is connected to.
pub struct Links<'a, M: RawMutex, W, const Q: usize> {
    /// Sample sets from the sampling task.
    pub samples: Receiver<'a, M, SampleSet, Q>,
    /// Telecommands from the uplink task.
    pub commands: zerocopy_channel::Receiver<'a, M, Incoming>,
    /// The sampler's latest counters.
    pub health: &'a HealthBoard<M>,
    /// The telemetry link.
    pub telemetry: &'a mut Telemetry<W>,
    /// Where each handled set is published for observers.
    pub observations: &'a Observations<M>,
    /// The calibration storage task, where the board has a writable store (else commits are
    /// refused).
    pub storage: Option<StorageLinks<'a, M>>,
    /// Where each handled set is counted for the watchdog's supervisor.
    pub liveness: &'a Liveness,
}

/// The application task: boots, then handles sample sets and telecommands as they come.
/// Never returns.
pub async fn app_task<M, W, T, const Q: usize>(app: &mut App, time: &T, links: Links<'_, M, W, Q>)
where
    M: RawMutex,
    W: Write,
    T: TimeBase,
{
    let Links {
        samples,
        mut commands,
        health,
        telemetry: tm,
        observations,
        storage,
        liveness,
    } = links;
    // One publisher per channel, taken here: `observations` is this task's alone.
    let publisher = observations.publisher();
    app.set_store_writable(storage.is_some());
    app.boot(time.now(), tm).await;
    let identifier = app.identifier();
    loop {
        // Commits come from identification (TC[200,11]) where the board has a writable store;
        // solutions from the identification task (TC[200,10]), reported as soon as they come.
        let event = {
            let replies = async {
                match &storage {
                    Some(s) => s.replies.receive().await,
                    None => core::future::pending().await,
                }
            };
            let solved = async {
                match identifier {
                    Some(i) => i.solved().await,
                    None => core::future::pending().await,
                }
            };
            select4(samples.receive(), commands.receive(), replies, solved).await
        };
        match event {
            Event::First(set) => {
                let seen = app.on_set(&set, health, tm).await;
                liveness.handled();
                if let Ok(p) = &publisher {
                    p.publish(seen).await;
                }
            }
            Event::Second(incoming) => {
                app.on_incoming(incoming, time.now(), tm).await;
                commands.receive_done();
                if let (Some(request), Some(s)) = (app.take_commit(), &storage) {
                    // One commit at a time (the application refuses another while busy): the
                    // channel has room.
                    s.requests.send(request).await;
                }
            }
            Event::Third(reply) => app.on_commit_reply(reply, time.now(), tm).await,
            Event::Fourth(solved) => app.on_solved(solved, time.now(), tm).await,
        }
    }
}
