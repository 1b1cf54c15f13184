//! Identification of every channel's geometry (paper §6): position `R` (3), axis tilt (2),
//! scale and bias, from a record of static poses and motion.
//!
//! A channel reads `h = scale · (s·f(R)) + bias` with `f(R) = σ0 + ({Ω′} + {Ω}² + Γ) R`
//! (paper eq. 4): estimator-core's channel model, parameters and tolerances
//! ([`estimator_core::identify::model`]), the same as the identification in flight's; the frame's
//! uncertainty is estimator-core's too ([`super::frame`]). Each alternation:
//! - **the field** at the present geometry: in a static pose `σ0 = g` (|g| = [`G0`], its
//!   direction by least squares, Ω = Ω′ = 0); in motion Ω from the reference rate sensor, or
//!   (self-calibration, or a reference of inexact scale as one more reading) from the estimator
//!   or the reference at first and then with σ0 and Ω′ by Gauss–Newton per sample; σ0 and Ω′
//!   by the linear least squares of the paper's Ω-known case;
//! - **the geometry**: one Gauss–Newton step on the joint normal equations of all channels'
//!   7 parameters with the field's unknowns projected out sample by sample (variable
//!   projection: `JᵀWJ − JᵀWH (HᵀWH)⁺ HᵀWJ`), so that the step and its covariance account
//!   for what the field can absorb; within a trust region of [`MAX_STEP`] tolerances.
//!
//! Observability is decided from the eigen-decomposition of the tolerance-scaled joint
//! normal matrix ([`Tolerance`]): parameters the record does not determine to half their
//! tolerance are set aside (held at nominal) one by one and named; directions the data do not
//! see at all (gauges: the common translation of all positions, without a reference the
//! common rotation, and without a reference or with one of inexact scale ([`RatePrior`]) the
//! size) are held by convention and named. The identified subspace is
//! decided on the third alternation of a stage and then kept, so the iteration converges.
//!
//! `ballisto calibrate -v` logs every alternation's largest step and the smallest
//! eigenvalues of the scaled normal matrix (`log::debug!`: for diagnosing a record that does
//! not converge).

use super::kinematics::RelativeRotation;
use super::scatter::Scatter;
use nalgebra::{DMatrix, DVector, Matrix3, SVector, Vector3};

pub use estimator_core::identify::Tolerance;
use estimator_core::identify::{too_few_determined, ChannelFit, Param, PARAMS};
use estimator_core::Channel;

mod fields;
mod finish;
mod residuals;
mod step;
#[cfg(test)]
mod tests;

pub use fields::array_fields;
pub(super) use fields::pose_gravity;
use fields::*;
use finish::*;
pub use residuals::{residuals, Residuals};
use step::*;

/// Per-channel parameters, in the order of the normal equations: estimator-core's, one for
/// every identification ([`Param`]).
pub const PARAMETERS: [&str; PARAMS] = {
    let mut names = [""; PARAMS];
    let mut p = 0;
    while p < PARAMS {
        names[p] = Param::ALL[p].name();
        p += 1;
    }
    names
};

/// What a calibration may change (`--fit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FitSet {
    /// Bias.
    pub bias: bool,
    /// Scale.
    pub scale: bool,
    /// Axis direction.
    pub axis: bool,
    /// Position.
    pub position: bool,
}

impl FitSet {
    /// Everything.
    pub const ALL: FitSet = FitSet {
        bias: true,
        scale: true,
        axis: true,
        position: true,
    };

    fn mask(&self) -> [bool; 7] {
        [
            self.scale,
            self.axis,
            self.axis,
            self.position,
            self.position,
            self.position,
            self.bias,
        ]
    }
}

/// One channel's geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Seismic point (m, body).
    pub position: Vector3<f64>,
    /// Unit sensitive axis (body).
    pub axis: Vector3<f64>,
    /// Scale factor.
    pub scale: f64,
    /// Bias (m/s²).
    pub bias: f64,
    /// White noise per sample (m/s²); inside [`identify`], once reweighted, a motion sample's
    /// measured scatter (its weight: [`Scatter`]).
    pub noise: f64,
}

