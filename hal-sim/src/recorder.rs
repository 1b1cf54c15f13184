//! The simulator's own reader of a scenario: the rig with every part read through its bus by
//! the bench reader at the scenario's rate (the reference record of `ballisto sim`, without the
//! firmware).

use crate::bench::{BenchError, BenchReader};
use crate::rig::Rig;
use crate::scenario::Scenario;

/// A scenario being recorded: the rig and the bench reader that reads every part at the
/// scenario's rate (pulsing the SYNC line first when a part samples on it).
pub struct Recorder {
    rig: Rig,
    reader: BenchReader,
    rate: f64,
    any_sync: bool,
    /// Bus usage of the start-up (identification and configuration).
    start_up: Vec<(String, u64, f64)>,
    /// Sets between reads of every part's temperature, where the scenario models it.
    temperature_every: Option<usize>,
}

impl Recorder {
    /// Builds the rig and starts the reader (identification and configuration of every part
    /// before t = 0).
    pub fn new(sc: &Scenario) -> Result<Self, String> {
        let rig = Rig::build(sc)?;
        let reader = BenchReader::start(sc, &rig.ports)?;
        let start_up = rig.bus_usage();
        Ok(Recorder {
            start_up,
            rig,
            reader,
            rate: sc.rate,
            any_sync: sc.parts.iter().any(|p| sc.sync(p)),
            temperature_every: sc
                .temperature
                // As often as the firmware reads each part's.
                .map(|_| {
                    let hz = f64::from(ballisto_fw::sampler::TEMPERATURE_HZ);
                    ((sc.rate / hz).floor() as usize).max(1)
                }),
        })
    }

    /// After sample set `k`: every part's temperature (°C, `None` where the read failed) if
    /// the scenario models temperature and this set is one it is read after.
    pub fn temperatures(&mut self, k: usize) -> Option<Vec<Option<f64>>> {
        let every = self.temperature_every?;
        if !k.is_multiple_of(every) {
            return None;
        }
        let n = self.rig.ports.len();
        Some(
            (0..n)
                .map(|i| self.reader.read_temperature(i).ok())
                .collect(),
        )
    }

    /// Sample set `k` at `t = k / rate`: each part's reading (m/s², part axes) or its error.
    pub fn sample_set(&mut self, k: usize) -> (f64, Vec<Result<[f64; 3], BenchError>>) {
        let t = k as f64 / self.rate;
        self.rig.clock.advance_to(t);
        if self.any_sync {
            self.rig.sync.pulse(t);
        }
        let n = self.rig.ports.len();
        (t, (0..n).map(|i| self.reader.read(i)).collect())
    }

    /// The truth at `t`.
    pub fn truth(&self, t: f64) -> crate::motion::Truth {
        self.rig.truth.borrow_mut().truth_at(t)
    }

    /// The rig (clock, buses).
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// Bus usage of the sample sets so far (start-up excluded): name, bytes, busy seconds.
    pub fn sampling_usage(&self) -> Vec<(String, u64, f64)> {
        self.rig.bus_usage_since(&self.start_up)
    }

    /// The reader's counts.
    pub fn reader(&self) -> &BenchReader {
        &self.reader
    }
}
