//! Temperature coefficients from a record that spans a temperature range (issue 50,
//! `estimator_core::thermal`, docs/formats.md "Temperature"): each channel's `bias_tc` and
//! `scale_tc` about `t_ref`, its mean temperature over the record's static poses.
//!
//! At a pose of gravity `g` a channel at temperature `T` reads
//! `scale·(1 + scale_tc·ΔT)·(s·g) + bias + bias_tc·ΔT` (ΔT = T − t_ref): against what the
//! channel's geometry predicts at `t_ref` the pose's mean reading is off by
//! `bias_tc·ΔT + scale_tc·ΔT·scale·(s·g)`, linear in the two coefficients. The geometry and
//! each pose's gravity (|g| = G0) are fitted with them, by Gauss–Newton over the static poses'
//! means (positions do not enter: a pose does not see them), until the coefficients move by
//! less than a hundredth of their deviation. Fitted alone, each pose's direction took up part
//! of the channels' common change with temperature, and alternating with the geometry
//! converged by a third per pass. Poses at several
//! temperatures in several attitudes separate the two: a ramp through a schedule of poses
//! repeated (the named scenario `ground-thermal`).

use estimator_core::thermal::Thermal;
use nalgebra::{DMatrix, DVector, Vector3};

use super::fit::{self, FitSet, Geometry, Pose};
use super::poses::remeasured;
use super::scatter::Scatter;

use estimator_core::thermal::MIN_SPAN_C;

/// Gauss–Newton steps of the joint fit at most.
const MAX_STEPS: usize = 10;

/// One channel's outcome.
#[derive(Clone, Debug, PartialEq)]
pub enum ChannelThermal {
    /// Identified: the coefficients and the deviations of `bias_tc` and `scale_tc`.
    Identified {
        /// The coefficients.
        thermal: Thermal,
        /// Standard deviations of `bias_tc` (m/s² per °C) and `scale_tc` (1/°C).
        sd: (f64, f64),
    },
    /// Not determined by the record: why.
    NotDetermined(String),
}

impl ChannelThermal {
    /// The coefficients, if identified.
    pub fn thermal(&self) -> Option<Thermal> {
        match self {
            ChannelThermal::Identified { thermal, .. } => Some(*thermal),
            ChannelThermal::NotDetermined(_) => None,
        }
    }
}

/// What [`identify`] found.
#[derive(Clone, Debug)]
pub struct Found {
    /// Per channel.
    pub channels: Vec<ChannelThermal>,
    /// Each channel's bias (at `t_ref`) in the last pose fit: what [`corrected`] needs.
    pub bias: Vec<f64>,
    /// Static poses with temperatures, and the span of their temperatures (°C, over every
    /// channel).
    pub poses: (usize, f64),
    /// Gauss–Newton steps run.
    pub steps: usize,
}

impl Found {
    /// Each channel's coefficients, where identified.
    pub fn thermal(&self) -> Vec<Option<Thermal>> {
        self.channels.iter().map(ChannelThermal::thermal).collect()
    }
}

/// `rows` brought to each channel's `t_ref` with `thermal` (at the temperatures `temps`, with
/// the channel biases `bias`); a row before a channel's first temperature is kept as read.
pub fn corrected(
    rows: &[Vec<f64>],
    temps: &[Vec<f64>],
    thermal: &[Option<Thermal>],
    bias: &[f64],
) -> Vec<Vec<f64>> {
    rows.iter()
        .zip(temps)
        .map(|(row, t)| {
            row.iter()
                .enumerate()
                .map(|(c, &p)| match thermal[c] {
                    Some(th) if !t[c].is_nan() => th.at_reference(p, t[c], bias[c]),
                    _ => p,
                })
                .collect()
        })
        .collect()
}

/// Each channel's `t_ref` (its mean temperature over the poses, to 0.01 °C) where the poses
/// determine its coefficients (at least 4 with a temperature, spanning at least
/// [`MIN_SPAN_C`]); else why not.
fn reference_temperatures(at_pose: &[Vec<f64>], n: usize) -> (Vec<f64>, Vec<Option<String>>) {
    // t_ref: the channel's mean over the poses; the span decides whether it is determined.
    let mut t_ref = vec![f64::NAN; n];
    let mut undetermined: Vec<Option<String>> = vec![None; n];
    for c in 0..n {
        let ts: Vec<f64> = at_pose
            .iter()
            .map(|t| t[c])
            .filter(|t| t.is_finite())
            .collect();
        if ts.len() < 4 {
            undetermined[c] = Some(format!(
                "{} static poses with a temperature (at least 4)",
                ts.len()
            ));
            continue;
        }
        let (lo, hi) = ts
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &t| {
                (l.min(t), h.max(t))
            });
        if hi - lo < MIN_SPAN_C {
            undetermined[c] = Some(format!(
                "its static poses span {:.1} °C (at least {MIN_SPAN_C})",
                hi - lo
            ));
            continue;
        }
        t_ref[c] = ((ts.iter().sum::<f64>() / ts.len() as f64) * 100.0).round() / 100.0;
    }
    (t_ref, undetermined)
}