impl Geometry {
    /// The channel as estimator-core describes it.
    pub fn channel(&self) -> Channel {
        Channel {
            position: self.position.into(),
            axis: self.axis.into(),
            noise: self.noise,
            bias: self.bias,
            scale: self.scale,
        }
    }

    /// What the channel reads in the field `f` at its position.
    pub fn reading(&self, f: &Vector3<f64>) -> f64 {
        self.scale * self.axis.dot(f) + self.bias
    }
}

/// A static pose found in the record: its samples and the mean reading of every channel.
#[derive(Clone, Debug)]
pub struct Pose {
    /// First and one-past-last sample.
    pub samples: std::ops::Range<usize>,
    /// Mean reading per channel.
    pub mean: Vec<f64>,
}

/// The field at one motion sample: σ0, Ω′ and Ω.
#[derive(Clone, Copy, Debug, Default)]
pub struct Field {
    /// Specific force at the origin (m/s²).
    pub sigma0: Vector3<f64>,
    /// Angular acceleration (rad/s²).
    pub domega: Vector3<f64>,
    /// Angular rate (rad/s).
    pub omega: Vector3<f64>,
    /// Variance of Ω (sum of its components, rad²/s², with σ0 and Ω′ unknown; 0 when Ω was
    /// held, not estimated).
    pub omega_var: f64,
}

impl Field {
    /// `{Ω′} + {Ω}² + Γ` (so that `f(R) = σ0 + M R`).
    pub(super) fn m(&self, gamma: &Matrix3<f64>) -> Matrix3<f64> {
        let w = self.omega;
        let ww = w * w.transpose() - Matrix3::identity() * w.norm_squared();
        self.domega.cross_matrix() + ww + gamma
    }

    /// What channel `g` reads in this field, with `m` = [`Self::m`]: `g.reading(σ0 + M R)`.
    pub(super) fn reading(&self, g: &Geometry, m: &Matrix3<f64>) -> f64 {
        g.reading(&(self.sigma0 + m * g.position))
    }
}

/// Ω per sample (`None` where it is not known).
pub type Rates = Vec<Option<Vector3<f64>>>;

/// One channel's row at one instant of the data: channel, weight, Jacobian (7), residual,
/// and its row of the field's columns.
struct DataRow {
    channel: usize,
    weight: f64,
    jacobian: SVector<f64, 7>,
    residual: f64,
    field: Vec<f64>,
}

/// Where the motion's angular rate comes from.
pub enum RateSource<'a> {
    /// A reference rate sensor, already at the sample instants (rad/s, body).
    Reference(&'a [Vector3<f64>]),
    /// The estimator on the current geometry (self-calibration); the closure runs it over
    /// the record and returns Ω per sample (`None` where the estimator flags the sample as
    /// not decided: fallback, ill-conditioned, branch ambiguous, input invalid).
    Estimator(&'a dyn Fn(&[Geometry]) -> Result<Rates, String>),
}

/// The record the fit reads.
pub struct Record<'a> {
    /// Readings, one row per sample, channels in arrangement order.
    pub rows: &'a [Vec<f64>],
    /// The time of every row (s).
    pub times: &'a [f64],
    /// Static poses (see [`super::poses`]).
    pub poses: &'a [Pose],
    /// Samples in motion (not in a pose) used for the field and the positions.
    pub motion: &'a [usize],
    /// Known gravity gradient Γ (0 on the ground).
    pub gamma: Matrix3<f64>,
    /// Told the number of every alternation as it starts (a progress bar; `&|_| {}` for
    /// none).
    pub progress: &'a dyn Fn(usize),
    /// A reference rate whose scale is not known exactly, taken as a reading of Ω
    /// ([`RatePrior`]); `None`: Ω is the rate source's (a reference held exact, or
    /// self-calibrating, free).
    pub rate_prior: Option<RatePrior<'a>>,
}

