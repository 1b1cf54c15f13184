//! The kinematic tie of self-calibration: the record's Ω′ must be the rate of change of its Ω.
//!
//! Without a reference, the identification ([`super::fit`]) estimates σ0, Ω′ and Ω freely at
//! every motion sample. A rotation `d` of all axes relative to the lever arms (axes tilted by
//! `½ d × s`, positions moved by `−½ d × R`: [`super::frame`]'s generator) is then a gauge to
//! first order: it moves each sample's Ω′ by `K(Ω) d`, `K(Ω) = −½ (|Ω|² I + ΩΩᵀ)`
//! (estimator-core's `frame_uncertainty`), and the free Ω′ absorbs it. The joint fit leaves it
//! at about its mounting tolerance (2.1 mrad on `ground-calibration`), which puts `|Ω|² d` into
//! every Ω′ the calibrated file estimates (1.4× the ideal parts' error).
//!
//! Time ties them: within a segment of consecutive samples starting at `t₀`,
//! `Ω(t) − ∫_{t₀}^{t} Ω′ = c − (∫_{t₀}^{t} K(Ω)) d + noise`, with `c` the segment's own
//! constant — a linear least-squares problem for `d` over thousands of samples, each weighted
//! by its Ω's variance (at low rates Ω is poorly determined). Segments are short
//! ([`SEGMENT_S`]) so that the integrated noise of Ω′ stays small against that of Ω and the
//! residuals are close to white; the deviation of `d` is taken from their scatter (which also
//! holds whatever else the geometry still gets wrong), not from the declared noise. A segment
//! with a sample far outside that scatter (Ω's sign flipped, a sample the estimator did not
//! decide well) is left out and counted.

use nalgebra::{Matrix3, Vector3};

use super::fit::{Field, Geometry};

/// Length of a segment, s. Within it the integral of Ω′'s noise (a random walk) must stay
/// small against Ω's per-sample noise: on `ground-calibration` (100 Hz) it reaches
/// `√200 · 0.01 s · 9e-3 rad/s² ≈ 1.3e-3 rad/s` against Ω's 7.6e-3.
pub const SEGMENT_S: f64 = 2.0;
/// Fewest samples in a segment.
const MIN_SEGMENT_SAMPLES: usize = 10;
/// A segment with a sample whose weighted residual exceeds this many robust standard
/// deviations is left out.
const OUTLIER: f64 = 5.0;
/// Fewest segments for an estimate.
const MIN_SEGMENTS: usize = 4;

/// What the kinematic tie found.
#[derive(Clone, Copy, Debug)]
pub struct RelativeRotation {
    /// The axes' rotation relative to the lever arms in the geometry the fields were
    /// estimated with (rad): the geometry's error along that freedom.
    pub d: Vector3<f64>,
    /// Its standard deviations (rad).
    pub sd: Vector3<f64>,
    /// Segments used.
    pub segments: usize,
    /// Segments left out as outliers.
    pub rejected: usize,
    /// The residuals' variance against what Ω's own noise explains (≈ 1 where Ω′ integrates
    /// to the change of Ω; [`CONSISTENT`]).
    pub misfit: f64,
    /// Whether the passes of the tie diverged (a pass found more rotation than the one
    /// before removed), and it was undone.
    pub diverged: bool,
}

/// The tie holds when its residuals are within twice (in sd) what Ω's noise explains: on
/// `ground-calibration` they are 0.72–0.81 of it; on the real 62.5 Hz board
/// (`mimu4444_exp6_raw`, Ω′ RMS ≈ 700 rad/s²) 1e5 of it — the trapezoid rule, and the
/// per-sample fields, cannot follow that motion between samples, so Ω′ does not integrate
/// to the change of Ω there and the tie would rotate the axes by tens of mrad for nothing.
pub const CONSISTENT: f64 = 4.0;

impl RelativeRotation {
    /// Whether the record's kinematics are consistent enough for the tie to be applied.
    pub fn holds(&self) -> bool {
        self.misfit <= CONSISTENT && !self.diverged
    }

