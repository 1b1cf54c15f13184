//! One part as the sampler drives it: its driver, how its samples are timed, its recent
//! timestamped samples and its health counters.

use embedded_hal_async::i2c::I2c;
use embedded_hal_async::spi::SpiDevice;
use heapless::HistoryBuf;

use super::conversion_clock::ConversionClock;
use crate::config::{Alignment, PartConfig, PartKind};
use crate::drivers::{adxl355, lis3dh};
use crate::time::{seconds, Nanos, TimeBase};

/// Oscillator tolerance assumed for a part's own clock before its period is measured.
const ODR_TOLERANCE: f64 = 0.02;
/// Allowance for conversion-instant jitter and the read instants (s).
const TIMING_MARGIN: f64 = 30e-6;
/// Consecutive failed reads after which a part is restarted (reset, identify, configure).
const FAILURES_TO_RESTART: u16 = 10;
/// Sample sets between restart attempts of a part that is down.
const RESTART_EVERY: u32 = 100;
/// Recent samples kept for interpolation.
const RECENT: usize = 4;

/// How the controller reaches one part.
pub enum PartBus<SPI, I2C> {
    /// An SPI device (chip select included).
    Spi(SPI),
    /// An I²C bus and the part's 7-bit address.
    I2c(I2C, u8),
}

/// The driver of a part.
enum Driver<SPI, I2C> {
    Adxl355(adxl355::Adxl355<SPI>),
    Lis3dh(lis3dh::Lis3dh<I2C>),
}

/// Health counters of one part (telemetry).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PartHealth {
    /// Read transactions attempted.
    pub reads: u32,
    /// Transfers the bus reported failed (no acknowledge, timeout, …).
    pub bus_errors: u32,
    /// Transfers whose data failed the plausibility check (or a wrong ID at start-up).
    pub implausible: u32,
    /// Sample sets without a value from this part (failed read, no new sample, lost FIFO
    /// count, nothing to interpolate from).
    pub missed: u32,
    /// Start attempts that failed.
    pub failed_starts: u32,
    /// Times the conversion clock lost its phase (FIFO overrun or a contradiction).
    pub resyncs: u32,
    /// The part is configured and being read.
    pub running: bool,
}

/// What went wrong in one transfer.
enum Fault {
    Bus,
    Implausible,
}

impl<E> From<adxl355::Error<E>> for Fault {
    fn from(e: adxl355::Error<E>) -> Self {
        match e {
            adxl355::Error::Bus(_) => Fault::Bus,
            _ => Fault::Implausible,
        }
    }
}

impl<E> From<lis3dh::Error<E>> for Fault {
    fn from(e: lis3dh::Error<E>) -> Self {
        match e {
            lis3dh::Error::Bus(_) => Fault::Bus,
            _ => Fault::Implausible,
        }
    }
}

/// What a read of a free-running part came to.
pub enum Reading {
    /// The part's value at the set instant and its variance factor, or `None`.
    Value(Option<([f32; 3], f32)>),
    /// Read once more at this instant, when the conversion after the set instant has surely
    /// happened.
    Later(Nanos),
}

/// A recent sample: (conversion index, x, y, z).
type Recent = (u64, [f32; 3]);

/// One read of a FIFO's level: between the instants `a` and `b` it held `samples` samples
/// (`entries` in the part's own unit) and had, or had not, overrun.
struct Level {
    a: Nanos,
    b: Nanos,
    samples: usize,
    entries: u8,
    lost: bool,
}

/// One part.
pub struct Part<SPI, I2C> {
    config: PartConfig,
    alignment: Alignment,
    driver: Driver<SPI, I2C>,
    clock: ConversionClock,
    /// Samples popped from the FIFO since the count was last lost.
    popped: u64,
    /// The most recent samples: (conversion index, x, y, z); a new one replaces the oldest.
    recent: HistoryBuf<Recent, RECENT>,
    /// Duration of the latest level read (ns).
    level_read: Nanos,
    failures: u16,
    health: PartHealth,
}