/// A reference rate sensor whose scale factors are known only to a tolerance (an
/// uncalibrated MEMS gyro: a few per cent). Held as Ω itself, its scale errors bend the
/// geometry to them: on the MIMU4444 (nominal gyro scale factors) the gyro-aided extents along
/// x and y moved by up to 1 mm between recordings of the same board (the 28 IMU distances
/// 0.80 mm RMS apart), where the array alone puts its shape to 0.1 mm. Taken instead as one
/// more reading of Ω per motion sample, `c·Ω_ref` with deviation
/// `√(floor² + (scale_sd · c·|Ω_ref|)²)` per axis, Ω is estimated with σ0 and Ω′ as in
/// self-calibration (eq. 4 per sample, nine unknowns). The common factor `c` and the array's
/// size are one freedom (the readings do not change when the positions grow by `k` and Ω
/// shrinks by `√k`): the fit runs at `c = 1`, then the size is held at the drawing's, as
/// without a reference, and `c` follows. What the reference brings is the rest: Ω's sign, its
/// frame, and Ω where the centripetal readings are within the noise.
#[derive(Clone, Copy, Debug)]
pub struct RatePrior<'a> {
    /// The reference's Ω at every row of the record (rad/s, body).
    pub omega: &'a [Vector3<f64>],
    /// Relative deviation of the reference's scale per axis, about its common factor.
    pub scale_sd: f64,
    /// Deviation of the reference's Ω at rest (rad/s).
    pub floor: f64,
    /// The reference's common scale factor `c` (1 in the fit; after it, what holding the size
    /// at the drawing's makes it).
    pub scale: f64,
}

impl RatePrior<'_> {
    /// The reference's reading of Ω at row `k`, `c·Ω_ref`, and its weight (1/variance per
    /// axis).
    fn at(&self, k: usize) -> (Vector3<f64>, f64) {
        let w = self.omega[k] * self.scale;
        let var = self.floor * self.floor + (self.scale_sd * w.norm()).powi(2);
        (w, 1.0 / var)
    }
}

/// The mean of the channels' positions.
fn centroid(geo: &[Geometry]) -> Vector3<f64> {
    geo.iter().map(|g| g.position).sum::<Vector3<f64>>() / geo.len() as f64
}

/// Whether Ω per motion sample is an unknown of the fit: self-calibrating, or with a reference
/// taken as a reading of Ω ([`RatePrior`]).
fn omega_unknown(rate: &RateSource, record: &Record) -> bool {
    matches!(rate, RateSource::Estimator(_)) || record.rate_prior.is_some()
}

/// The array's size: the RMS distance of the channels' positions from their mean (the size
/// [`RatePrior`] holds).
fn size(geo: &[Geometry]) -> f64 {
    let mean = centroid(geo);
    (geo.iter()
        .map(|g| (g.position - mean).norm_squared())
        .sum::<f64>()
        / geo.len() as f64)
        .sqrt()
}

/// Scales the positions of `geo` about their mean by `k`.
fn grow(geo: &mut [Geometry], k: f64) {
    let mean = centroid(geo);
    for g in geo.iter_mut() {
        g.position = mean + (g.position - mean) * k;
    }
}

/// One channel's identified geometry and its standard deviations.
#[derive(Clone, Debug)]
pub struct Identified {
    /// The geometry.
    pub geometry: Geometry,
    /// Standard deviation of each of [`PARAMETERS`] (NaN where not identified).
    pub sd: [f64; 7],
    /// Parameter directions the record does not determine (held at nominal), by the names
    /// of their main parameters.
    pub held: Vec<String>,
    /// RMS of the channel's residual (m/s²) with the nominal and with the identified geometry.
    pub residual_rms: (f64, f64),
    /// Scatter of one reading at rest about the identified geometry (m/s²): the white noise
    /// and the floor of the pose means ([`Scatter::at_rest`]).
    pub rest_scatter: f64,
}

impl Identified {
    /// The channel's fit as every identification reports it (estimator-core's
    /// [`ChannelFit`]): a parameter this record did not determine is held, with its
    /// tolerance for deviation; the residual is the identified geometry's.
    pub fn channel_fit(&self, tol: &Tolerance) -> ChannelFit {
        let mut held = 0u8;
        let sd = core::array::from_fn(|p| {
            if self.sd[p].is_finite() {
                self.sd[p]
            } else {
                held |= Param::ALL[p].bit();
                tol.of(p)
            }
        });
        ChannelFit {
            channel: self.geometry.channel(),
            sd,
            held,
            residual_rms: self.residual_rms.1,
        }
    }
}

