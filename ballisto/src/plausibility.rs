//! Whether inputs look like what the file formats say (docs/formats.md: positions in metres,
//! readings in m/s²), so that a wrong unit does not pass silently. Each check returns a
//! warning that names the likely cause; a reading no accelerometer can give is treated as
//! missing and flagged ([`Flags::INPUT_ABSURD`]).

use ballisto_config::arrangement_file::LoadedArrangement;
use estimator_core::Flags;

/// Smallest extent of an array that can see rotation, m: below it the positions are likely
/// in kilometres, or all the same.
pub const EXTENT_MIN: f64 = 1e-3;
/// Largest extent, m: beyond it the positions are likely in millimetres.
pub const EXTENT_MAX: f64 = 10.0;

/// Where a channel declares no full scale: readings beyond this are absurd, m/s² (≈ 1000 g,
/// beyond the MEMS accelerometers this tool knows, and what raw 16-bit counts reach).
pub const READING_MAX: f64 = 1e4;

/// A reading is absurd beyond this many times its channel's full scale (a part saturates at
/// its full scale; twice it cannot be a reading).
pub const RANGE_FACTOR: f64 = 2.0;

/// The largest plausible reading of each channel (`ranges`: full scale, infinite if none).
pub fn reading_bounds(ranges: &[f64]) -> Vec<f64> {
    ranges
        .iter()
        .map(|r| {
            if r.is_finite() {
                RANGE_FACTOR * r
            } else {
                READING_MAX
            }
        })
        .collect()
}

