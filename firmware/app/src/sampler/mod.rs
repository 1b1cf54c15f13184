//! Synchronized sampling: every part sampled at one rate on one time base (sampler → the
//! estimation task).
//!
//! At each instant `t_k = t_0 + k/rate` the sampler pulses the SYNC line (parts on it take one
//! sample then) and reads those parts; then it reads each free-running part through its FIFO
//! at the instant its [`ConversionClock`] says is most informative (its next conversion, if a
//! read there ends well before `t_{k+1}`; else at once, and the FIFO level alone at that
//! conversion), timestamps the FIFO samples and interpolates to `t_k`
//! ([`Alignment::Interpolate`]); or it takes the latest output as the value at `t_k`
//! ([`Alignment::Latest`], the unaligned reference). The reads of a set run in time order.
//! A set records which parts have no value.
//!
//! The loop never stalls on a part: a failed read is counted and leaves that part's value
//! empty; a part failing repeatedly is marked down and restarted every second or so; if a set
//! overruns its period, the instants already past are skipped and counted.

pub mod conversion_clock;
pub mod health;
pub mod part;

use embassy_sync::blocking_mutex::raw::RawMutex;
use embassy_sync::channel::Sender;
use embedded_hal::digital::OutputPin;
use embedded_hal_async::i2c::I2c;
use embedded_hal_async::spi::SpiDevice;
use heapless::Vec;

pub use conversion_clock::ConversionClock;
pub use health::{Health, HealthBoard};
pub use part::{Part, PartBus, PartHealth, Reading};

use crate::config::{Alignment, SamplingConfig, MAX_PARTS};
use crate::time::{Nanos, TimeBase};

/// The readings of all parts at one instant.
#[derive(Clone, Copy, Debug)]
pub struct SampleSet {
    /// Index of the instant since the sampler started.
    pub k: u32,
    /// The instant (time base).
    pub t: Nanos,
    /// Each part's x, y, z (m/s², part axes) at `t`, or `None`.
    pub parts: [Option<[f32; 3]>; MAX_PARTS],
    /// Each part's noise variance over one sample's declared one: 1 for a sample taken at
    /// `t`, `(1 − w)² + w²` for a value interpolated with weight `w` (0.5 midway), so that the
    /// fault monitor expects of it what it has.
    pub variance: [f32; MAX_PARTS],
    /// Each part's last temperature read (°C; NaN where none): every part's at start, then
    /// one part's after the readings of every [`Sampler::temperature_every`]-th set, in turn.
    pub temperatures: [f32; MAX_PARTS],
    /// Temperature reads since start (wrapping): a set whose count differs from the last
    /// set's carries a new temperature.
    pub temperature_reads: u32,
}

impl SampleSet {
    /// The set of index `k` at `t` with the parts' values (each a sample taken at `t`).
    pub fn new(k: u32, t: Nanos, parts: [Option<[f32; 3]>; MAX_PARTS]) -> Self {
        SampleSet {
            k,
            t,
            parts,
            variance: [1.0; MAX_PARTS],
            temperatures: [f32::NAN; MAX_PARTS],
            temperature_reads: 0,
        }
    }
}

/// Counters of the sampling loop itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoopHealth {
    /// Sample sets produced.
    pub sets: u32,
    /// Instants skipped because a set overran its period.
    pub skipped: u32,
    /// Sets the estimation task had no room for (its queue was full).
    pub dropped: u32,
    /// Failures to drive the SYNC line.
    pub sync_errors: u32,
}

/// The sampler: the parts, the SYNC line and the schedule.
pub struct Sampler<SPI, I2C, SYNC> {
    parts: [Option<Part<SPI, I2C>>; MAX_PARTS],
    sync: SYNC,
    period: Nanos,
    alignment: Alignment,
    t0: Nanos,
    k: u32,
    health: LoopHealth,
    /// Sets between two temperature reads.
    temperature_every: u32,
    /// The part whose temperature is read next.
    temperature_next: usize,
    /// Each part's last temperature read (°C; NaN where none).
    temperatures: [f32; MAX_PARTS],
    /// Temperature reads since start (wrapping).
    temperature_reads: u32,
}

/// How often each part's temperature is read (Hz): a part's die follows its surroundings
/// over minutes, and a read is one short transfer after a set's readings.
pub const TEMPERATURE_HZ: f32 = 4.0;