/// The outcome of [`identify`].
#[derive(Clone, Debug)]
pub struct Identification {
    /// Per channel.
    pub channels: Vec<Identified>,
    /// Freedoms held by convention (named for the report).
    pub conventions: Vec<String>,
    /// Alternations run.
    pub iterations: usize,
    /// The largest move of a parameter in the last alternation, in tolerances: above
    /// [`CONVERGED_STEP`] the iteration did not converge.
    pub last_step: f64,
    /// How well the identified arrangement's frame is tied to the body
    /// ([`super::frame::uncertainty`]).
    pub frame: estimator_core::FrameUncertainty<f64>,
    /// The residuals with the nominal and with the identified geometry.
    pub residuals: (Residuals, Residuals),
    /// Self-calibration: the axes' rotation relative to the lever arms that the kinematic
    /// tie removed (total over its passes) and the deviation left
    /// ([`super::kinematics`]); `None` with a reference, or where the record's motion did not
    /// determine it.
    pub kinematic: Option<RelativeRotation>,
    /// With a reference of inexact scale ([`RatePrior`]): its common scale factor as fitted.
    pub reference_scale: Option<f64>,
    /// The tolerances the identified subspace was decided with.
    pub tolerance: Tolerance,
}

/// The last step of a converged identification moves no parameter by more than this many
/// tolerances.
pub const CONVERGED_STEP: f64 = 0.01;

/// Runs the identification (see the module doc). `nominal` is the arrangement as drawn.
///
/// Without a reference, Ω comes from the estimator on the geometry being identified: the fit
/// starts from the static poses alone (the parameters they determine), so that the first
/// field is not the uncalibrated one. Ω at every motion sample is the reference's, or
/// (self-calibration) the estimator's on the geometry after the static poses, then refined
/// with the field at every alternation. The record is weighted by the declared noise first;
/// once that fit has converged, by each kind of datum's measured scatter ([`Scatter`]), from
/// where the motion's stage started: the directions the reweighted record no longer
/// determines stay where that start put them; the scatter is measured once the
/// declared-noise fit has settled to [`SETTLED_COST`] of its cost (the residuals it measures
/// are then as good as converged): on a record the model does not fit, that fit only finds the
/// weights, and its slow tail cost as much as the reweighted fit. The identified subspace is
/// decided on the third iteration of a stage (the first ones may start far from the solution)
/// and then kept, so that directions near the threshold do not flip in and out and the
/// iteration converges.
pub fn identify(
    nominal: &[Geometry],
    record: &Record,
    rate: &RateSource,
    fit: FitSet,
    tol: &Tolerance,
) -> Result<Identification, String> {
    let n = nominal.len();
    let mut geo = nominal.to_vec();
    if record.poses.is_empty() && record.motion.is_empty() {
        return Err("the record has neither static poses nor motion to calibrate from".into());
    }
    let residual_before = residuals(&geo, record, rate)?;
    let mut step = JointStep::default();
    let mut iterations = 0;
    let mut last_step = f64::INFINITY;
    let self_calibration = matches!(rate, RateSource::Estimator(_));
    let statics_first = self_calibration && !record.poses.is_empty();
    let mut omega: Option<Vec<Option<Vector3<f64>>>> = None;
    let mut frozen: Option<JointStep> = None;
    let mut flat = 0;
    let mut stage_start = if statics_first { MAX_ITERATIONS / 3 } else { 0 };
    let motion_iterations = MAX_ITERATIONS - stage_start;
    let mut scatter = Scatter::white(nominal);
    let mut motion_start: Option<Vec<Geometry>> = None;
    let mut weights_final = false;
    let mut limit = MAX_ITERATIONS;
    let poses_only = Record {
        motion: &[],
        rate_prior: None,
        ..*record
    };
    let free_omega = omega_unknown(rate, record);
    for it in 0.. {
        if it >= limit {
            break;
        }
        iterations = it + 1;
        (record.progress)(it);
        let stage = if statics_first && it < MAX_ITERATIONS / 3 {
            &poses_only
        } else {
            record
        };
        let record = stage;
        if it == stage_start && motion_start.is_none() {
            motion_start = Some(geo.clone());
        }
        let probe = Probe::new(record, free_omega, &scatter);
        let (normal, rhs, motion_fields) = normal_equations(&geo, &probe, rate, &mut omega)?;
        let at = if std::ptr::eq(stage, &poses_only) {
            it
        } else {
            it - stage_start
        };
        if at == 0 {
            frozen = None;
            flat = 0;
        }
        step = match &frozen {
            Some(f) => truncated_step(&normal, &rhs, n, &[], tol, Some(f)),
            None => decided_step(&normal, &rhs, n, &fit.mask(), tol),
        };
        if at == 2 {
            frozen = Some(step.clone());
            let last_stage = !std::ptr::eq(stage, &poses_only);
            if last_stage && determines_too_few(&step, fit, n) {
                last_step = f64::INFINITY;
                break;
            }
        }
        let (largest, shrink) = trust_region(&step, tol, n);
        last_step = largest;
        let seeds = omega.clone().unwrap_or_default();
        let probe = Probe {
            record,
            seeds: &seeds,
            free_omega,
            scatter: &scatter,
        };
        let (trial, scale, before, after) = line_search(&geo, &step, &probe, shrink);
        // A step that raises the cost even shortened is not taken. Converged on the cost when
        // no step lowers it by more than a part in 10⁷ any more (the Gauss–Newton step can
        // stay finite along directions the cost is flat in: a real board's misfit).
        let descends = after <= before;
        if descends {
            geo = trial;
        }
        check_in_range(&geo, it)?;
        flat = if descends && before - after > 1e-7 * before {
            0
        } else {
            flat + 1
        };
        if flat >= FLAT_ITERATIONS {
            last_step = 0.0;
        }
        log::debug!(
            "iteration {it}: largest scaled step {largest:.3e} (taken × {scale:.3}), cost {before:.6e} -> {after:.6e}, motion fields {motion_fields}"
        );
        let converged = largest < 1e-10 || flat >= FLAT_ITERATIONS;
        let settled = !weights_final && descends && before - after <= SETTLED_COST * before;
        if converged || settled {
            if statics_first && it < MAX_ITERATIONS / 3 {
                continue;
            }
            if !weights_final {
                weights_final = true;
                let probe = Probe::new(record, free_omega, &scatter);
                if let Some(measured) = reweighted(&geo, &probe, omega.as_deref()) {
                    log::debug!("reweighted: {measured:?}");
                    scatter = measured;
                    geo = motion_start.clone().unwrap_or_else(|| nominal.to_vec());
                    scatter.weigh_motion(&mut geo);
                    if free_omega {
                        omega = None;
                    }
                    stage_start = it + 1;
                    limit = stage_start + motion_iterations;
                    last_step = f64::INFINITY;
                    continue;
                }
            }
            if converged {
                break;
            }
        }
    }
    finish(
        nominal,
        record,
        rate,
        tol,
        Fitted {
            geo,
            omega: omega.filter(|_| self_calibration),
            scatter,
            step,
            residual_before,
            iterations,
            last_step,
        },
    )
}