/// Warnings on an arrangement: its extent (largest distance between two channels' positions)
/// outside [`EXTENT_MIN`]–[`EXTENT_MAX`], naming the likely unit; sensors without an
/// `orientation` (taken as the identity, which a part mounted otherwise silently breaks).
pub fn arrangement(loaded: &LoadedArrangement, file: &str) -> Vec<String> {
    let mut warnings: Vec<String> = extent(loaded, file).into_iter().collect();
    if !loaded.unoriented.is_empty() {
        warnings.push(format!(
            "{file}: no orientation for sensor {}: taken as the identity (the part's axes along the body's); write orientation = [[1, 0, 0], [0, 1, 0], [0, 0, 1]] if that is how it is mounted",
            loaded
                .unoriented
                .iter()
                .map(|n| format!("\"{n}\""))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    warnings
}

/// The extent outside [`EXTENT_MIN`]–[`EXTENT_MAX`]: a warning naming the likely unit.
fn extent(loaded: &LoadedArrangement, file: &str) -> Option<String> {
    let chans = loaded.arrangement.channels();
    let mut extent: f64 = 0.0;
    for (i, a) in chans.iter().enumerate() {
        for b in &chans[i + 1..] {
            let d = (0..3)
                .map(|k| (a.position[k] - b.position[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            extent = extent.max(d);
        }
    }
    if extent > EXTENT_MAX {
        Some(format!(
            "{file}: the channels are up to {extent:.4} m apart: positions look like millimetres (they are metres)"
        ))
    } else if extent < EXTENT_MIN {
        Some(format!(
            "{file}: the channels are at most {extent:.2e} m apart (less than 1 mm): an array this small cannot see rotation; positions are in metres"
        ))
    } else {
        None
    }
}

/// The median magnitude of σ0 over a record against what a specific force can be: far beyond
/// a few g the readings are likely raw counts or mg; close to 1 in a record that sits near
/// one value, likely g. `None` when it looks like m/s².
pub fn specific_force(median: f64) -> Option<String> {
    const G: f64 = estimator_core::G0;
    if median > 5.0 * G {
        Some(format!(
            "the median |sigma0| is {median:.4} m/s^2 ({:.1} g): readings look like raw counts or mg, not m/s^2",
            median / G
        ))
    } else if (0.9..=1.1).contains(&median) {
        Some(format!(
            "the median |sigma0| is {median:.4} m/s^2: close to 1, readings may be in g, not m/s^2 (1 g = {G} m/s^2)"
        ))
    } else {
        None
    }
}

/// Per channel: how many readings were absurd and the largest magnitude among them.
#[derive(Clone, Debug, Default)]
pub struct AbsurdCount {
    /// Readings beyond the channel's bound.
    pub count: u64,
    /// The largest magnitude of them.
    pub largest: f64,
}

/// A warning per channel with absurd readings.
pub fn absurd(counts: &[AbsurdCount], names: &[String], bounds: &[f64]) -> Vec<String> {
    counts
        .iter()
        .zip(names)
        .zip(bounds)
        .filter(|((c, _), _)| c.count > 0)
        .map(|((c, name), bound)| {
            format!(
                "{name}: {} readings beyond {bound} m/s^2 (largest {:e}): treated as missing, rows flagged {}",
                c.count,
                c.largest,
                Flags::INPUT_ABSURD
            )
        })
        .collect()
}

/// The readings' own noise against the declared noise: in free fall the specific force is
/// near zero whatever the unit, so readings in g cannot be told by their magnitude, but their
/// noise is then 1/9.81 of the declared noise in m/s². Per channel, the median |second
/// difference| of successive readings, `x[k+1] − 2x[k] + x[k−1]`, estimates the white noise
/// (variance 6σ²), robust to steps and outliers; the motion only adds to it (its second
/// derivative × dt²), so a noise far *below* the declared one is evidence, while one far above
/// is not (the MIMU4444's hand-held shaking at 62.5 Hz reads 268 × its noise): readings in mg
/// or counts are named by their magnitude where the record has gravity
/// ([`specific_force`]). The median comes from a histogram of log10 |difference| in
/// 0.05-decade bins, so memory does not grow with the record.
pub struct NoiseTrack {
    last: Vec<[f64; 2]>,
    seen: Vec<u8>,
    /// Per channel: counts per bin; bin 0 holds the exact zeros (quantised steady readings).
    bins: Vec<[u32; BINS]>,
}

/// Histogram bins of log10 |difference| from [`LOG_MIN`] in steps of [`LOG_STEP`].
const BINS: usize = 400;
const LOG_MIN: f64 = -10.0;
const LOG_STEP: f64 = 0.05;
/// Median |N(0, 6σ²)| = 0.6745 · √6 · σ.
const MEDIAN_OF_SECOND_DIFFERENCE: f64 = 0.674_489_75 * 2.449_489_74;
/// Differences needed per channel before anything is said.
const NOISE_MIN_COUNT: u32 = 200;
/// The noise ratio (measured / declared) below which the readings are named as g (which read
/// 0.10 ×); a declared noise up to 4 × too large passes.
const NOISE_LOW: f64 = 0.25;

impl NoiseTrack {
    /// A track of `channels` channels.
    pub fn new(channels: usize) -> Self {
        NoiseTrack {
            last: vec![[0.0; 2]; channels],
            seen: vec![0; channels],
            bins: vec![[0; BINS]; channels],
        }
    }

    /// The next row of readings (NaN: missing, which restarts that channel's differences).
    pub fn push(&mut self, row: &[f64]) {
        for (c, &x) in row.iter().enumerate().take(self.last.len()) {
            if !x.is_finite() {
                self.seen[c] = 0;
                continue;
            }
            let [a, b] = self.last[c];
            if self.seen[c] >= 2 {
                let d = (x - 2.0 * b + a).abs();
                let bin = if d == 0.0 {
                    0
                } else {
                    (((d.log10() - LOG_MIN) / LOG_STEP).floor().max(1.0) as usize).min(BINS - 1)
                };
                self.bins[c][bin] += 1;
            }
            self.last[c] = [b, x];
            self.seen[c] = (self.seen[c] + 1).min(2);
        }
    }

    /// Channel `c`'s white noise from its readings (the unit of the readings); `None` with
    /// too few differences, or where most are exactly zero (quantisation decides, not noise).
    pub fn noise(&self, c: usize) -> Option<f64> {
        let bins = &self.bins[c];
        let n: u32 = bins.iter().sum();
        if n < NOISE_MIN_COUNT {
            return None;
        }
        let mut below = 0;
        for (i, k) in bins.iter().enumerate() {
            below += k;
            if 2 * below >= n {
                if i == 0 {
                    return None;
                }
                let log = LOG_MIN + (i as f64 + 0.5) * LOG_STEP;
                return Some(10f64.powf(log) / MEDIAN_OF_SECOND_DIFFERENCE);
            }
        }
        None
    }

    /// A warning when the channels' noise (the median over channels of measured / declared)
    /// is far below the declared noise: readings in g.
    pub fn warning(&self, declared: &[f64]) -> Option<String> {
        let mut ratios: Vec<f64> = (0..self.bins.len())
            .filter_map(|c| Some(self.noise(c)? / declared.get(c).filter(|d| **d > 0.0)?))
            .collect();
        if ratios.is_empty() {
            return None;
        }
        ratios.sort_by(f64::total_cmp);
        let r = ratios[ratios.len() / 2];
        let of = format!(
            "the readings' noise is {r:.3} x the declared noise (median of {} channels)",
            ratios.len()
        );
        (r < NOISE_LOW).then(|| {
            format!(
                "{of}: readings look like g, not m/s^2 (g reads 1/9.81 of it) — or the declared noise is too large"
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ballisto_config::arrangement_file::ArrangementFile;

    fn board(a: f64) -> LoadedArrangement {
        let mut text = String::new();
        for (i, p) in [[a, 0.0, 0.0], [0.0, a, 0.0], [0.0, 0.0, a], [-a, -a, -a]]
            .iter()
            .enumerate()
        {
            text.push_str(&format!(
                "[[sensor]]\nname = \"u{i}\"\nposition = [{}, {}, {}]\nnoise = 0.002\n",
                p[0], p[1], p[2]
            ));
        }
        ArrangementFile::parse(&text, "b")
            .unwrap()
            .load("b")
            .unwrap()
    }

    #[test]
    fn millimetres_and_counts_are_named() {
        let one = |a: f64| {
            let w = arrangement(&board(a), "a.toml");
            assert_eq!(w.len(), 2, "{w:?}");
            assert!(
                w[1].contains("no orientation for sensor \"u0\", \"u1\""),
                "{w:?}"
            );
            w[0].clone()
        };
        assert_eq!(arrangement(&board(0.1), "a.toml").len(), 1);
        assert!(one(100.0).contains("millimetres"));
        assert!(one(1e-4).contains("less than 1 mm"));
        assert!(specific_force(9.81).is_none());
        assert!(specific_force(0.0).is_none());
        assert!(specific_force(1930.0).unwrap().contains("raw counts"));
        assert!(specific_force(1.0).unwrap().contains("in g"));
        assert_eq!(reading_bounds(&[f64::INFINITY, 39.2]), vec![1e4, 78.4]);
    }

    /// White noise of σ = 0.002 m/s² on a slow sinusoid: measured within 10 %; in g it is
    /// named as g; scaled up (mg, or fast motion) and quantised steady readings say nothing.
    #[test]
    fn the_noise_of_the_readings_names_their_unit() {
        let sigma = 0.002;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut gauss = || {
            // Box–Muller on a xorshift stream.
            let mut u = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let (a, b) = (u().max(1e-300), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let rows: Vec<f64> = (0..20_000)
            .map(|k| 0.01 * (k as f64 * 0.003).sin() + sigma * gauss())
            .collect();
        let track = |scale: f64| {
            let mut t = NoiseTrack::new(1);
            for x in &rows {
                t.push(&[x * scale]);
            }
            t
        };
        let si = track(1.0);
        let measured = si.noise(0).unwrap();
        assert!((measured / sigma - 1.0).abs() < 0.1, "{measured}");
        assert!(si.warning(&[sigma]).is_none());
        let g = track(1.0 / estimator_core::G0).warning(&[sigma]).unwrap();
        assert!(g.contains("look like g"), "{g}");
        let mg = track(1000.0 / estimator_core::G0);
        assert!((mg.noise(0).unwrap() / sigma / 102.0 - 1.0).abs() < 0.1);
        assert!(mg.warning(&[sigma]).is_none());
        let mut steady = NoiseTrack::new(1);
        for _ in 0..1000 {
            steady.push(&[9.81]);
        }
        assert!(steady.noise(0).is_none() && steady.warning(&[sigma]).is_none());
    }
}