    /// One line for the calibrated file's header and the report.
    pub fn describe(&self) -> String {
        if self.diverged {
            return format!(
                "kinematic tie not applied: its passes did not converge (after the first removed its estimate, the next found [{:.4}, {:.4}, {:.4}] mrad, more: this record's motion does not determine it well enough), so the axes' rotation against the lever arms stays as the joint fit left it",
                -self.d.x * 1e3,
                -self.d.y * 1e3,
                -self.d.z * 1e3
            );
        }
        if !self.holds() {
            return format!(
                "kinematic tie not applied: Ω′ does not integrate to the change of Ω on this record (residuals {:.3e} times the variance Ω's noise explains, more than {CONSISTENT}: the sampling is too slow for the motion, or the model does not fit it), so the axes' rotation against the lever arms stays as the joint fit left it",
                self.misfit
            );
        }
        format!(
            "axes turned against the lever arms by [{:.4}, {:.4}, {:.4}] mrad from Ω′ against the change of Ω (kinematic tie, {} segments, {} left out, residuals {:.2} of their noise; deviation left {:.1e} rad)",
            -self.d.x * 1e3,
            -self.d.y * 1e3,
            -self.d.z * 1e3,
            self.segments,
            self.rejected,
            self.misfit,
            self.sd.max()
        )
    }
}

/// `K(Ω) = −½ (|Ω|² I + ΩΩᵀ)`: how the relative rotation `d` moves Ω′.
fn k_of(w: &Vector3<f64>) -> Matrix3<f64> {
    -(Matrix3::identity() * w.norm_squared() + w * w.transpose()) * 0.5
}

/// One sample of a segment: `z = Ω − ∫Ω′`, `C = ∫K(Ω)` (from the segment's start) and the
/// weight `1 / var(Ω)` (per component).
struct Point {
    z: Vector3<f64>,
    c: Matrix3<f64>,
    w: f64,
}

/// The segments over runs of consecutive motion samples with a field (`motion` indexes
/// `times`; `fields` is per motion sample), each centred on its weighted mean (which removes
/// its constant).
fn segments(times: &[f64], motion: &[usize], fields: &[Option<Field>]) -> Vec<Vec<Point>> {
    if times.len() < 2 {
        return Vec::new();
    }
    let rate = (times.len() - 1) as f64 / (times[times.len() - 1] - times[0]);
    let len = ((SEGMENT_S * rate).round() as usize).max(MIN_SEGMENT_SAMPLES);
    let usable = |j: usize| fields[j].is_some_and(|f| f.omega_var > 0.0 && f.omega_var.is_finite());
    let mut out = Vec::new();
    let mut j = 0;
    while j < motion.len() {
        if !usable(j) {
            j += 1;
            continue;
        }
        // A segment: consecutive usable samples, at most `len`.
        let mut seg = Vec::new();
        let (mut z_int, mut c_int) = (Vector3::zeros(), Matrix3::zeros());
        let mut prev: Option<(usize, Field)> = None;
        while j < motion.len() && seg.len() < len && usable(j) {
            let f = fields[j].unwrap_or_default();
            if let Some((pj, pf)) = prev {
                let dt = times[motion[j]] - times[motion[pj]];
                if motion[j] != motion[pj] + 1
                    || dt.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater)
                {
                    break;
                }
                // Trapezoid rule (its error at 100 Hz moves d by ~1e-8 rad).
                z_int += (pf.domega + f.domega) * (0.5 * dt);
                c_int += (k_of(&pf.omega) + k_of(&f.omega)) * (0.5 * dt);
            }
            seg.push(Point {
                z: f.omega - z_int,
                c: c_int,
                w: 3.0 / f.omega_var,
            });
            prev = Some((j, f));
            j += 1;
        }
        if seg.len() >= MIN_SEGMENT_SAMPLES {
            let sw: f64 = seg.iter().map(|p| p.w).sum();
            let zm = seg.iter().fold(Vector3::zeros(), |a, p| a + p.z * p.w) / sw;
            let cm = seg.iter().fold(Matrix3::zeros(), |a, p| a + p.c * p.w) / sw;
            for p in seg.iter_mut() {
                p.z -= zm;
                p.c -= cm;
            }
            out.push(seg);
        }
    }
    out
}

/// Weighted least squares for `d` over the segments in use (`z = −C d`): `d`, the inverse
/// normal matrix, and per segment the largest weighted residual and the weighted RSS.
type Solution = (Vector3<f64>, Matrix3<f64>, Vec<(f64, f64)>);

