//! The firmware on the host: its sampling and estimation tasks run against the simulated
//! buses of a scenario, in simulated time.
//!
//! The firmware's [`TimeBase`] is the rig's [`SimClock`] (nanoseconds since power-on; waiting
//! moves the simulated time forward), its SYNC output pulses the rig's [`SyncLine`], and the
//! parts are the rig's SPI devices and I²C bus. The two tasks are polled by one
//! single-threaded loop (`embassy_futures::block_on` over a `select`): on the board they are
//! embassy tasks; here the loop must end after the scenario's sets and may run many times in
//! one process, which embassy-executor's `run` (never returns, static task storage) does not
//! allow. The tasks are the same functions either way.

use std::convert::Infallible;
use std::path::Path;

use ballisto_config::arrangement_file::LoadedArrangement;
use ballisto_config::firmware_config::{firmware_arrangement, Part, PartSpec, Sampling};
use ballisto_config::model_choice::recommend;
use ballisto_fw::app::{
    app_task, uplink_task, App, Incoming, Links, Mode, Observations, COMMAND_QUEUE,
};
use ballisto_fw::calstore::ram_flash::RamFlash;
use ballisto_fw::calstore::store::CalibrationStore;
use ballisto_fw::config::{Alignment, AppConfig, SamplingConfig, MAX_PARTS};
use ballisto_fw::estimation::{Builds, SetEstimate};
use ballisto_fw::identification::{Identification, Identifier};
use ballisto_fw::sampler::{
    sampling_task, HealthBoard, LoopHealth, PartBus, PartHealth, SampleSet, Sampler,
};
use ballisto_fw::storage::{storage_task, CommitReplies, CommitRequests, StorageLinks};
use ballisto_fw::telemetry::Telemetry;
use ballisto_fw::time::{Nanos, TimeBase};
use ballisto_link::{BootInfo, CalibrationId, ResetCause};
use embassy_futures::select::select;
use embassy_futures::yield_now;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::zerocopy_channel::Channel as ZeroCopyChannel;
use embedded_hal::digital::{ErrorType, OutputPin};

use crate::bus::i2c::SimI2cBus;
use crate::bus::spi::SimSpiDevice;
use crate::clock::SimClock;
use crate::motion::Truth;
use crate::rig::{Port, Rig, POWER_ON};
use crate::scenario::{PartType, Scenario};
use crate::sensors::sync_line::SyncLine;

/// Simulated time of power-on in whole nanoseconds (negative).
const POWER_ON_NS: i64 = (POWER_ON * 1e9) as i64;

/// The firmware's time base on simulated time: nanoseconds since power-on.
pub struct SimTime(pub SimClock);

impl SimTime {
    /// Simulated seconds of a firmware instant.
    pub fn seconds(t: Nanos) -> f64 {
        // Whole nanoseconds from 0, divided once: 10 ms prints as 0.01.
        (t as i64 + POWER_ON_NS) as f64 / 1e9
    }

    /// The firmware instant of simulated seconds `t` (the inverse of [`SimTime::seconds`]).
    pub fn nanos(t: f64) -> Nanos {
        ((t - POWER_ON) * 1e9).round().max(0.0) as Nanos
    }
}

impl TimeBase for SimTime {
    fn now(&self) -> Nanos {
        Self::nanos(self.0.now())
    }

    async fn wait_until(&mut self, at: Nanos) {
        self.0.advance_to(Self::seconds(at));
        // Let the other task run, as the executor would while this one sleeps.
        yield_now().await;
    }
}

/// The firmware's SYNC output: a rising edge is a pulse on the rig's line now.
pub struct SimSyncPin {
    line: SyncLine,
    clock: SimClock,
}

impl ErrorType for SimSyncPin {
    type Error = Infallible;
}

impl OutputPin for SimSyncPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        self.line.pulse(self.clock.now());
        Ok(())
    }
}