/// The joint normal equations at `geo` ([`joint_normal_equations`]) with the field of every
/// motion sample from `omega` (the rates, first from `rate`; updated when Ω is free) and the
/// poses' gravity; also how many motion samples have a field.
fn normal_equations(
    geo: &[Geometry],
    probe: &Probe,
    rate: &RateSource,
    omega: &mut Option<Vec<Option<Vector3<f64>>>>,
) -> Result<(DMatrix<f64>, DVector<f64>, usize), String> {
    let (record, free_omega, scatter) = (probe.record, probe.free_omega, probe.scatter);
    if !record.motion.is_empty() && omega.is_none() {
        *omega = Some(initial_rates(geo, record, rate)?);
    }
    let fields = match omega.as_ref() {
        Some(w) => motion_fields(geo, record, w, free_omega),
        None => Vec::new(),
    };
    if free_omega && !record.motion.is_empty() {
        *omega = Some(fields.iter().map(|f| f.map(|f| f.omega)).collect());
    }
    let gravity = pose_gravity(geo, record.poses, scatter);
    let (normal, rhs) = joint_normal_equations(geo, record, &fields, &gravity, free_omega, scatter);
    Ok((normal, rhs, fields.iter().filter(|f| f.is_some()).count()))
}

/// A record that determines fewer than half of the parameters asked for is refused by the
/// caller ("not exciting enough"): the alternations stop there rather than slide along what
/// it does not determine (one pose with a little motion moved a scale out of range in 30
/// alternations).
fn determines_too_few(step: &JointStep, fit: FitSet, n: usize) -> bool {
    let mask = fit.mask();
    let asked = (0..7 * n).filter(|&p| mask[p % 7]).count();
    let determined = (0..7 * n)
        .filter(|&p| mask[p % 7] && step.sd[p].is_finite())
        .count();
    too_few_determined(determined, asked)
}

