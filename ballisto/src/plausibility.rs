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

/// The arrangement's extent (largest distance between two channels' positions) outside
/// [`EXTENT_MIN`]–[`EXTENT_MAX`]: a warning naming the likely unit.
pub fn arrangement(loaded: &LoadedArrangement, file: &str) -> Option<String> {
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
        assert!(arrangement(&board(0.1), "a.toml").is_none());
        assert!(arrangement(&board(100.0), "a.toml")
            .unwrap()
            .contains("millimetres"));
        assert!(arrangement(&board(1e-4), "a.toml")
            .unwrap()
            .contains("less than 1 mm"));
        assert!(specific_force(9.81).is_none());
        assert!(specific_force(0.0).is_none());
        assert!(specific_force(1930.0).unwrap().contains("raw counts"));
        assert!(specific_force(1.0).unwrap().contains("in g"));
        assert_eq!(reading_bounds(&[f64::INFINITY, 39.2]), vec![1e4, 78.4]);
    }
}