/// What the application holds for `'static` across one run — the second configuration buffer
/// ([`Builds::inline`]: changes are built in the sample path at once, as `ballisto estimate`
/// makes them, since simulated time does not pass during a build; about 26 KB) and the
/// identification task's queues (about 11 KB) — kept in a pool across runs (as many as runs
/// at a time) instead of leaked per run.
trait Pooled: Sync + 'static {
    /// The pool.
    fn pool() -> &'static std::sync::Mutex<Vec<&'static Self>>;
    /// A new one.
    fn make() -> Self;
    /// Emptied for the next run.
    fn empty(&self);
}

impl Pooled for Builds {
    fn pool() -> &'static std::sync::Mutex<Vec<&'static Self>> {
        static POOL: std::sync::Mutex<Vec<&'static Builds>> = std::sync::Mutex::new(Vec::new());
        &POOL
    }
    fn make() -> Self {
        Builds::inline()
    }
    fn empty(&self) {
        self.clear();
    }
}

impl Pooled for Identifier {
    fn pool() -> &'static std::sync::Mutex<Vec<&'static Self>> {
        static POOL: std::sync::Mutex<Vec<&'static Identifier>> = std::sync::Mutex::new(Vec::new());
        &POOL
    }
    fn make() -> Self {
        Identifier::new()
    }
    fn empty(&self) {
        self.clear();
    }
}

/// One run's loan from a [`Pooled`] pool.
struct Loan<T: Pooled>(&'static T);

impl<T: Pooled> Loan<T> {
    fn take() -> Self {
        let pooled = T::pool().lock().ok().and_then(|mut pool| pool.pop());
        Loan(pooled.unwrap_or_else(|| Box::leak(Box::new(T::make()))))
    }
}

impl<T: Pooled> Drop for Loan<T> {
    /// Back to the pool, emptied (declared before the application, it outlives it).
    fn drop(&mut self) {
        self.0.empty();
        if let Ok(mut pool) = T::pool().lock() {
            pool.push(self.0);
        }
    }
}

/// The firmware configuration of a scenario (the command the host gives at start-up): its
/// parts with their ranges, rates and sync, channels in the order of the scenario's
/// arrangement, the model `ballisto` chooses for that arrangement, and the scenario's rate hint
/// — built by the same code as a board's ([`ballisto_config::firmware_config`]).
pub fn firmware_config(
    sc: &Scenario,
    loaded: &LoadedArrangement,
    alignment: Alignment,
) -> Result<AppConfig, String> {
    let arrangement =
        firmware_arrangement(loaded).map_err(|e| format!("the scenario's arrangement: {e}"))?;
    let parts: Vec<PartSpec> = sc
        .parts
        .iter()
        .map(|p| PartSpec {
            name: p.name.clone(),
            part: match p.part {
                PartType::Adxl355 => Part::Adxl355,
                PartType::Lis3dh => Part::Lis3dh,
            },
            range: Some(p.part.full_scale(sc.range_g(p))),
            odr_hz: sc.odr(p) as f32,
            sync: sc.sync(p),
        })
        .collect();
    let (model, _) = recommend(None, loaded, Path::new("the scenario's arrangement"))?;
    let sampling = Sampling {
        rate_hz: sc.rate as f32,
        alignment,
    };
    ballisto_config::firmware_config::firmware_config(
        loaded,
        arrangement,
        &parts,
        sampling,
        model,
        sc.initial_omega,
    )
}

/// Calls `f(channel, value)` for every channel a sample set carries: each part's x, y, z that
/// `config` maps onto a channel of the arrangement (a missing part carries none).
pub fn for_each_channel(config: &SamplingConfig, set: &SampleSet, mut f: impl FnMut(usize, f32)) {
    for (value, part) in set.parts.iter().zip(config.parts.iter()) {
        if let (Some(v), Some(part)) = (value, part) {
            for (x, c) in v.iter().zip(part.channels.iter()) {
                if let Some(c) = c {
                    f(usize::from(*c), *x);
                }
            }
        }
    }
}

/// What the firmware did in a run.
#[derive(Clone, Debug)]
pub struct FirmwareReport {
    /// Per part (scenario order).
    pub parts: Vec<PartHealth>,
    /// The sampling loop.
    pub sampling: LoopHealth,
    /// Estimates produced.
    pub estimates: u64,
    /// Size of the sampling, application and uplink task futures (bytes): their static
    /// storage as embassy tasks (the application task's holds references to the state).
    pub task_sizes: (usize, usize, usize),
    /// Per bus, sample sets only: name, bytes, busy time (s).
    pub buses: Vec<(String, u64, f64)>,
    /// Size of the estimation state (bytes).
    pub estimation_size: usize,
    /// Size of the application state, estimation included (bytes).
    pub app_size: usize,
    /// The application's last housekeeping values.
    pub housekeeping: ballisto_link::Housekeeping,
    /// Octets the firmware sent on its telemetry link (written to the run's downlink).
    pub telemetry_bytes: u64,
    /// Per free-running part: half-width of its conversion-time interval at the end (s).
    pub clock_uncertainty: Vec<Option<f64>>,
}

/// What the host gets per sample set: the set, the estimate made from it, and the truth at
/// its instant.
pub type Emit<'a> = &'a mut dyn FnMut(&SampleSet, &SetEstimate, &Truth);

/// Telecommands for a run: at each time (scenario seconds) the bytes that arrive on the
/// command link (normally COBS frames).
pub type Uplink = [(f64, Vec<u8>)];

/// The host side of the command link: hands out each scheduled chunk once the rig's clock has
/// reached its time, and nothing more after the last one.
struct HostUplink<'a> {
    clock: SimClock,
    schedule: &'a Uplink,
    next: usize,
    /// Octets of the current chunk already handed out (a chunk longer than the reader's
    /// buffer takes several reads).
    offset: usize,
}