impl<SPI: SpiDevice, I2C: I2c> Part<SPI, I2C> {
    /// A part on its bus, not started. `None` if the part type does not match the bus.
    pub fn new(config: PartConfig, alignment: Alignment, bus: PartBus<SPI, I2C>) -> Option<Self> {
        let driver = match (config.kind, bus) {
            (PartKind::Adxl355 { range, .. }, PartBus::Spi(spi)) => {
                Driver::Adxl355(adxl355::Adxl355::bare(spi, range))
            }
            (PartKind::Lis3dh { range, .. }, PartBus::I2c(i2c, address)) => {
                Driver::Lis3dh(lis3dh::Lis3dh::bare(i2c, address, range))
            }
            _ => return None,
        };
        let period = 1.0 / f64::from(config.kind.odr_hz());
        Some(Part {
            config,
            alignment,
            driver,
            clock: ConversionClock::new(period, ODR_TOLERANCE, TIMING_MARGIN),
            popped: 0,
            recent: HistoryBuf::new(),
            level_read: 0,
            failures: 0,
            health: PartHealth::default(),
        })
    }

    /// The health counters.
    pub fn health(&self) -> PartHealth {
        let mut h = self.health;
        h.resyncs = h.resyncs.saturating_add(self.clock.resyncs());
        h
    }

    /// The conversion clock (free-running parts).
    pub fn clock(&self) -> &ConversionClock {
        &self.clock
    }

    /// True if the part samples on the SYNC line.
    pub fn synced(&self) -> bool {
        !self.config.kind.free_running()
    }

    /// True if the part is read through its FIFO with timestamps.
    fn interpolated(&self) -> bool {
        self.config.kind.free_running() && self.alignment == Alignment::Interpolate
    }

    /// True if running.
    pub fn running(&self) -> bool {
        self.health.running
    }

    /// Starts the part (reset, identification, configuration); failures are counted.
    pub async fn start(&mut self) {
        let fifo = self.interpolated();
        let r: Result<(), Fault> = match (&mut self.driver, self.config.kind) {
            (Driver::Adxl355(d), PartKind::Adxl355 { range, odr, sync }) => {
                let sync = if sync {
                    adxl355::Sync::External
                } else {
                    adxl355::Sync::Internal
                };
                d.start(adxl355::Config { range, odr, sync })
                    .await
                    .map_err(Fault::from)
            }
            (Driver::Lis3dh(d), PartKind::Lis3dh { range, odr }) => d
                .start(lis3dh::Config { range, odr, fifo })
                .await
                .map_err(Fault::from),
            _ => Err(Fault::Implausible),
        };
        self.health.running = r.is_ok();
        self.failures = 0;
        self.popped = 0;
        self.recent.clear();
        self.clock.unlock();
        if r.is_err() {
            self.health.failed_starts += 1;
        }
    }

    /// Restarts a part that is down, every [`RESTART_EVERY`] sample sets.
    pub async fn maybe_restart(&mut self, k: u32) {
        if !self.health.running && k.is_multiple_of(RESTART_EVERY) {
            self.start().await;
        }
    }

    /// Counts one read and its failure; a part failing too often in a row is marked down.
    fn count<T>(&mut self, r: Result<T, Fault>) -> Option<T> {
        self.health.reads += 1;
        match r {
            Ok(v) => {
                self.failures = 0;
                Some(v)
            }
            Err(f) => {
                match f {
                    Fault::Bus => self.health.bus_errors += 1,
                    Fault::Implausible => self.health.implausible += 1,
                }
                self.failures += 1;
                if self.failures >= FAILURES_TO_RESTART {
                    self.health.running = false;
                }
                None
            }
        }
    }

    /// The part's value for the set, counting a set without one as missed.
    fn or_missed<V>(&mut self, value: Option<V>) -> Option<V> {
        if value.is_none() {
            self.health.missed += 1;
        }
        value
    }

    /// The sample of a part on the SYNC line, just pulsed: `None` if the read failed or the
    /// part has no new sample.
    pub async fn read_synced(&mut self) -> Option<[f32; 3]> {
        if !self.health.running {
            return self.or_missed(None);
        }
        let r = match &mut self.driver {
            Driver::Adxl355(d) => d.read_status_and_acceleration().await.map_err(Fault::from),
            Driver::Lis3dh(_) => Err(Fault::Implausible),
        };
        let value = self
            .count(r)
            .and_then(|(status, a)| status.data_ready().then_some(a));
        self.or_missed(value)
    }