fn solve(segs: &[Vec<Point>], use_it: &[bool]) -> Option<Solution> {
    let mut n = Matrix3::zeros();
    let mut r = Vector3::zeros();
    for seg in segs.iter().zip(use_it).filter(|(_, u)| **u).map(|(s, _)| s) {
        for p in seg {
            n += p.c.transpose() * p.c * p.w;
            r -= p.c.transpose() * p.z * p.w;
        }
    }
    let inv = n.try_inverse()?;
    let d = inv * r;
    let res = segs
        .iter()
        .map(|seg| {
            seg.iter().fold((0.0f64, 0.0), |(big, rss), p| {
                let e2 = (p.z + p.c * d).norm_squared() * p.w;
                (big.max(e2.sqrt()), rss + e2)
            })
        })
        .collect();
    Some((d, inv, res))
}

/// The axes' rotation relative to the lever arms that the record's kinematics show in the
/// fields (σ0, Ω′, Ω per motion sample, estimated with the geometry). `None` when the record
/// has too few segments in motion, or its motion does not determine `d` (at rest `K(Ω)`
/// vanishes).
pub fn relative_rotation(
    times: &[f64],
    motion: &[usize],
    fields: &[Option<Field>],
) -> Option<RelativeRotation> {
    let segs = segments(times, motion, fields);
    if segs.len() < MIN_SEGMENTS {
        return None;
    }
    let mut use_it = vec![true; segs.len()];
    let (_, _, res) = solve(&segs, &use_it)?;
    // Robust scale of a sample's weighted residual: the median over segments of their RSS
    // per sample (a flipped segment moves the median by one place).
    let sigma = {
        let mut per: Vec<f64> = segs
            .iter()
            .zip(res.iter())
            .map(|(s, r)| r.1 / s.len() as f64)
            .collect();
        per.sort_by(f64::total_cmp);
        per[per.len() / 2].sqrt()
    };
    for (u, r) in use_it.iter_mut().zip(res.iter()) {
        *u = r.0 <= OUTLIER * sigma;
    }
    let used = use_it.iter().filter(|u| **u).count();
    if used < MIN_SEGMENTS {
        return None;
    }
    let (d, inv, res) = solve(&segs, &use_it)?;
    let (rss, samples) = segs
        .iter()
        .zip(res.iter())
        .zip(use_it.iter())
        .filter(|(_, u)| **u)
        .fold((0.0, 0usize), |(a, n), ((s, r), _)| (a + r.1, n + s.len()));
    // Each segment's constant took 3 degrees of freedom, d three more.
    let dof = 3 * (samples - used) - 3;
    let s2 = rss / dof as f64;
    let sd = Vector3::from_fn(|i, _| (s2 * inv[(i, i)]).sqrt());
    if !(d.iter().all(|v| v.is_finite()) && sd.iter().all(|v| v.is_finite())) {
        return None;
    }
    Some(RelativeRotation {
        d,
        sd,
        segments: used,
        rejected: segs.len() - used,
        misfit: s2,
        diverged: false,
    })
}