impl embedded_io_async::ErrorType for HostUplink<'_> {
    type Error = Infallible;
}

impl embedded_io_async::Read for HostUplink<'_> {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let Some((at, bytes)) = self.schedule.get(self.next) else {
            return core::future::pending().await;
        };
        while self.clock.now() < *at {
            yield_now().await;
        }
        let rest = &bytes[self.offset.min(bytes.len())..];
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        self.offset += n;
        if self.offset >= bytes.len() {
            self.next += 1;
            self.offset = 0;
        }
        Ok(n)
    }
}

/// The host side of the telemetry link: every byte goes straight to a writer (a file for
/// `ballisto sim --firmware`, so memory does not grow with the run; a `Vec` in tests). The
/// first host write error is kept for the caller; the firmware sees the failed write as a
/// lost packet, as it would a link error.
pub struct Downlink<'a> {
    out: &'a mut dyn std::io::Write,
    bytes: u64,
    error: Option<std::io::Error>,
}

impl<'a> Downlink<'a> {
    /// A link writing to `out`.
    pub fn new(out: &'a mut dyn std::io::Write) -> Self {
        Downlink {
            out,
            bytes: 0,
            error: None,
        }
    }
}

impl embedded_io_async::ErrorType for Downlink<'_> {
    type Error = embedded_io_async::ErrorKind;
}

impl embedded_io_async::Write for Downlink<'_> {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        match self.out.write_all(buf) {
            Ok(()) => {
                self.bytes += buf.len() as u64;
                Ok(buf.len())
            }
            Err(e) => {
                self.error.get_or_insert(e);
                Err(embedded_io_async::ErrorKind::Other)
            }
        }
    }

    async fn flush(&mut self) -> Result<(), Self::Error> {
        self.out.flush().map_err(|e| {
            self.error.get_or_insert(e);
            embedded_io_async::ErrorKind::Other
        })
    }
}

/// Runs the firmware on a scenario's rig over `instants` sample instants (sampled, or skipped
/// after an overrun); `emit` gets every sample set with the estimate made from it and the
/// truth at its instant. The telemetry is discarded.
pub fn run_firmware(
    sc: &Scenario,
    config: &AppConfig,
    instants: u32,
    emit: Emit,
) -> Result<FirmwareReport, String> {
    run_firmware_with(sc, config, instants, &[], &mut std::io::sink(), emit)
}