impl<SPI: SpiDevice, I2C: I2c, SYNC: OutputPin> Sampler<SPI, I2C, SYNC> {
    /// A sampler for `config`, with the bus handle of each configured part (same index); a
    /// part without a handle, or on a bus of the wrong kind, stays empty.
    pub fn new(
        config: &SamplingConfig,
        mut buses: [Option<PartBus<SPI, I2C>>; MAX_PARTS],
        sync: SYNC,
    ) -> Self {
        let parts: [Option<Part<SPI, I2C>>; MAX_PARTS] =
            core::array::from_fn(|i| match (config.parts[i], buses[i].take()) {
                (Some(p), Some(bus)) => Part::new(p, config.alignment, bus),
                _ => None,
            });
        let count = parts.iter().flatten().count().max(1) as f32;
        let temperature_every = (config.rate_hz / (TEMPERATURE_HZ * count)).max(1.0) as u32;
        Sampler {
            parts,
            sync,
            period: config.period_ns().max(1),
            alignment: config.alignment,
            t0: 0,
            k: 0,
            health: LoopHealth::default(),
            temperature_every,
            temperature_next: 0,
            temperatures: [f32::NAN; MAX_PARTS],
            temperature_reads: 0,
        }
    }

    /// Sets between two temperature reads: each part's temperature is read at about
    /// [`TEMPERATURE_HZ`] (or once per set where the rate is lower).
    pub fn temperature_every(&self) -> u32 {
        self.temperature_every
    }

    /// The next part's temperature (round robin over the configured parts); a failed read
    /// keeps the last one.
    async fn read_temperature(&mut self) {
        for _ in 0..MAX_PARTS {
            let i = self.temperature_next;
            self.temperature_next = (i + 1) % MAX_PARTS;
            if let Some(p) = self.parts[i].as_mut() {
                if let Some(t) = p.read_temperature().await {
                    self.temperatures[i] = t;
                    self.temperature_reads = self.temperature_reads.wrapping_add(1);
                }
                return;
            }
        }
    }

    /// Starts every part (failures are counted; such parts are retried while sampling) and
    /// sets the first instant: `first` if given and not past, else the next instant after
    /// now on the grid of `first` (default: whole periods of the time base).
    pub async fn start<T: TimeBase>(&mut self, time: &T, first: Option<Nanos>) {
        let _ = self.sync.set_low();
        for p in self.parts.iter_mut().flatten() {
            p.start().await;
        }
        // Every part's temperature before the first set: its readings are corrected from the
        // first on.
        for _ in 0..self.parts.iter().flatten().count() {
            self.read_temperature().await;
        }
        let grid = first.unwrap_or(0);
        let now = time.now();
        self.t0 = if grid >= now {
            grid
        } else {
            grid + (now - grid).div_ceil(self.period) * self.period
        };
        self.k = 0;
    }

    /// A part's health counters.
    pub fn part_health(&self, i: usize) -> Option<PartHealth> {
        self.parts.get(i)?.as_ref().map(Part::health)
    }

    /// A part (for its conversion clock).
    pub fn part(&self, i: usize) -> Option<&Part<SPI, I2C>> {
        self.parts.get(i)?.as_ref()
    }

    /// The loop's counters.
    pub fn health(&self) -> LoopHealth {
        self.health
    }

    /// Every counter, for the housekeeping reports.
    pub fn snapshot(&self) -> Health {
        let mut parts = [None; MAX_PARTS];
        for (slot, part) in parts.iter_mut().zip(self.parts.iter()) {
            *slot = part.as_ref().map(Part::health);
        }
        Health {
            parts,
            sampling: self.health,
        }
    }

    /// The index of the next instant to sample at time `now`: instants more than half a
    /// period past (the previous set overran) are skipped and counted.
    pub fn next_index(&mut self, now: Nanos) -> u32 {
        let t = self.t0 + u64::from(self.k) * self.period;
        if now > t + self.period / 2 {
            let behind = ((now - t) / self.period + 1) as u32;
            self.k = self.k.saturating_add(behind);
            self.health.skipped = self.health.skipped.saturating_add(behind);
        }
        self.k
    }