/// Turns every channel's axis against its lever arm by `−d` (the inverse of the relative
/// rotation `d`: axes tilted by `−½ d × s`, positions moved by `½ d × R`).
pub fn remove(geo: &mut [Geometry], d: &Vector3<f64>) {
    for g in geo.iter_mut() {
        g.axis = (g.axis - d.cross(&g.axis) * 0.5).normalize();
        g.position += d.cross(&g.position) * 0.5;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fields of a body spinning up about a turning axis, as a geometry off by `d` sees them
    /// to first order: Ω′ moved by `K(Ω) d`.
    fn fields_with(
        d: &Vector3<f64>,
        noise: f64,
        seed: u64,
    ) -> (Vec<f64>, Vec<usize>, Vec<Option<Field>>) {
        let rate = 100.0;
        let n = 3000;
        let times: Vec<f64> = (0..n).map(|k| k as f64 / rate).collect();
        let mut state = 0x2545_f491_4f6c_dd1du64 ^ seed.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let mut normal = || {
            // Irwin–Hall sum of 12 uniforms: unit variance, zero mean.
            let mut s = -6.0;
            for _ in 0..12 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                s += (state >> 11) as f64 / (1u64 << 53) as f64;
            }
            s
        };
        let omega = |t: f64| {
            let a = Vector3::new((0.3 * t).cos(), (0.3 * t).sin(), 0.5).normalize();
            a * (4.0 * (1.0 - (-t / 3.0).exp()))
        };
        let fields = times
            .iter()
            .map(|&t| {
                let h = 1e-5;
                let w = omega(t);
                let dw = (omega(t + h) - omega(t - h)) / (2.0 * h);
                Some(Field {
                    sigma0: Vector3::zeros(),
                    domega: dw + k_of(&w) * d + Vector3::from_fn(|_, _| noise * normal()),
                    omega: w + Vector3::from_fn(|_, _| noise * normal()),
                    omega_var: 3.0 * (noise * noise).max(1e-12),
                })
            })
            .collect();
        let motion = (0..n).collect();
        (times, motion, fields)
    }

    #[test]
    fn the_relative_rotation_is_recovered_from_the_kinematics() {
        let d = Vector3::new(2e-3, -1e-3, 1.5e-3);
        let (times, motion, fields) = fields_with(&d, 0.0, 0);
        let r = relative_rotation(&times, &motion, &fields).expect("estimate");
        // The trapezoid rule's error at 100 Hz (h²/12 times Ω′'s change over a segment)
        // leaves 1.1e-8 rad (4e-6 relative): nothing against a deviation of 1e-4 rad.
        assert!((r.d - d).norm() <= 1e-5 * d.norm(), "{:?}", r.d);
    }

    #[test]
    fn with_noise_its_deviation_is_honest_and_outliers_are_left_out() {
        let d = Vector3::new(2e-3, -1e-3, 1.5e-3);
        let mut z2 = 0.0;
        let mut count = 0;
        for seed in 0..20u64 {
            let (times, motion, mut fields) = fields_with(&d, 0.01, seed);
            // A sign flip of Ω for 30 samples (a mirror branch) in every record, at a
            // different place.
            let at = 300 + 97 * seed as usize;
            for f in fields[at..at + 30].iter_mut().flatten() {
                f.omega = -f.omega;
            }
            let r = relative_rotation(&times, &motion, &fields).expect("estimate");
            // The flip lies in one or two segments of 200 samples: those, and no others.
            assert!(
                (1..=2).contains(&r.rejected),
                "the flipped segment is left out: {r:?} at {at}"
            );
            for i in 0..3 {
                z2 += ((r.d[i] - d[i]) / r.sd[i]).powi(2);
                count += 1;
            }
        }
        let rms = (z2 / count as f64).sqrt();
        assert!((0.5..=1.5).contains(&rms), "RMS(error/sd) {rms}");
    }

    #[test]
    fn a_record_whose_rate_does_not_integrate_its_acceleration_is_not_tied() {
        let d = Vector3::new(2e-3, -1e-3, 1.5e-3);
        let (times, motion, fields) = fields_with(&d, 0.01, 3);
        let good = relative_rotation(&times, &motion, &fields).expect("estimate");
        assert!(good.holds(), "{good:?}");
        // Ω′ 20 % short of the rate's change (a model the record does not follow): its
        // integral no longer matches the change of Ω, far beyond Ω's noise.
        let mut short = fields.clone();
        for f in short.iter_mut().flatten() {
            f.domega *= 0.8;
        }
        let bad = relative_rotation(&times, &motion, &short).expect("estimate");
        assert!(!bad.holds(), "{bad:?}");
        assert!(bad.describe().contains("not applied"));
    }

    #[test]
    fn removing_it_turns_the_axes_against_the_lever_arms() {
        let mut geo = vec![Geometry {
            position: Vector3::new(0.1, 0.0, 0.0),
            axis: Vector3::y(),
            scale: 1.0,
            bias: 0.0,
            noise: 1e-3,
        }];
        let d = Vector3::new(0.0, 0.0, 2e-3);
        remove(&mut geo, &d);
        // The axis turned by −1e-3 about z, the position by +1e-3: 2e-3 between them.
        assert!((geo[0].axis.x - 1e-3).abs() < 1e-9, "{:?}", geo[0].axis);
        assert!(
            (geo[0].position.y - 1e-4).abs() < 1e-9,
            "{:?}",
            geo[0].position
        );
    }
}