/// [`run_firmware`] with telecommands arriving on the command link (`uplink`, one chunk of
/// bytes at a time) and every byte of the telemetry link written to `downlink`.
pub fn run_firmware_with(
    sc: &Scenario,
    config: &AppConfig,
    instants: u32,
    uplink: &Uplink,
    downlink: &mut dyn std::io::Write,
    emit: Emit,
) -> Result<FirmwareReport, String> {
    let boot = Boot {
        store: None,
        calibration: CalibrationId::default(),
        info: Boot::power_on(),
    };
    run_firmware_boot(sc, config, instants, uplink, downlink, emit, boot)
}

/// The flash of the host's calibration store: the STM32H743's word programming (32 octets,
/// once per erase) in 4 KiB sectors.
pub type HostFlash<'a> = RamFlash<'a, HOST_SECTOR, 32>;
/// The host's calibration store.
pub type HostStore<'a> = CalibrationStore<HostFlash<'a>>;
/// Sector size of [`HostFlash`].
pub const HOST_SECTOR: usize = 4096;

/// What a boot of the firmware comes up with besides its configuration: a writable
/// calibration store (its storage task runs, commits are taken) and which calibration the
/// configuration's arrangement is (housekeeping reports it).
pub struct Boot<'s, 'f> {
    /// The store, if the board has a writable one.
    pub store: Option<&'s mut HostStore<'f>>,
    /// The calibration the arrangement comes from.
    pub calibration: CalibrationId,
    /// Which boot since power-on this is, and why (housekeeping and the boot event report it).
    pub info: BootInfo,
}

impl Boot<'_, '_> {
    /// A simulated power-on: the first boot, as the boards count it
    /// (`ballisto_fw::boot::count_boot`).
    pub fn power_on() -> BootInfo {
        ballisto_fw::boot::count_boot(&mut [0; 2], ResetCause::PowerOn)
    }
}

/// A free-running part's conversion clock uncertainty once its clock is locked (none for a
/// part on the sync line).
fn clock_uncertainty(p: &ballisto_fw::sampler::part::Part<SimSpiDevice, SimI2cBus>) -> Option<f64> {
    (!p.synced() && p.clock().is_locked()).then(|| p.clock().uncertainty())
}

/// Each part's bus as the sampler takes it (the rig's ports), and the sync line.
fn sampler_ports(
    rig: &Rig,
) -> (
    [Option<PartBus<SimSpiDevice, SimI2cBus>>; MAX_PARTS],
    SimSyncPin,
) {
    let mut buses: [Option<PartBus<SimSpiDevice, SimI2cBus>>; MAX_PARTS] = Default::default();
    for (slot, port) in buses.iter_mut().zip(rig.ports.iter()) {
        *slot = Some(match port.clone() {
            Port::Spi(dev) => PartBus::Spi(dev),
            Port::I2c(bus, address) => PartBus::I2c(bus, address),
        });
    }
    let sync = SimSyncPin {
        line: rig.sync.clone(),
        clock: rig.clock.clone(),
    };
    (buses, sync)
}

