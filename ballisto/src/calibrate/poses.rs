//! Static poses found in a record: runs where every channel stays within its noise.
//!
//! A sample is static when, over the window of `window` samples centred on it, every
//! channel's standard deviation is at most [`STATIC_NOISE_FACTOR`] × its noise (and, with a
//! reference, |Ω| is small). Runs of static samples make a pose once a window is dropped at
//! both ends (a turn starts and ends slowly) if `min_len` samples remain.

use super::fit::Pose;

/// A window's standard deviation may reach this many times the channel's noise (the spread
/// of a sample standard deviation over 50 samples is ≈ 10 %; 2 leaves room for slow
/// vibration and quantisation but not for a turn: 90° in 2 s moves 1 g).
pub const STATIC_NOISE_FACTOR: f64 = 2.0;

/// Finds the static poses; `noise` per channel (m/s²), `rate_ok[k]` false where a reference
/// says the body turns.
pub fn find_poses(
    rows: &[Vec<f64>],
    noise: &[f64],
    rate_ok: Option<&[bool]>,
    window: usize,
    min_len: usize,
) -> Vec<Pose> {
    let n = rows.len();
    let half = window / 2;
    let channels = noise.len();
    let mut is_static = vec![false; n];
    if n >= window && window >= 2 {
        // Running sums over the window.
        let mut sum = vec![0.0; channels];
        let mut sq = vec![0.0; channels];
        let mut bad = 0usize;
        let add = |row: &[f64], sign: f64, sum: &mut [f64], sq: &mut [f64]| {
            for (c, v) in row.iter().enumerate() {
                if v.is_finite() {
                    sum[c] += sign * v;
                    sq[c] += sign * v * v;
                }
            }
        };
        let finite = |row: &[f64]| row.iter().all(|v| v.is_finite());
        for row in rows.iter().take(window) {
            add(row, 1.0, &mut sum, &mut sq);
            bad += usize::from(!finite(row));
        }
        for start in 0..=n - window {
            if start > 0 {
                add(&rows[start - 1], -1.0, &mut sum, &mut sq);
                bad -= usize::from(!finite(&rows[start - 1]));
                add(&rows[start + window - 1], 1.0, &mut sum, &mut sq);
                bad += usize::from(!finite(&rows[start + window - 1]));
            }
            let w = window as f64;
            let quiet = bad == 0
                && (0..channels).all(|c| {
                    let var = (sq[c] - sum[c] * sum[c] / w) / (w - 1.0);
                    var.max(0.0).sqrt() <= STATIC_NOISE_FACTOR * noise[c]
                });
            let centre = start + half;
            let turning = rate_ok.is_some_and(|ok| !ok[centre]);
            is_static[centre] = quiet && !turning;
        }
    }
    let mut poses = Vec::new();
    let mut k = 0;
    while k < n {
        if !is_static[k] {
            k += 1;
            continue;
        }
        let start = k;
        while k < n && is_static[k] {
            k += 1;
        }
        // Drop a whole window at both ends: a turn starts and ends slowly, and its first
        // milliradians stay within the noise of one window.
        let (a, b) = (start + window, k.saturating_sub(window));
        if b > a && b - a >= min_len {
            poses.push(Pose {
                samples: a..b,
                mean: column_means(&rows[a..b], channels),
            });
        }
    }
    poses
}

/// The mean of each of the `channels` columns of `rows`.
fn column_means(rows: &[Vec<f64>], channels: usize) -> Vec<f64> {
    (0..channels)
        .map(|c| rows.iter().map(|r| r[c]).sum::<f64>() / rows.len() as f64)
        .collect()
}

/// The same poses with their means taken over `rows` instead (the record corrected, or any
/// per-sample quantity of the record's channels, e.g. their temperatures).
pub fn remeasured(poses: &[Pose], rows: &[Vec<f64>]) -> Vec<Pose> {
    poses
        .iter()
        .map(|p| Pose {
            samples: p.samples.clone(),
            mean: column_means(&rows[p.samples.clone()], p.mean.len()),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_turn_between_two_rests_gives_two_poses() {
        // 2 channels at 100 Hz: 3 s at rest, a 2 s turn, 3 s at rest; noise 0.01.
        let mut rows = Vec::new();
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        let mut noise = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            ((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.01 * 12f64.sqrt()
        };
        for k in 0..800 {
            let t = k as f64 / 100.0;
            let angle = ((t - 3.0) / 2.0).clamp(0.0, 1.0) * std::f64::consts::FRAC_PI_2;
            rows.push(vec![
                9.8 * angle.cos() + noise(),
                9.8 * angle.sin() + noise(),
            ]);
        }
        let poses = find_poses(&rows, &[0.01, 0.01], None, 50, 100);
        assert_eq!(
            poses.len(),
            2,
            "{:?}",
            poses.iter().map(|p| p.samples.clone()).collect::<Vec<_>>()
        );
        assert!(poses[0].samples.end <= 300 && poses[1].samples.start >= 500);
        assert!((poses[0].mean[0] - 9.8).abs() < 0.01 && poses[1].mean[1] > 9.79);
    }
}
