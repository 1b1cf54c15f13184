//! A scenario's record read through the simulated registers (`hal-sim`'s recorder), one reading
//! per channel of its arrangement, and the scenario with ideal parts.

use hal_sim::motion::Truth;
use hal_sim::recorder::Recorder;
use hal_sim::scenario::Scenario;

/// Every sample set of `sc`: its time, one reading per channel of the scenario's arrangement
/// (NaN where a read failed), and the truth at that time.
pub fn record(sc: &Scenario) -> (Vec<(f64, Vec<f64>)>, Vec<Truth>) {
    let loaded = sc
        .arrangement()
        .load("arrangement.toml")
        .expect("arrangement");
    let mut rec = Recorder::new(sc).expect("recorder");
    let n = sc.samples();
    let (mut sets, mut truth) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        let (t, set) = rec.sample_set(k);
        let mut p = vec![f64::NAN; loaded.names.len()];
        for (part, reading) in sc.parts.iter().zip(set.iter()) {
            if let Ok(a) = reading {
                for (j, v) in a.iter().enumerate() {
                    if let Some(c) = loaded.channel(&part.name, j) {
                        p[c] = *v;
                    }
                }
            }
        }
        sets.push((t, p));
        truth.push(rec.truth(t));
    }
    (sets, truth)
}