/// [`run_firmware_with`] for one boot ([`Boot`]).
pub fn run_firmware_boot(
    sc: &Scenario,
    config: &AppConfig,
    instants: u32,
    uplink: &Uplink,
    downlink: &mut dyn std::io::Write,
    emit: Emit,
    boot: Boot,
) -> Result<FirmwareReport, String> {
    let rig = Rig::build(sc)?;
    let (buses, sync) = sampler_ports(&rig);
    let mut sampler = Sampler::new(&config.sampling, buses, sync);
    let spare = Loan::<Builds>::take();
    let identifier = Loan::<Identifier>::take();
    let mut app =
        App::new(config, Mode::Operate).map_err(|e| format!("firmware estimator: {e}"))?;
    app.attach_builds(spare.0);
    app.attach_identifier(identifier.0);
    let mut window = Box::new(Identification::new());
    app.set_calibration(boot.calibration);
    app.set_boot_info(boot.info);
    let requests = CommitRequests::<NoopRawMutex>::new();
    let replies = CommitReplies::<NoopRawMutex>::new();
    let writable = boot.store.is_some();
    let mut time = SimTime(rig.clock.clone());
    let app_time = SimTime(rig.clock.clone());
    let queue = Channel::<NoopRawMutex, SampleSet, { ballisto_fw::QUEUE }>::new();
    let mut slots: [Incoming; COMMAND_QUEUE] = Default::default();
    let mut commands = ZeroCopyChannel::<NoopRawMutex, Incoming>::new(&mut slots);
    let (command_tx, command_rx) = commands.split();
    let health = HealthBoard::<NoopRawMutex>::new();
    let mut telemetry = Telemetry::new(Downlink::new(downlink));
    let observations = Observations::<NoopRawMutex>::new();
    let mut observer = observations
        .subscriber()
        .map_err(|_| "the observation channel has no room for a subscriber".to_string())?;
    let mut estimates = 0u64;
    let estimation_size = std::mem::size_of_val(app.estimation());
    let app_size = std::mem::size_of_val(&app);
    let first = (-POWER_ON_NS) as Nanos;
    embassy_futures::block_on(sampler.start(&time, Some(first)));
    let start_up = rig.bus_usage();
    let task_sizes;
    {
        let sampling = async {
            sampling_task(
                &mut sampler,
                &mut time,
                queue.sender(),
                &health,
                Some(instants),
            )
            .await;
            // The run ends once the application has handled every set and the observer has
            // taken every observation (the application handles a set in one poll, up to
            // publishing it).
            while !queue.is_empty() || !observations.is_empty() {
                yield_now().await;
            }
        };
        // No watchdog on the host: the count goes unread.
        let liveness = ballisto_fw::supervisor::Liveness::new();
        let application = app_task(
            &mut app,
            &app_time,
            Links {
                samples: queue.receiver(),
                commands: command_rx,
                health: &health,
                telemetry: &mut telemetry,
                observations: &observations,
                storage: writable.then(|| StorageLinks {
                    requests: requests.sender(),
                    replies: replies.receiver(),
                }),
                liveness: &liveness,
            },
        );
        let truth = rig.truth.clone();
        let observing = async {
            loop {
                let seen = observer.next_message_pure().await;
                if let Some(motion) = &seen.motion {
                    let tr = truth.borrow_mut().truth_at(SimTime::seconds(seen.set.t));
                    emit(&seen.set, motion, &tr);
                    estimates += 1;
                }
            }
        };
        let link = HostUplink {
            clock: rig.clock.clone(),
            schedule: uplink,
            next: 0,
            offset: 0,
        };
        let receiving = async {
            uplink_task(link, command_tx).await;
            core::future::pending::<()>().await
        };
        let storing = async {
            match boot.store {
                Some(store) => {
                    storage_task(store, requests.receiver(), replies.sender()).await;
                }
                None => core::future::pending::<()>().await,
            }
        };
        // The identification task: polled after the others, as its lower priority on the board
        // (every task here handles what is queued in one poll: it runs between two sets).
        let identifying = identifier.0.run(&mut window);
        task_sizes = (
            std::mem::size_of_val(&sampling),
            std::mem::size_of_val(&application),
            std::mem::size_of_val(&receiving),
        );
        embassy_futures::block_on(select(
            sampling,
            select(
                application,
                select(receiving, select(observing, select(storing, identifying))),
            ),
        ));
    }
    let parts = (0..sc.parts.len())
        .map(|i| sampler.part_health(i).unwrap_or_default())
        .collect();
    let clock_uncertainty = (0..sc.parts.len())
        .map(|i| sampler.part(i).and_then(clock_uncertainty))
        .collect();
    let buses = rig.bus_usage_since(&start_up);
    let housekeeping = app.housekeeping(telemetry.lost());
    let link = telemetry.link();
    if let Some(e) = link.error.take() {
        return Err(format!("telemetry: {e}"));
    }
    let telemetry_bytes = link.bytes;
    Ok(FirmwareReport {
        parts,
        sampling: sampler.health(),
        estimates,
        task_sizes,
        estimation_size,
        app_size,
        buses,
        clock_uncertainty,
        housekeeping,
        telemetry_bytes,
    })
}