/// The span of the poses' temperatures (°C; 0 without any).
fn span_of(at_pose: &[Vec<f64>]) -> f64 {
    let finite: Vec<f64> = at_pose
        .iter()
        .flatten()
        .copied()
        .filter(|t| t.is_finite())
        .collect();
    let span = finite.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
        - finite.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    if finite.is_empty() {
        0.0
    } else {
        span
    }
}

/// Each pose's gravity turned by the step `x` (its turns from column `first` on, three per
/// pose), its magnitude kept at G0.
fn turn_poses(gravity: &mut [Option<Vector3<f64>>], x: &DVector<f64>, first: usize) {
    for (k, grav) in gravity.iter_mut().enumerate() {
        if let Some(g) = grav {
            let at = first + 3 * k;
            let turn = Vector3::new(x[at], x[at + 1], x[at + 2]);
            *g = (*g + turn.cross(g)).normalize() * estimator_core::G0;
        }
    }
}

/// The unknowns of each channel: bias_tc, scale_tc, then the bias, scale and tilt (3) that
/// `fit` frees.
fn unknowns_per_channel(fit: FitSet) -> usize {
    [(true, 2), (fit.bias, 1), (fit.scale, 1), (fit.axis, 3)]
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, k)| *k)
        .sum()
}

/// Each channel's result: its coefficients and their deviations, or why they are not
/// determined (too few or too close poses, or coefficients beyond any part's).
fn channel_results(
    undetermined: &[Option<String>],
    t_ref: &[f64],
    btc: &[f64],
    stc: &[f64],
    sds: &[(f64, f64)],
) -> Vec<ChannelThermal> {
    (0..undetermined.len())
        .map(|c| {
            if let Some(why) = &undetermined[c] {
                return ChannelThermal::NotDetermined(why.clone());
            }
            match Thermal::new(t_ref[c], btc[c], stc[c]) {
                Ok(thermal) => ChannelThermal::Identified { thermal, sd: sds[c] },
                Err(_) => ChannelThermal::NotDetermined(format!(
                    "bias_tc {:.3e}, scale_tc {:.3e} beyond any part's (something other than temperature moves its readings)",
                    btc[c], stc[c]
                )),
            }
        })
        .collect()
}