/// The step's largest move in tolerances, and the factor that keeps it within the trust
/// region: no parameter moves more than [`MAX_STEP`] tolerances in one step (far from the
/// solution the linearisation, and a field from an uncalibrated estimator, would otherwise
/// throw the iteration out).
fn trust_region(step: &JointStep, tol: &Tolerance, n: usize) -> (f64, f64) {
    let largest = (0..7 * n)
        .map(|p| (step.delta[p] / tol.of(p % 7)).abs())
        .fold(0.0f64, f64::max);
    let shrink = if largest > MAX_STEP {
        MAX_STEP / largest
    } else {
        1.0
    };
    (largest, shrink)
}

/// The weights measured on `geo` ([`measured_scatter`]), if they call for reweighting
/// ([`Scatter::reweights`]). Reweighted once: Helmert's iteration would go on until the
/// scatter settles — a misfit in motion drags the parameters the poses fix, so their floor
/// comes out high at first and the deviations conservative (error/sd 0.63 RMS on the misfit
/// test, 0.78 after three reweightings) — but on the real board each further reweighting
/// raised the self-calibration's declared motion noise, the estimator left more samples
/// undecided (6 525 → 4 538 on exp4) and the kinematic tie turned the axes by 0.24 rad: Ω
/// 6.9 rad/s RMS against 2.8 after one.
fn reweighted(
    geo: &[Geometry],
    probe: &Probe,
    omega: Option<&[Option<Vector3<f64>>]>,
) -> Option<Scatter> {
    let record = probe.record;
    let measured = measured_scatter(geo, record, omega, probe.scatter, probe.free_omega);
    let pose_len = record.poses.iter().map(|p| p.samples.len()).max();
    probe
        .scatter
        .reweights(&measured, pose_len.unwrap_or(1))
        .then_some(measured)
}

/// Iterations in a row that leave the cost unchanged before the fit counts as converged.
const FLAT_ITERATIONS: usize = 3;

/// A declared-noise fit whose step lowers the cost by less than this share has settled
/// enough to measure its scatter from.
const SETTLED_COST: f64 = 1e-3;

/// Halvings of a step that raises the cost, at most.
const MAX_HALVINGS: usize = 4;

/// The weighted sum of squared residuals of `geo` on the record, with the field re-estimated
/// from `seeds` (Ω per motion sample) as the iteration does.
fn cost(
    geo: &[Geometry],
    record: &Record,
    seeds: &[Option<Vector3<f64>>],
    with_omega: bool,
    scatter: &Scatter,
) -> f64 {
    let gravity = pose_gravity(geo, record.poses, scatter);
    let mut sum = 0.0;
    for (pose, gk) in record.poses.iter().zip(gravity.iter()) {
        for (i, (g, m)) in geo.iter().zip(pose.mean.iter()).enumerate() {
            let r = m - g.reading(gk);
            if r.is_finite() {
                sum += r * r * scatter.pose_weight(i, pose.samples.len());
            }
        }
    }
    if !record.motion.is_empty() && !seeds.is_empty() {
        let fields = motion_fields(geo, record, seeds, with_omega);
        for (&k, field) in record.motion.iter().zip(fields.iter()) {
            let Some(field) = field else {
                continue;
            };
            sum += sample_chi2(geo, record, k, field);
        }
    }
    sum
}

/// One motion sample's whitened residual `Σ ((p − reading) / noise)²` over its finite readings,
/// with the field `f` (what [`cost`] sums and [`reject_outliers`] tests).
fn sample_chi2(geo: &[Geometry], record: &Record, k: usize, f: &Field) -> f64 {
    let (row, gamma) = (&record.rows[k], &record.gamma);
    let m = f.m(gamma);
    let prior = record.rate_prior.map_or(0.0, |p| {
        let (w, weight) = p.at(k);
        (f.omega - w).norm_squared() * weight
    });
    prior
        + geo
            .iter()
            .zip(row.iter())
            .filter(|(_, p)| p.is_finite())
            .map(|(g, p)| {
                let e = p - f.reading(g, &m);
                e * e / (g.noise * g.noise)
            })
            .sum::<f64>()
}