    /// The part's temperature (°C), counted as a read: `None` if it is down, the read failed
    /// or the value is not a temperature (`estimator_core::thermal::plausible`).
    pub async fn read_temperature(&mut self) -> Option<f32> {
        if !self.health.running {
            return None;
        }
        let r = match &mut self.driver {
            Driver::Adxl355(d) => d.read_temperature().await.map_err(Fault::from),
            Driver::Lis3dh(d) => d.read_temperature().await.map_err(Fault::from),
        };
        let r = r.and_then(|t| {
            if estimator_core::thermal::plausible(f64::from(t)) {
                Ok(t)
            } else {
                Err(Fault::Implausible)
            }
        });
        self.count(r)
    }

    /// The latest output as if sampled now ([`Alignment::Latest`]).
    pub async fn read_latest(&mut self) -> Option<[f32; 3]> {
        if !self.health.running {
            return self.or_missed(None);
        }
        let r = match &mut self.driver {
            Driver::Adxl355(d) => d.read_acceleration().await.map_err(Fault::from),
            Driver::Lis3dh(d) => d.read_acceleration().await.map_err(Fault::from),
        };
        let value = self.count(r);
        self.or_missed(value)
    }

    /// When to read this part for the sample instant `t`, and when to read its FIFO level
    /// alone, both from one prediction of its next conversion: the read at that conversion if
    /// it comes by `latest` (reads until then end before the next instant `end`); else the
    /// read at once (the set's value is extrapolated then) and, if the part's phase is known
    /// and a level read there ends well before `end`, the level read at the conversion.
    /// Without that level read a conversion late in the period is never met by a read: at the
    /// set rate, a LIS3DH at +150 ppm stayed in the last eighth of the period for 8 s, its
    /// conversion clock running on the period estimate alone and 0.3–1.0 ms off, its values
    /// 1.5–2.9 × white noise in their 0.5 s means at 3 rad/s.
    pub fn read_times(&self, t: Nanos, latest: Nanos, end: Nanos) -> (Nanos, Option<Nanos>) {
        let at = self.predicted_after(t).saturating_sub(self.level_read / 2);
        if at >= t && at <= latest {
            return (at, None);
        }
        let probe = self.health.running
            && self.clock.is_locked()
            && at > latest
            && at + 2 * self.level_read <= end;
        (t, probe.then_some(at))
    }

    /// A level read only, at [`Part::read_times`]' second instant: it cuts the conversion clock's interval;
    /// the samples wait in the FIFO for the next set's read. Skipped if it could not end
    /// well before the next instant `end` (the reads before it ran long).
    pub async fn probe_level<T: TimeBase>(&mut self, time: &T, end: Nanos) {
        if time.now() + 2 * self.level_read > end {
            return;
        }
        let r = self.read_level(time).await;
        if let Some(level) = self.count(r) {
            self.observe(&level, false);
        }
    }

    /// The predicted first conversion after `t` (`t` itself while the phase is unknown). A
    /// level read is best started half its duration before it: the instant at which the
    /// part counts is somewhere in the transfer, and a read that starts at the prediction
    /// sees the conversion counted whenever it came up to a transfer late, which cuts the
    /// clock's interval from one side only.
    fn predicted_after(&self, t: Nanos) -> Nanos {
        (self.clock.probe_after(seconds(t)) * 1e9) as Nanos
    }