/// Identifies every channel's coefficients from the static `poses` of `rows` at the
/// temperatures `temps` (per row and channel, °C, NaN before the first), starting from the
/// `nominal` geometry; `fit` says which of bias, scale and axis the poses may change with
/// them (positions: a pose does not see them). Errors: a record without a usable pose.
pub fn identify(
    nominal: &[Geometry],
    rows: &[Vec<f64>],
    temps: &[Vec<f64>],
    poses: &[Pose],
    fit: FitSet,
) -> Result<Found, String> {
    let n = nominal.len();
    // Each channel's mean temperature over each pose (NaN where the record has none).
    let at_pose: Vec<Vec<f64>> = remeasured(poses, temps)
        .into_iter()
        .map(|p| p.mean)
        .collect();
    let (t_ref, mut undetermined) = reference_temperatures(&at_pose, n);
    let raw = remeasured(poses, rows);
    let mut geo: Vec<Geometry> = nominal.to_vec();
    // Each pose's gravity (|g| = G0: free, its magnitude would take up every channel's common
    // change of scale with temperature), `None` where the channels do not give one.
    let mut gravity: Vec<Option<Vector3<f64>>> =
        fit::pose_gravity(&geo, &raw, &Scatter::white(&geo))
            .into_iter()
            .map(|g| (g.norm() > 0.0).then_some(g))
            .collect();
    if gravity.iter().all(Option::is_none) {
        return Err("no static pose to identify temperature coefficients from".into());
    }
    // Per pose, after every channel's unknowns: a turn of its gravity (3).
    let per_channel = unknowns_per_channel(fit);
    let mut btc = vec![0.0; n];
    let mut stc = vec![0.0; n];
    let mut sds = vec![(0.0, 0.0); n];
    let mut steps = 0;
    for _ in 0..MAX_STEPS {
        steps += 1;
        let free: Vec<usize> = (0..n).filter(|&c| undetermined[c].is_none()).collect();
        let cols = per_channel * n + 3 * poses.len();
        let mut ata = DMatrix::<f64>::zeros(cols, cols);
        let mut atb = DVector::<f64>::zeros(cols);
        let mut obs = Vec::new();
        for (k, grav) in gravity.iter().enumerate() {
            let Some(grav) = grav else { continue };
            let weight = poses[k].samples.len() as f64;
            for c in 0..n {
                let (m, t) = (raw[k].mean[c], at_pose[k][c]);
                let thermal_free = free.contains(&c);
                let dt = if thermal_free { t - t_ref[c] } else { 0.0 };
                if !m.is_finite() || (thermal_free && !t.is_finite()) {
                    continue;
                }
                let g = &geo[c];
                let warm = 1.0 + stc[c] * dt;
                let sg = g.axis.dot(grav);
                let r = m - (g.scale * warm * sg + g.bias + btc[c] * dt);
                let w = weight / (g.noise * g.noise).max(1e-30);
                let base = per_channel * c;
                let mut row: Vec<(usize, f64)> = Vec::with_capacity(per_channel + 3);
                if thermal_free {
                    row.push((base, dt));
                    row.push((base + 1, dt * g.scale * sg));
                }
                let mut at = base + 2;
                if fit.bias {
                    row.push((at, 1.0));
                    at += 1;
                }
                if fit.scale {
                    row.push((at, warm * sg));
                    at += 1;
                }
                if fit.axis {
                    let d = g.axis.cross(grav) * (g.scale * warm);
                    row.extend((0..3).map(|i| (at + i, d[i])));
                }
                let turn = grav.cross(&g.axis) * (g.scale * warm);
                let at = per_channel * n + 3 * k;
                row.extend((0..3).map(|i| (at + i, turn[i])));
                for &(a, va) in &row {
                    atb[a] += w * va * r;
                    for &(b, vb) in &row {
                        ata[(a, b)] += w * va * vb;
                    }
                }
                obs.push((row, r, w));
            }
        }
        // Turns about an axis or about gravity change nothing, nor does one common turn of
        // every axis and every pose: a small ridge holds them (and the coefficients of a
        // channel left out).
        let ridge = 1e-9 * (0..cols).map(|i| ata[(i, i)]).fold(0.0, f64::max);
        for i in 0..cols {
            ata[(i, i)] += ridge;
        }
        let Some(inv) = ata.try_inverse() else {
            for &c in &free {
                undetermined[c] = Some("its poses do not separate bias and scale change".into());
            }
            break;
        };
        let x = &inv * &atb;
        let dof = obs.len().saturating_sub(cols).max(1) as f64;
        let s2 = obs
            .iter()
            .map(|(row, r, w)| w * (r - row.iter().map(|&(a, v)| v * x[a]).sum::<f64>()).powi(2))
            .sum::<f64>()
            / dof;
        let mut moved = 0.0f64;
        for c in 0..n {
            let base = per_channel * c;
            let mut at = base + 2;
            let g = &mut geo[c];
            if fit.bias {
                g.bias += x[at];
                at += 1;
            }
            if fit.scale {
                g.scale += x[at];
                at += 1;
            }
            if fit.axis {
                let turn = Vector3::new(x[at], x[at + 1], x[at + 2]);
                g.axis = (g.axis + turn.cross(&g.axis)).normalize();
            }
            if !free.contains(&c) {
                continue;
            }
            btc[c] += x[base];
            stc[c] += x[base + 1];
            let sd = (
                (s2 * inv[(base, base)]).sqrt(),
                (s2 * inv[(base + 1, base + 1)]).sqrt(),
            );
            moved = moved
                .max(x[base].abs() / sd.0.max(1e-12))
                .max(x[base + 1].abs() / sd.1.max(1e-15));
            sds[c] = sd;
        }
        turn_poses(&mut gravity, &x, per_channel * n);
        if moved < 0.01 {
            break;
        }
    }
    let channels = channel_results(&undetermined, &t_ref, &btc, &stc, &sds);
    Ok(Found {
        channels,
        bias: geo.iter().map(|g| g.bias).collect(),
        poses: (poses.len(), span_of(&at_pose)),
        steps,
    })
}