    /// Waits for the next instant and samples every part.
    pub async fn sample<T: TimeBase>(&mut self, time: &mut T) -> SampleSet {
        self.next_index(time.now());
        let t = self.t0 + u64::from(self.k) * self.period;
        time.wait_until(t).await;
        let k = self.k;
        for p in self.parts.iter_mut().flatten() {
            p.maybe_restart(k).await;
        }
        let mut set = SampleSet::new(k, t, [None; MAX_PARTS]);
        // Parts on the SYNC line sample on this edge.
        if self.parts.iter().flatten().any(|p| p.synced()) {
            let ok = self.sync.set_high().is_ok() & self.sync.set_low().is_ok();
            if !ok {
                self.health.sync_errors += 1;
            }
        }
        for (out, p) in set.parts.iter_mut().zip(self.parts.iter_mut()) {
            if let Some(p) = p.as_mut().filter(|p| p.synced()) {
                *out = p.read_synced().await;
            }
        }
        self.read_free_running(time, t, &mut set).await;
        if k.is_multiple_of(self.temperature_every) {
            self.read_temperature().await;
        }
        set.temperatures = self.temperatures;
        set.temperature_reads = self.temperature_reads;
        self.k = self.k.saturating_add(1);
        self.health.sets = self.health.sets.saturating_add(1);
        set
    }

    /// The free-running parts: each at its own read instant (in time order), or all at once
    /// for [`Alignment::Latest`].
    async fn read_free_running<T: TimeBase>(
        &mut self,
        time: &mut T,
        t: Nanos,
        set: &mut SampleSet,
    ) {
        // Reads end before the next instant, when the SYNC line is pulsed again: they start by
        // 7/8 of the period (room for the transfers). Each part is read once (twice if the
        // first read came before its conversion after `t`), and its level read once more at its
        // next conversion if the read could not meet it (see `Part::read_times`); all in time
        // order, so that no part's wait holds up another's.
        let end = t + self.period;
        let latest = end - self.period / 8;
        let mut steps: Vec<(Nanos, usize, Step), { 3 * MAX_PARTS }> = Vec::new();
        for (i, p) in self.parts.iter().enumerate() {
            if let Some(p) = p.as_ref().filter(|p| !p.synced()) {
                let (read, probe) = p.read_times(t, latest, end);
                let _ = steps.push((read, i, Step::Read));
                if let Some(at) = probe {
                    let _ = steps.push((at, i, Step::Probe));
                }
            }
        }
        while let Some(next) = (0..steps.len()).min_by_key(|&j| steps[j]) {
            let (at, i, step) = steps.swap_remove(next);
            let Some(p) = self.parts[i].as_mut() else {
                continue;
            };
            if self.alignment == Alignment::Latest {
                set.parts[i] = p.read_latest().await;
                continue;
            }
            time.wait_until(at).await;
            match step {
                Step::Read | Step::Reread => {
                    match p
                        .read_interpolated(time, t, latest, step == Step::Read)
                        .await
                    {
                        Reading::Value(value) => {
                            set.parts[i] = value.map(|(value, variance)| {
                                set.variance[i] = variance;
                                value
                            });
                        }
                        Reading::Later(at) => {
                            let _ = steps.push((at, i, Step::Reread));
                        }
                    }
                }
                Step::Probe => p.probe_level(time, end).await,
            }
        }
    }
}

/// One step of a set's reads of the free-running parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Step {
    /// The set's read.
    Read,
    /// A second read, after the conversion the first came before.
    Reread,
    /// A level read alone, at a conversion the read could not meet.
    Probe,
}

/// The sampling task: one sample set per period into the estimation queue, without waiting
/// for room (a full queue drops the set and counts it). Runs up to the instant of index
/// `instants` (sampled or skipped), or for ever. Call [`Sampler::start`] first.
pub async fn sampling_task<SPI, I2C, SYNC, T, M, const Q: usize>(
    sampler: &mut Sampler<SPI, I2C, SYNC>,
    time: &mut T,
    queue: Sender<'_, M, SampleSet, Q>,
    board: &HealthBoard<M>,
    instants: Option<u32>,
) where
    SPI: SpiDevice,
    I2C: I2c,
    SYNC: OutputPin,
    T: TimeBase,
    M: RawMutex,
{
    while instants.is_none_or(|n| sampler.next_index(time.now()) < n) {
        let set = sampler.sample(time).await;
        if queue.try_send(set).is_err() {
            sampler.health.dropped = sampler.health.dropped.saturating_add(1);
        }
        board.publish(sampler.snapshot());
    }
}