    /// Reads the FIFO (level, then the samples, timestamped by the conversion clock) and
    /// interpolates to the instant `t`: the value and its noise variance over one sample's
    /// (see [`value_at`]). If the newest sample is still before `t` (the read came before the
    /// next conversion, which happens about half the time while the conversion clock's
    /// interval is wide: the first ~0.7 s after a start, before its period is measured), and
    /// `again` allows, asks to be read once more when that conversion has surely happened, if
    /// that is not after `latest`: otherwise the value is extrapolated from the two samples
    /// before `t`, with up to √5 ≈ 2.2 × their noise (measured on the mixed layout's LIS3DHs:
    /// 1.5–2.0 × the declared noise over the first 0.7 s, against 1.0 after; the fault
    /// monitor's window was 3 × its degrees of freedom there, and every fault-free run
    /// flagged).
    pub async fn read_interpolated<T: TimeBase>(
        &mut self,
        time: &T,
        t: Nanos,
        latest: Nanos,
        again: bool,
    ) -> Reading {
        if !self.health.running {
            return Reading::Value(self.or_missed(None));
        }
        let r = self.drain(time).await;
        if self.count(r).is_none() {
            return Reading::Value(self.or_missed(None));
        }
        let newest = self.recent.recent().map_or(0, |s| s.0);
        let at = (self.clock.surely_by(newest + 1) * 1e9) as Nanos;
        if again && self.clock.time_of(newest) < seconds(t) && at <= latest {
            return Reading::Later(at);
        }
        let value = self.value_at(seconds(t));
        Reading::Value(self.or_missed(value))
    }

    /// One FIFO read: the level (an observation of the conversion count), then that many
    /// samples.
    async fn drain<T: TimeBase>(&mut self, time: &T) -> Result<(), Fault> {
        let mut buf = [[0.0f32; 3]; 32];
        let level = self.read_level(time).await?;
        let got = match &mut self.driver {
            Driver::Adxl355(d) => d.read_fifo_entries(level.entries, &mut buf).await?,
            Driver::Lis3dh(d) => {
                d.read_fifo(&mut buf[..level.samples]).await?;
                level.samples
            }
        };
        self.observe(&level, got != level.samples);
        for (i, s) in buf[..got].iter().enumerate() {
            self.remember(self.popped + 1 + i as u64, *s);
        }
        self.popped += level.samples as u64;
        Ok(())
    }

    /// The FIFO level between two time stamps, and whether it overran.
    async fn read_level<T: TimeBase>(&mut self, time: &T) -> Result<Level, Fault> {
        let level = match &mut self.driver {
            Driver::Adxl355(d) => {
                let lost = d.status().await?.fifo_overrun();
                let a = time.now();
                let entries = d.fifo_entries().await?;
                let b = time.now();
                let samples = usize::from(entries / 3);
                Level {
                    a,
                    b,
                    samples,
                    entries,
                    lost,
                }
            }
            Driver::Lis3dh(d) => {
                let a = time.now();
                let l = d.fifo_level().await?;
                let b = time.now();
                Level {
                    a,
                    b,
                    samples: usize::from(l.samples),
                    entries: l.samples,
                    lost: l.overrun,
                }
            }
        };
        self.level_read = level.b.saturating_sub(level.a);
        Ok(level)
    }

    /// Tells the conversion clock the count a level read saw; if the count is broken (an
    /// overrun, or fewer samples read than the level said) counting starts again from the
    /// samples then in the FIFO.
    fn observe(&mut self, level: &Level, short: bool) {
        if level.lost || short {
            self.clock.unlock();
            self.health.resyncs += 1;
            self.popped = 0;
            self.recent.clear();
        }
        let n = self.popped + level.samples as u64;
        self.clock.observe(seconds(level.a), seconds(level.b), n);
    }

    fn remember(&mut self, index: u64, value: [f32; 3]) {
        self.recent.write((index, value));
    }

    /// The part's value at `t` from its recent samples, and its variance factor (see
    /// [`value_at`]).
    fn value_at(&self, t: f64) -> Option<([f32; 3], f32)> {
        value_at(&self.recent, &self.clock, t)
    }
}