/// Passes of the kinematic tie at most (the first removes nearly all of the relative
/// rotation; the next ones re-estimate the fields with the corrected geometry).
const KINEMATIC_PASSES: usize = 3;

/// Self-calibration's kinematic tie ([`super::kinematics`]): estimates the axes' rotation
/// relative to the lever arms from Ω′ against the change of Ω, removes it from `geo`, and
/// repeats with the fields re-estimated until the estimate is below a tenth of its deviation.
/// Returns the total removed, with the last pass's deviation. Passes that do not converge —
/// one finds more rotation than the one before removed — are undone, all of them, and the tie
/// is said not applied (`ground-calibration` without its held-out stretches, which hold the
/// turntable's ramps: 2.2 mrad, then 21, then 3 rad, and the held-out residual 698× the
/// noise).
fn tie_kinematics(
    geo: &mut [Geometry],
    record: &Record,
    omega: &[Option<Vector3<f64>>],
) -> Option<RelativeRotation> {
    let mut seeds = omega.to_vec();
    let mut total: Option<RelativeRotation> = None;
    let untied = geo.to_vec();
    let mut last = None;
    for _ in 0..KINEMATIC_PASSES {
        let fields = motion_fields(geo, record, &seeds, true);
        let Some(r) = super::kinematics::relative_rotation(record.times, record.motion, &fields)
        else {
            break;
        };
        if !r.holds() {
            // The record's kinematics do not hold: said, not applied (a later pass has
            // already moved the geometry by passes that held; keep those).
            return Some(total.unwrap_or(r));
        }
        if last.is_some_and(|l: Vector3<f64>| r.d.norm() > l.norm()) {
            geo.copy_from_slice(&untied);
            log::debug!("kinematic tie diverged: {r:?}");
            return Some(RelativeRotation {
                diverged: true,
                ..r
            });
        }
        super::kinematics::remove(geo, &r.d);
        last = Some(r.d);
        seeds = fields.iter().map(|f| f.map(|f| f.omega)).collect();
        let small = (0..3).all(|i| r.d[i].abs() <= 0.1 * r.sd[i]);
        total = Some(RelativeRotation {
            d: total.map_or(Vector3::zeros(), |t| t.d) + r.d,
            ..r
        });
        log::debug!("kinematic tie: {r:?}");
        if small {
            break;
        }
    }
    total
}

/// The largest move of a parameter in one step, in tolerances.
pub const MAX_STEP: f64 = 2.0;

/// Most alternations of field and geometry (Gauss–Newton converges in a handful; the
/// estimator as the rate source needs a few more).
pub const MAX_ITERATIONS: usize = 45;

/// Alternations of one identification at most: the fit with the declared noise and the one
/// reweighted by the measured scatter.
pub const MAX_ALTERNATIONS: usize = 2 * MAX_ITERATIONS;

/// A parameter is not identified when more than this share of it lies in directions the
/// record does not determine.
const HELD_SHARE: f64 = 0.5;
/// An eigenvalue below this fraction of the largest is a freedom the data do not see at all
/// (round-off level of the projected normal matrix).
const GAUGE_EIGENVALUE: f64 = 1e-9;

/// The scatter of `geo`'s residuals on `record` ([`Scatter::measured`]): the fields
/// re-estimated from `omega` (with `self_calibration`, Ω as well), the poses' gravity weighted
/// by `scatter`.
fn measured_scatter(
    geo: &[Geometry],
    record: &Record,
    omega: Option<&[Option<Vector3<f64>>]>,
    scatter: &Scatter,
    self_calibration: bool,
) -> Scatter {
    let fields = omega.map_or_else(Vec::new, |w| {
        motion_fields(geo, record, w, self_calibration)
    });
    let gravity = pose_gravity(geo, record.poses, scatter);
    let unknowns = if self_calibration { 9 } else { 6 };
    scatter.measured(geo, record, &fields, &gravity, unknowns)
}
