//! The QEMU board's boots on the host: the same tasks on the same synthetic sets and scripted
//! uplink, in simulated time, the telemetry kept (`builtin_scenario`, `builtin_tumble`).

use std::cell::Cell;
use std::rc::Rc;

use ballisto::decode::Stream;
use ballisto_fw::app::{
    app_task, uplink_task, App, Incoming, Links, Mode, Observations, COMMAND_QUEUE,
};
use ballisto_fw::calstore::{CalibrationStore, Programming, RamFlash};
use ballisto_fw::config::AppConfig;
use ballisto_fw::identification::{Identification, Identifier};
use ballisto_fw::sampler::{HealthBoard, SampleSet};
use ballisto_fw::storage::{storage_task, CommitReplies, CommitRequests, StorageLinks};
use ballisto_fw::telemetry::Telemetry;
use ballisto_fw::time::{Nanos, TimeBase};
use ballisto_link::decode::Report;
use ballisto_link::identification::IdentificationSummary;
use ballisto_link::{BootInfo, CalibrationId, EventId, MotionReport};
use board_qemu::demo::{Script, ScriptedUplink};
use board_qemu::synthetic::{synthetic_task, Synthetic};
use embassy_futures::join::join;
use embassy_futures::select::select;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::zerocopy_channel::Channel as ZeroCopyChannel;
use hal_sim::firmware_host::Downlink;

/// Time that jumps to each instant waited for.
#[derive(Clone)]
pub struct StepTime(Rc<Cell<Nanos>>);

impl TimeBase for StepTime {
    fn now(&self) -> Nanos {
        self.0.get()
    }

    async fn wait_until(&mut self, at: Nanos) {
        self.0.set(self.0.get().max(at));
        embassy_futures::yield_now().await;
    }
}

/// The QEMU board's calibration flash: two 4 KiB sectors, 32-octet words.
pub type HostStore<'a> = CalibrationStore<RamFlash<'a, 4096, 32>>;

/// One boot of the built-in scenario on the host, booting at 0 with the first instant one
/// period later: `config` (its calibration `id`, the boot `info`) on `source`'s sets for
/// `sets` instants, the uplink `script`, the storage task on `store`. Returns the telemetry.
pub fn run_boot(
    config: &AppConfig,
    (id, info): (CalibrationId, BootInfo),
    mut source: Synthetic,
    (script, sets): (Script, u32),
    store: &mut HostStore<'_>,
) -> Vec<u8> {
    let mut app = App::new(config, Mode::Operate).unwrap();
    // The identification task's queues, as the board's static (one per boot: a few KB).
    let identifier: &'static Identifier = Box::leak(Box::new(Identifier::new()));
    app.attach_identifier(identifier);
    let mut window = Box::new(Identification::new());
    app.set_calibration(id);
    app.set_boot_info(info);
    let mut time = StepTime(Rc::new(Cell::new(0)));
    let app_time = time.clone();
    let period = source.period();
    let t0 = period;
    let samples = Channel::<NoopRawMutex, SampleSet, { ballisto_fw::QUEUE }>::new();
    let mut slots: [Incoming; COMMAND_QUEUE] = Default::default();
    let mut commands = ZeroCopyChannel::<NoopRawMutex, Incoming>::new(&mut slots);
    let (tx, rx) = commands.split();
    let health = HealthBoard::<NoopRawMutex>::new();
    let requests = CommitRequests::<NoopRawMutex>::new();
    let replies = CommitReplies::<NoopRawMutex>::new();
    let mut bytes = Vec::new();
    let mut tm = Telemetry::new(Downlink::new(&mut bytes));
    let observations = Observations::<NoopRawMutex>::new();
    let mut observer = observations.subscriber().unwrap();
    {
        // No watchdog on the host: the count goes unread.
        let liveness = ballisto_fw::supervisor::Liveness::new();
        let application = app_task(
            &mut app,
            &app_time,
            Links {
                samples: samples.receiver(),
                commands: rx,
                health: &health,
                telemetry: &mut tm,
                observations: &observations,
                storage: Some(StorageLinks {
                    requests: requests.sender(),
                    replies: replies.receiver(),
                }),
                liveness: &liveness,
            },
        );
        // As the QEMU board: the boot ends with the last set handled.
        let last_set = async { while observer.next_message_pure().await.set.k + 1 < sets {} };
        let sampling = synthetic_task(
            &mut source,
            &mut time,
            samples.sender(),
            &health,
            t0,
            Some(sets),
        );
        let uplink = uplink_task(ScriptedUplink::new(&app_time, t0, period, script), tx);
        let storing = storage_task(store, requests.receiver(), replies.sender());
        let identifying = identifier.run(&mut window);
        embassy_futures::block_on(select(
            last_set,
            select(
                application,
                join(join(sampling, uplink), join(storing, identifying)),
            ),
        ));
    }
    drop(tm);
    bytes
}

/// A stream's motion reports, with their packets' times.
pub fn motions(s: &Stream) -> Vec<(f64, MotionReport)> {
    s.packets
        .iter()
        .filter_map(|p| match &p.report {
            Report::Motion(m) => Some((p.t, *m)),
            _ => None,
        })
        .collect()
}

/// A stream's identification summary and its `calibration-stored` event (id, CRC).
pub fn identification(s: &Stream) -> (Option<IdentificationSummary>, Option<(u32, u32)>) {
    let summary = s.packets.iter().find_map(|p| match &p.report {
        Report::IdentificationSummary(x) => Some(*x),
        _ => None,
    });
    let stored = s.packets.iter().find_map(|p| match &p.report {
        Report::Event(e) if e.id == EventId::CalibrationStored => Some((e.a, e.b)),
        _ => None,
    });
    (summary, stored)
}

/// A boot of the QEMU board on its calibration flash `mem` (two 4 KiB sectors; erased first
/// at a `power_on`): the configuration and calibration `demo::boot` gives (`config` in its
/// place when given: the store then only takes commits), booted as `info` says, on `source`'s
/// sets with the uplink `script` (and the sets it runs for). Returns the telemetry, the
/// calibration and the configuration run.
pub fn boot_on(
    mem: &mut [u8],
    power_on: bool,
    info: BootInfo,
    config: Option<&AppConfig>,
    source: Synthetic,
    script: (Script, u32),
) -> (Vec<u8>, CalibrationId, AppConfig) {
    let mut erases = [0u32; 2];
    let mut flash = RamFlash::<4096, 32>::new(mem, &mut erases, Programming::WordOnce);
    if power_on {
        flash.erase_all();
    }
    let (booted, id, mut store) =
        embassy_futures::block_on(board_qemu::demo::boot(flash, 0..2 * 4096))
            .expect("the QEMU board's store");
    let config = config.cloned().unwrap_or(booted);
    let telemetry = run_boot(&config, (id, info), source, script, &mut store);
    (telemetry, id, config)
}