/// Linear interpolation between the two recent samples around `t` (their conversion times
/// from `clock`), or extrapolation from the last two by at most one and a half periods;
/// `None` without two samples, without a locked clock, or too far from them. With the value,
/// its noise variance over one sample's, `(1 − w)² + w²` for the weight `w` of the later
/// sample (0.5 midway, 1 at a sample, up to 5 extrapolated): what the fault monitor's test
/// must expect of it (`FaultMonitor::set_variance`).
fn value_at(
    recent: &HistoryBuf<Recent, RECENT>,
    clock: &ConversionClock,
    t: f64,
) -> Option<([f32; 3], f32)> {
    if recent.len() < 2 || !clock.is_locked() {
        return None;
    }
    let time = |s: &Recent| clock.time_of(s.0);
    // The first two consecutive samples whose later one is at or after `t`, else the last
    // two.
    let mut pair: Option<(Recent, Recent)> = None;
    let mut before: Option<Recent> = None;
    for s in recent.oldest_ordered() {
        if let Some(b) = before {
            pair = Some((b, *s));
            if time(s) >= t {
                break;
            }
        }
        before = Some(*s);
    }
    let (sa, sb) = pair?;
    let (t0, t1) = (time(&sa), time(&sb));
    let reach = 1.5 * clock.period();
    if !(t1 > t0) || t > t1 + reach || t < t0 - reach {
        return None;
    }
    let w = ((t - t0) / (t1 - t0)) as f32;
    let (a, b) = (sa.1, sb.1);
    let variance = (1.0 - w) * (1.0 - w) + w * w;
    Some((core::array::from_fn(|k| a[k] + w * (b[k] - a[k])), variance))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clock locked on conversion 0 at about 10 ms, period 2.5 ms.
    fn clock() -> ConversionClock {
        let mut c = ConversionClock::new(0.0025, 1e-3, 5e-6);
        c.observe(0.010, 0.010_000_1, 0);
        assert!(c.is_locked());
        c
    }

    /// Samples `from..to`, value of sample `i` = (i, 2i, −i).
    fn samples(from: u64, to: u64) -> HistoryBuf<Recent, RECENT> {
        let mut h = HistoryBuf::new();
        for i in from..to {
            h.write((i, [i as f32, 2.0 * i as f32, -(i as f32)]));
        }
        h
    }

    #[test]
    fn interpolates_between_the_samples_around_t() {
        let c = clock();
        let h = samples(0, 4);
        let (t1, t2) = (c.time_of(1), c.time_of(2));
        let (v, variance) = value_at(&h, &c, t1 + 0.25 * (t2 - t1)).unwrap();
        for (got, want) in v.iter().zip([1.25f32, 2.5, -1.25]) {
            assert!((got - want).abs() < 1e-5, "{v:?}");
        }
        // 0.75² + 0.25² of one sample's variance.
        assert!((variance - 0.625).abs() < 1e-5, "{variance}");
        // At a sample's own time: that sample.
        assert_eq!(value_at(&h, &c, t2), Some(([2.0, 4.0, -2.0], 1.0)));
    }

    #[test]
    fn extrapolates_at_most_one_and_a_half_periods() {
        let c = clock();
        let h = samples(0, 4);
        let (t3, p) = (c.time_of(3), c.period());
        let (v, variance) = value_at(&h, &c, t3 + p).unwrap();
        assert!((v[0] - 4.0).abs() < 1e-4, "{v:?}");
        // 2 × sample 3 − sample 2: (−1)² + 2².
        assert!((variance - 5.0).abs() < 1e-3, "{variance}");
        assert_eq!(value_at(&h, &c, t3 + 1.6 * p), None);
        assert_eq!(value_at(&h, &c, c.time_of(0) - 1.6 * p), None);
    }

    #[test]
    fn keeps_the_latest_samples_only_and_needs_two_and_a_locked_clock() {
        let c = clock();
        // Ten written, four kept (6..10): sample 2's time is out of reach now.
        let h = samples(0, 10);
        assert_eq!(h.len(), RECENT);
        assert_eq!(value_at(&h, &c, c.time_of(2)), None);
        assert_eq!(
            value_at(&h, &c, c.time_of(7)),
            Some(([7.0, 14.0, -7.0], 1.0))
        );
        assert_eq!(value_at(&samples(0, 1), &c, c.time_of(0)), None);
        let unlocked = ConversionClock::new(0.0025, 1e-3, 5e-6);
        assert_eq!(value_at(&h, &unlocked, c.time_of(7)), None);
    }
}
