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
use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, SVector, SymmetricEigen, Vector3};

pub use estimator_core::identify::Tolerance;
use estimator_core::identify::{reading_gradient, too_few_determined, ChannelFit, Param, PARAMS};
use estimator_core::{Channel, G0};

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
    // Without a reference, Ω comes from the estimator on the geometry being identified: start
    // from the static poses alone (the parameters they determine), so that the first field
    // is not the uncalibrated one.
    let self_calibration = matches!(rate, RateSource::Estimator(_));
    let statics_first = self_calibration && !record.poses.is_empty();
    // Ω at every motion sample: the reference's, or (self-calibration) the estimator's on the
    // geometry after the static poses, then refined with the field at every alternation.
    let mut omega: Option<Vec<Option<Vector3<f64>>>> = None;
    let mut frozen: Option<JointStep> = None;
    let mut flat = 0;
    let mut stage_start = if statics_first { MAX_ITERATIONS / 3 } else { 0 };
    let motion_iterations = MAX_ITERATIONS - stage_start;
    // Weighted by the declared noise first; once that fit has converged, by each kind of
    // datum's measured scatter ([`Scatter`]), from where the motion's stage started: the
    // directions the reweighted record no longer determines stay where that start put them.
    let mut scatter = Scatter::white(nominal);
    let mut motion_start: Option<Vec<Geometry>> = None;
    let mut weights_final = false;
    let mut limit = MAX_ITERATIONS;
    let poses_only = Record {
        rows: record.rows,
        times: record.times,
        poses: record.poses,
        motion: &[],
        gamma: record.gamma,
        progress: record.progress,
        rate_prior: None,
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
        if !record.motion.is_empty() && omega.is_none() {
            omega = Some(initial_rates(&geo, record, rate)?);
        }
        let fields = match &omega {
            Some(w) => motion_fields(&geo, record, w, free_omega),
            None => Vec::new(),
        };
        if free_omega && !record.motion.is_empty() {
            omega = Some(fields.iter().map(|f| f.map(|f| f.omega)).collect());
        }
        let gravity = pose_gravity(&geo, record.poses, &scatter);
        let (normal, rhs) =
            joint_normal_equations(&geo, record, &fields, &gravity, free_omega, &scatter);
        // The identified subspace is decided on the third iteration of a stage (the first
        // ones may start far from the solution) and then kept, so that directions near the
        // threshold do not flip in and out and the iteration converges.
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
            // A record that determines fewer than half of the parameters asked for is
            // refused by the caller ("not exciting enough"): stop here rather than slide
            // along what it does not determine (one pose with a little motion moved a scale
            // out of range in 30 alternations).
            let mask = fit.mask();
            let asked = (0..7 * n).filter(|&p| mask[p % 7]).count();
            let determined = (0..7 * n)
                .filter(|&p| mask[p % 7] && step.sd[p].is_finite())
                .count();
            let last_stage = !std::ptr::eq(stage, &poses_only);
            if last_stage && too_few_determined(determined, asked) {
                last_step = f64::INFINITY;
                break;
            }
        }
        let largest = (0..7 * n)
            .map(|p| (step.delta[p] / tol.of(p % 7)).abs())
            .fold(0.0f64, f64::max);
        // Trust region: no parameter moves more than MAX_STEP tolerances in one step (far
        // from the solution the linearisation, and a field from an uncalibrated estimator,
        // would otherwise throw the iteration out).
        last_step = largest;
        let shrink = if largest > MAX_STEP {
            MAX_STEP / largest
        } else {
            1.0
        };
        let seeds = omega.clone().unwrap_or_default();
        let moved = |scale: f64| {
            let mut trial = geo.clone();
            for (i, g) in trial.iter_mut().enumerate() {
                let d = SVector::<f64, 7>::from_fn(|j, _| step.delta[7 * i + j] * scale);
                apply(g, &d);
            }
            trial
        };
        let before = cost(&geo, record, &seeds, free_omega, &scatter);
        let mut scale = shrink;
        let mut trial = moved(scale);
        let mut halvings = 0;
        let mut after = cost(&trial, record, &seeds, free_omega, &scatter);
        while halvings < MAX_HALVINGS && after > before {
            scale *= 0.5;
            trial = moved(scale);
            after = cost(&trial, record, &seeds, free_omega, &scatter);
            halvings += 1;
        }
        // A step that raises the cost even shortened is not taken. Converged on the cost when
        // no step lowers it by more than a part in 10⁷ any more (the Gauss–Newton step can
        // stay finite along directions the cost is flat in: a real board's misfit).
        let descends = after <= before;
        if descends {
            geo = trial;
        }
        if let Some((i, g)) = geo
            .iter()
            .enumerate()
            .find(|(_, g)| !(g.scale > 0.5 && g.scale < 2.0 && g.bias.is_finite()))
        {
            return Err(format!(
                "the identification diverged: after {} alternations channel {i} (arrangement order, from 0) has scale {:.3} and bias {:.3} m/s², outside any part's range; the record does not determine them (in free fall, without static poses, a channel's scale and its lever arm are seen only as their product): nothing written",
                it + 1,
                g.scale,
                g.bias
            ));
        }
        flat = if !descends || before - after <= 1e-7 * before {
            flat + 1
        } else {
            0
        };
        if flat >= FLAT_ITERATIONS {
            last_step = 0.0;
        }
        log::debug!(
            "iteration {it}: largest scaled step {largest:.3e} (taken × {scale:.3}), cost {before:.6e} -> {after:.6e}, motion fields {}",
            fields.iter().filter(|f| f.is_some()).count()
        );
        let converged = largest < 1e-10 || flat >= FLAT_ITERATIONS;
        // The scatter is measured once the declared-noise fit has settled to a part in a
        // thousand of its cost (the residuals it measures are then as good as converged): on
        // a record the model does not fit, that fit only finds the weights, and its slow
        // tail cost as much as the reweighted fit (a one-hour record: 74 s).
        let settled = !weights_final && descends && before - after <= SETTLED_COST * before;
        if converged || settled {
            if statics_first && it < MAX_ITERATIONS / 3 {
                continue;
            }
            if !weights_final {
                // Reweighted once. Helmert's iteration would go on until the scatter settles
                // — a misfit in motion drags the parameters the poses fix, so their floor
                // comes out high at first and the deviations conservative (error/sd 0.63 RMS
                // on the misfit test, 0.78 after three reweightings) — but on the real board
                // each further reweighting raised the self-calibration's declared motion
                // noise, the estimator left more samples undecided (6 525 → 4 538 on exp4)
                // and the kinematic tie turned the axes by 0.24 rad: Ω 6.9 rad/s RMS against
                // 2.8 after one.
                weights_final = true;
                let measured =
                    measured_scatter(&geo, record, omega.as_deref(), &scatter, free_omega);
                let pose_len = record.poses.iter().map(|p| p.samples.len()).max();
                if scatter.reweights(&measured, pose_len.unwrap_or(1)) {
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
    // With a reference of inexact scale, its common factor and the array's size are one
    // freedom ([`RatePrior`]): the size is held at the drawing's and the factor follows
    // (exact for the array's own Ω: its readings do not change).
    let prior = record.rate_prior.map(|p| {
        let k = size(nominal) / size(&geo);
        grow(&mut geo, k);
        RatePrior {
            scale: p.scale / k.sqrt(),
            ..p
        }
    });
    let kinematic = match &omega {
        Some(w) if self_calibration => tie_kinematics(&mut geo, record, w),
        _ => None,
    };
    for (g, w) in geo.iter_mut().zip(scatter.white.iter()) {
        // The geometry's noise is the white noise again (the motion's scatter was the fit's
        // weight).
        g.noise = *w;
    }
    let fitted = Record {
        rate_prior: prior,
        ..*record
    };
    let residual_after = residuals(&geo, &fitted, rate)?;
    let channels = (0..n)
        .map(|i| Identified {
            geometry: geo[i],
            sd: core::array::from_fn(|j| step.sd[7 * i + j]),
            held: step.held[i].clone(),
            residual_rms: (
                residual_before.per_channel[i],
                residual_after.per_channel[i],
            ),
            rest_scatter: scatter.at_rest(i),
        })
        .collect();
    let mut frame = super::frame::uncertainty(&geo, &step.error_covariance(n), tol);
    let mut conventions = step.common;
    if let Some(p) = prior {
        // The size is held as a gauge is: only as good as the drawing.
        frame.size = frame.size.hypot(super::frame::held_size(&geo, tol));
        conventions.push(format!(
            "the array's size: held at the drawing's (with a reference of inexact scale the size and the reference's common scale factor are one freedom; the factor is fitted: {:.4})",
            p.scale
        ));
    }
    if let Some(k) = kinematic.as_ref().filter(|k| k.holds()) {
        frame.relative_rotation = k.sd.max();
    }
    Ok(Identification {
        channels,
        conventions,
        reference_scale: prior.map(|p| p.scale),
        tolerance: *tol,
        iterations,
        last_step,
        frame,
        residuals: (residual_before, residual_after),
        kinematic,
    })
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

/// The gravity direction of each pose (|g| = G0), by least squares over the channels.
pub(super) fn pose_gravity(
    geo: &[Geometry],
    poses: &[Pose],
    scatter: &Scatter,
) -> Vec<Vector3<f64>> {
    poses
        .iter()
        .map(|pose| {
            let mut a = Matrix3::zeros();
            let mut b = Vector3::zeros();
            for (i, (g, m)) in geo.iter().zip(pose.mean.iter()).enumerate() {
                if !m.is_finite() {
                    continue;
                }
                let k = g.axis * g.scale;
                let w = scatter.pose_weight(i, pose.samples.len());
                a += k * k.transpose() * w;
                b += k * ((m - g.bias) * w);
            }
            let v = a.lu().solve(&b).unwrap_or_else(Vector3::zeros);
            if v.norm() > 0.0 {
                v * (G0 / v.norm())
            } else {
                v
            }
        })
        .collect()
}

/// Ω at every motion sample from the source, before any refinement.
fn initial_rates(
    geo: &[Geometry],
    record: &Record,
    rate: &RateSource,
) -> Result<Vec<Option<Vector3<f64>>>, String> {
    Ok(match rate {
        RateSource::Reference(w) => record.motion.iter().map(|&k| Some(w[k])).collect(),
        RateSource::Estimator(run) => {
            let all = run(geo)?;
            record.motion.iter().map(|&k| all[k]).collect()
        }
    })
}

/// The field at every motion sample of `record` with Ω estimated by the array itself (σ0, Ω′
/// and Ω by Gauss–Newton from `seeds`; `None` where the sample's readings do not fit).
pub fn array_fields(
    geo: &[Geometry],
    record: &Record,
    seeds: &[Option<Vector3<f64>>],
) -> Vec<Option<Field>> {
    motion_fields(geo, record, seeds, true)
}

/// The derivative of a channel's centripetal reading `k·(Ω×(Ω×R))` with respect to Ω.
fn centripetal_gradient(k: &Vector3<f64>, r: &Vector3<f64>, w: &Vector3<f64>) -> Vector3<f64> {
    k * w.dot(r) + r * k.dot(w) - w * (2.0 * k.dot(r))
}

/// The field at every motion sample by least squares over the channels: σ0 and Ω′ with Ω
/// held at `omega` (a reference), or with `estimate_omega` σ0, Ω′ and Ω together (three
/// Gauss–Newton steps from `omega`: the sign of Ω does not matter, only `{Ω}²` enters).
fn motion_fields(
    geo: &[Geometry],
    record: &Record,
    omega: &[Option<Vector3<f64>>],
    estimate_omega: bool,
) -> Vec<Option<Field>> {
    let mut fields: Vec<Option<Field>> = record
        .motion
        .iter()
        .zip(omega.iter())
        .map(|(&k, omega)| {
            let row = &record.rows[k];
            let mut field = Field {
                omega: (*omega)?,
                ..Default::default()
            };
            // σ0 and Ω′ with Ω held: linear.
            // Fixed-size matrices: the per-sample solves are most of a calibration's time
            // (dynamic ones spent a third of it in allocation and a general matrix product).
            let mut a = SMatrix::<f64, 6, 6>::zeros();
            let mut b = SVector::<f64, 6>::zeros();
            for (g, p) in geo.iter().zip(row.iter()).filter(|(_, p)| p.is_finite()) {
                let kv = g.axis * g.scale;
                let rk = g.position.cross(&kv);
                let h = SVector::<f64, 6>::new(kv.x, kv.y, kv.z, rk.x, rk.y, rk.z);
                let y = p - g.bias - kv.dot(&(field.m(&record.gamma) * g.position));
                let w = 1.0 / (g.noise * g.noise);
                a += h * h.transpose() * w;
                b += h * (y * w);
            }
            let x = a.lu().solve(&b)?;
            field.sigma0 = Vector3::new(x[0], x[1], x[2]);
            field.domega = Vector3::new(x[3], x[4], x[5]);
            if !estimate_omega {
                return Some(field);
            }
            // Then all nine by Gauss–Newton increments; directions the sample does not
            // determine (near rest the centripetal columns vanish) keep their value. A step
            // that does not lower the sample's residual is not taken (the per-sample problem
            // has mirror solutions and flat directions: undamped steps can climb), so the
            // field only ever improves on its start.
            let mut best = f64::INFINITY;
            let mut previous = field;
            for _ in 0..FIELD_ITERATIONS {
                let m = field.m(&record.gamma);
                let mut a = SMatrix::<f64, 9, 9>::zeros();
                let mut b = SVector::<f64, 9>::zeros();
                let mut ssr = 0.0;
                for (g, p) in geo.iter().zip(row.iter()).filter(|(_, p)| p.is_finite()) {
                    let kv = g.axis * g.scale;
                    let rk = g.position.cross(&kv);
                    let c = centripetal_gradient(&kv, &g.position, &field.omega);
                    let h = SVector::<f64, 9>::from_column_slice(&[
                        kv.x, kv.y, kv.z, rk.x, rk.y, rk.z, c.x, c.y, c.z,
                    ]);
                    let e = p - field.reading(g, &m);
                    let w = 1.0 / (g.noise * g.noise);
                    ssr += e * e * w;
                    a += h * h.transpose() * w;
                    b += h * (e * w);
                }
                if let Some(prior) = record.rate_prior {
                    let (w, weight) = prior.at(k);
                    let e = w - field.omega;
                    ssr += e.norm_squared() * weight;
                    for i in 0..3 {
                        a[(6 + i, 6 + i)] += weight;
                        b[6 + i] += e[i] * weight;
                    }
                }
                if ssr > best {
                    field = previous;
                    break;
                }
                best = ssr;
                let tiny = a.diagonal().max() * 1e-8;
                let inv = a.pseudo_inverse(tiny).ok()?;
                let d = inv * b;
                // A direction the sample does not determine (pseudo-inverse zero there)
                // leaves that part of Ω unknown, not exact.
                let determined = (6..9).all(|i| inv[(i, i)] > 0.0);
                field.omega_var = if determined {
                    inv[(6, 6)] + inv[(7, 7)] + inv[(8, 8)]
                } else {
                    f64::INFINITY
                };
                previous = field;
                field.sigma0 += Vector3::new(d[0], d[1], d[2]);
                field.domega += Vector3::new(d[3], d[4], d[5]);
                field.omega += Vector3::new(d[6], d[7], d[8]);
                // Converged: the step no longer moves Ω by a relevant amount.
                if d.rows(6, 3).norm_squared() <= 1e-12 * (1.0 + previous.omega.norm_squared()) {
                    break;
                }
            }
            Some(field)
        })
        .collect();
    if estimate_omega {
        reject_outliers(geo, record, &mut fields);
    }
    fields
}

/// Leaves out the motion samples whose field does not explain their readings: a whitened
/// residual above the 99.9 % point of χ² for the sample's degrees of freedom and 25× the
/// median sample's (a tail the model leaves on a fitting record is kept). Such a sample's
/// Ω started far from its own (at the onset of a rotation the estimator's rate is small and
/// the centripetal columns vanish) and the per-sample solve stays there: kept, a handful of
/// them biased a noise-free fit by 2e-6 of scale and stalled it. Only where the median sample
/// fits to its noise (χ² ≤ 2 dof): on a record the model does not fit (the real 62.5 Hz board:
/// residuals 5–15× the noise) the test cannot tell such a sample from the misfit, and leaving
/// out its worst-fitting samples made its self-calibrated Ω worse than the nominal geometry's
/// (7.79 against 6.44 rad/s RMS); on `ground-calibration` the χ² point alone (without the 25×
/// median) left out enough of the tail to throw the kinematic tie off by 1.5 rad.
fn reject_outliers(geo: &[Geometry], record: &Record, fields: &mut [Option<Field>]) {
    let ssr: Vec<Option<f64>> = record
        .motion
        .iter()
        .zip(fields.iter())
        .map(|(&k, f)| f.as_ref().map(|f| sample_chi2(geo, record, k, f)))
        .collect();
    let mut sorted: Vec<f64> = ssr.iter().flatten().copied().collect();
    if sorted.is_empty() {
        return;
    }
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let dof = geo.len().saturating_sub(9).max(1);
    if median > 2.0 * dof as f64 {
        return;
    }
    let gate = estimator_core::estimate::chi2_999(dof).max(25.0 * median);
    for (f, s) in fields.iter_mut().zip(ssr.iter()) {
        if s.is_some_and(|s| s > gate) {
            *f = None;
        }
    }
}

/// Gauss–Newton steps per sample for σ0, Ω′ and Ω.
const FIELD_ITERATIONS: usize = 6;

/// The tilt directions `u1, u2` perpendicular to the unit `a` (estimator-core's
/// [`estimator_core::identify::tilt_basis`]).
pub(super) fn tilt_basis(a: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let (u1, u2) = estimator_core::identify::tilt_basis(&(*a).into());
    (u1.into(), u2.into())
}

/// The channel's Jacobian row (in [`PARAMETERS`] order) at the specific force `f` seen at its
/// position, with `m` the field matrix (`f = σ0 + m R`): the channel model's gradient
/// ([`reading_gradient`]).
fn jacobian(g: &Geometry, f: &Vector3<f64>, m: &Matrix3<f64>) -> SVector<f64, 7> {
    let (u1, u2) = estimator_core::identify::tilt_basis(&g.axis.into());
    let rows: [[f64; 3]; 3] = core::array::from_fn(|a| core::array::from_fn(|l| m[(a, l)]));
    SVector::<f64, 7>::from(reading_gradient(
        g.scale,
        &g.axis.into(),
        &(u1, u2),
        &rows,
        &(*f).into(),
    ))
}

/// The joint normal equations of all channels' parameters (7 per channel, [`PARAMETERS`]
/// order) with the field projected out (variable projection): per pose its gravity
/// direction (2 unknowns: the magnitude is [`G0`]), per motion sample σ0 and Ω′ (6). Each
/// row of data adds `JᵀWJ − (JᵀWH)(HᵀWH)⁻¹(HᵀWJ)` with `H` the field's columns, so the
/// geometry step accounts for what the field can absorb, and the inverse of the result is
/// the geometry's covariance with the field unknown.
fn joint_normal_equations(
    geo: &[Geometry],
    record: &Record,
    fields: &[Option<Field>],
    gravity: &[Vector3<f64>],
    with_omega: bool,
    scatter: &Scatter,
) -> (DMatrix<f64>, DVector<f64>) {
    let n = geo.len();
    let mut normal = DMatrix::<f64>::zeros(7 * n, 7 * n);
    let mut rhs = DVector::<f64>::zeros(7 * n);
    // `prior`: a reading of Ω (the field's last three unknowns): its residual and weight.
    let mut add = |rows: &[DataRow], q: usize, prior: Option<(Vector3<f64>, f64)>| {
        let mut s = DMatrix::<f64>::zeros(q, q);
        let mut c = DMatrix::<f64>::zeros(7 * n, q);
        let mut hc = DVector::<f64>::zeros(q);
        if let Some((e, weight)) = prior {
            for i in 0..3 {
                s[(6 + i, 6 + i)] += weight;
                hc[6 + i] += e[i] * weight;
            }
        }
        for row in rows {
            let (i, w, e) = (row.channel, row.weight, row.residual);
            let hv = DVector::from_column_slice(&row.field);
            s += &hv * hv.transpose() * w;
            hc += &hv * (w * e);
            for a in 0..7 {
                let ja = row.jacobian[a] * w;
                rhs[7 * i + a] += ja * e;
                for b in 0..7 {
                    normal[(7 * i + a, 7 * i + b)] += ja * row.jacobian[b];
                }
                for (col, hq) in row.field.iter().enumerate() {
                    c[(7 * i + a, col)] += ja * hq;
                }
            }
        }
        // normal −= C S⁺ Cᵀ, rhs −= C S⁺ (HᵀWe). The pseudo-inverse: near rest the
        // centripetal columns vanish and S is singular (the field then has fewer freedoms).
        let tiny = s.diagonal().max() * 1e-8;
        let Ok(s_pinv) = s.pseudo_inverse(tiny) else {
            return;
        };
        let s_inv_ct = &s_pinv * c.transpose();
        normal.gemm(-1.0, &c, &s_inv_ct, 1.0);
        rhs.gemv(-1.0, &c, &(&s_pinv * hc), 1.0);
    };
    let mut rows = Vec::with_capacity(n);
    for (pose, gk) in record.poses.iter().zip(gravity.iter()) {
        rows.clear();
        let (u1, u2) = tilt_basis(&gk.normalize());
        for (i, g) in geo.iter().enumerate() {
            let p = pose.mean[i];
            if !p.is_finite() {
                continue;
            }
            let w = scatter.pose_weight(i, pose.samples.len());
            let k = g.axis * g.scale;
            let j = jacobian(g, gk, &Matrix3::zeros());
            rows.push(DataRow {
                channel: i,
                weight: w,
                jacobian: j,
                residual: p - g.reading(gk),
                field: vec![G0 * k.dot(&u1), G0 * k.dot(&u2)],
            });
        }
        add(&rows, 2, None);
    }
    for (&t, field) in record.motion.iter().zip(fields.iter()) {
        let Some(field) = field else {
            continue;
        };
        rows.clear();
        let m = field.m(&record.gamma);
        for (i, g) in geo.iter().enumerate() {
            let p = record.rows[t][i];
            if !p.is_finite() {
                continue;
            }
            let w = 1.0 / (g.noise * g.noise);
            let k = g.axis * g.scale;
            let rk = g.position.cross(&k);
            let f = field.sigma0 + m * g.position;
            let j = jacobian(g, &f, &m);
            let mut h = vec![k.x, k.y, k.z, rk.x, rk.y, rk.z];
            if with_omega {
                h.extend_from_slice(centripetal_gradient(&k, &g.position, &field.omega).as_slice());
            }
            rows.push(DataRow {
                channel: i,
                weight: w,
                jacobian: j,
                residual: p - g.reading(&f),
                field: h,
            });
        }
        let prior = record.rate_prior.filter(|_| with_omega).map(|p| {
            let (w, weight) = p.at(t);
            (w - field.omega, weight)
        });
        add(&rows, if with_omega { 9 } else { 6 }, prior);
    }
    (normal, rhs)
}

/// One joint Gauss–Newton step and what it says about observability.
#[derive(Clone, Default)]
struct JointStep {
    delta: Vec<f64>,
    sd: Vec<f64>,
    /// Per channel: held directions that are its own.
    held: Vec<Vec<String>>,
    /// Held directions shared by many channels (freedoms of the whole arrangement).
    common: Vec<String>,
    /// The identified directions (columns; tolerance-scaled fitted parameters).
    basis: DMatrix<f64>,
    /// The held directions that are not conventions (their tolerance enters the deviations).
    held_basis: DMatrix<f64>,
    /// The parameters moved (7 per channel).
    fitted: Vec<bool>,
    /// Covariance of the fitted parameters (tolerance-scaled, in their order): the identified
    /// directions' from the data, the held directions' one tolerance.
    cov: DMatrix<f64>,
    /// The gauge directions (columns, tolerance-scaled fitted parameters): held by
    /// convention, so only as good as the nominal geometry (one tolerance).
    gauge_basis: DMatrix<f64>,
}

impl JointStep {
    /// Covariance (tolerance-scaled, all 7 parameters of every channel) of the geometry's
    /// error against the truth: the data's where identified; one tolerance along held
    /// directions, gauges and parameters not fitted (they keep the nominal values, which are
    /// as good as the mounting).
    fn error_covariance(&self, n: usize) -> DMatrix<f64> {
        let idx: Vec<usize> = (0..7 * n).filter(|&p| self.fitted[p]).collect();
        let mut c = DMatrix::identity(7 * n, 7 * n);
        if self.cov.nrows() != idx.len() {
            return c;
        }
        let g = &self.cov + &self.gauge_basis * self.gauge_basis.transpose();
        for (a, &pa) in idx.iter().enumerate() {
            for (b, &pb) in idx.iter().enumerate() {
                c[(pa, pb)] = g[(a, b)];
            }
        }
        c
    }
}

/// The step with the parameters the record does not determine to half their tolerance held
/// at their present values (nominal, when decided at the start) and named: the least
/// determined parameters are set aside until every remaining one is (a parameter can become
/// determined once a correlated one is held).
fn decided_step(
    normal: &DMatrix<f64>,
    rhs: &DVector<f64>,
    n: usize,
    kinds: &[bool; 7],
    tol: &Tolerance,
) -> JointStep {
    let mut fitted: Vec<bool> = (0..7 * n).map(|p| kinds[p % 7]).collect();
    let mut set_aside: Vec<usize> = Vec::new();
    loop {
        let mut step = truncated_step(normal, rhs, n, &fitted, tol, None);
        // Scaled deviation of every fitted parameter (NaN: mostly in a held direction).
        let scaled: Vec<(usize, f64)> = (0..7 * n)
            .filter(|&p| fitted[p])
            .map(|p| {
                let z = step.sd[p] / tol.of(p % 7);
                (p, if z.is_nan() { f64::INFINITY } else { z })
            })
            .filter(|(_, z)| *z > 0.5)
            .collect();
        // A bias is told from the scale only by readings of different size: where a
        // channel's scale or axis is held, its bias (estimated as if they were exact) is
        // held too, rather than reported with a deviation that ignores theirs.
        let dependent: Vec<usize> = (0..n)
            .map(|i| 7 * i + Param::Bias as usize)
            .filter(|&b| {
                fitted[b] && (0..3).any(|j| kinds[j] && !fitted[b - Param::Bias as usize + j])
            })
            .collect();
        if scaled.is_empty() && !dependent.is_empty() {
            for p in dependent {
                fitted[p] = false;
                set_aside.push(p);
            }
            continue;
        }
        if scaled.is_empty() {
            for &p in &set_aside {
                step.held[p / 7].push(PARAMETERS[p % 7].to_string());
            }
            for h in step.held.iter_mut() {
                h.sort();
                h.dedup();
            }
            return step;
        }
        // All the hopeless ones at once, else the least determined one.
        let hopeless: Vec<usize> = scaled
            .iter()
            .filter(|(_, z)| *z > 2.0)
            .map(|(p, _)| *p)
            .collect();
        let drop = if hopeless.is_empty() {
            vec![scaled
                .iter()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(0, |(p, _)| *p)]
        } else {
            hopeless
        };
        for p in drop {
            fitted[p] = false;
            set_aside.push(p);
        }
    }
}

/// The step restricted to the fitted parameters and to the directions the data determine to
/// half the tolerance (eigen-decomposition of the tolerance-scaled normal matrix); the
/// standard deviations of the identified parameters (NaN for a parameter that is mostly in a
/// held direction).
fn truncated_step(
    normal: &DMatrix<f64>,
    rhs: &DVector<f64>,
    n: usize,
    fitted: &[bool],
    tol: &Tolerance,
    frozen: Option<&JointStep>,
) -> JointStep {
    let fitted = frozen.map_or(fitted, |f| &f.fitted[..]);
    let idx: Vec<usize> = (0..7 * n).filter(|&p| fitted[p]).collect();
    let q = idx.len();
    let mut out = JointStep {
        delta: vec![0.0; 7 * n],
        sd: vec![f64::NAN; 7 * n],
        held: vec![Vec::new(); n],
        common: Vec::new(),
        basis: DMatrix::zeros(0, 0),
        held_basis: DMatrix::zeros(0, 0),
        fitted: fitted.to_vec(),
        cov: DMatrix::zeros(0, 0),
        gauge_basis: DMatrix::zeros(0, 0),
    };
    if q == 0 {
        return out;
    }
    let d = DVector::from_iterator(q, idx.iter().map(|&p| tol.of(p % 7)));
    let ns = DMatrix::from_fn(q, q, |a, b| normal[(idx[a], idx[b])] * d[a] * d[b]);
    let bs = DVector::from_fn(q, |a, _| rhs[idx[a]] * d[a]);
    if let Some(f) = frozen {
        // The identified subspace decided before: Gauss–Newton within it.
        let v = &f.basis;
        let nr = v.transpose() * &ns * v;
        let br = v.transpose() * &bs;
        if let Some(chol) = nr.clone().cholesky() {
            let x = v * chol.solve(&br);
            let cov = v * chol.inverse() * v.transpose() + &f.held_basis * f.held_basis.transpose();
            out.held = f.held.clone();
            out.common = f.common.clone();
            out.basis = f.basis.clone();
            out.held_basis = f.held_basis.clone();
            out.gauge_basis = f.gauge_basis.clone();
            for a in 0..q {
                out.delta[idx[a]] = x[a] * d[a];
                if !f.sd[idx[a]].is_nan() {
                    out.sd[idx[a]] = cov[(a, a)].max(0.0).sqrt() * d[a];
                }
            }
            out.cov = cov;
            return out;
        }
    }
    let eig = SymmetricEigen::new(ns);
    if log::log_enabled!(log::Level::Debug) {
        let mut l: Vec<f64> = eig.eigenvalues.iter().copied().collect();
        l.sort_by(f64::total_cmp);
        log::debug!(
            "largest eigenvalue {:.3e}, smallest {:?}",
            l[l.len() - 1],
            l[..l.len().min(10)]
                .iter()
                .map(|v| format!("{v:.2e}"))
                .collect::<Vec<_>>()
        );
    }
    let mut x = DVector::zeros(q);
    let mut var = DVector::<f64>::zeros(q);
    let mut mostly_held = vec![false; q];
    let mut kept = Vec::new();
    let mut held_dirs = Vec::new();
    let mut gauges = Vec::new();
    let mut gauge_share = vec![0.0; q];
    let lambda_max = eig.eigenvalues.max().max(0.0);
    for (e, &lambda) in eig.eigenvalues.iter().enumerate() {
        let v = eig.eigenvectors.column(e);
        // Identified: the data's standard deviation along v is at most half the tolerance.
        if lambda >= 4.0 {
            kept.push(e);
            x += v * (v.dot(&bs) / lambda);
            for a in 0..q {
                var[a] += v[a] * v[a] / lambda;
            }
            continue;
        }
        // A freedom no such record can fix (the data say nothing at all along it: a
        // gauge) is a convention; a direction the record determines, but not to half the
        // tolerance, is held at nominal and its tolerance counted in the deviations.
        if lambda < GAUGE_EIGENVALUE * lambda_max {
            gauges.push(e);
            for a in 0..q {
                gauge_share[a] += v[a] * v[a];
            }
        } else {
            held_dirs.push(e);
            for a in 0..q {
                var[a] += v[a] * v[a];
            }
        }
    }
    // A parameter mostly inside the gauges is not identified at all; one that shares a
    // little of a gauge (each position's part of the common translation) is identified
    // relative to the convention.
    for a in 0..q {
        if gauge_share[a] > HELD_SHARE {
            mostly_held[a] = true;
        }
    }
    if !gauges.is_empty() {
        let mut kinds: Vec<&str> = gauges
            .iter()
            .flat_map(|&e| {
                let v = eig.eigenvectors.column(e);
                (0..q)
                    .filter(move |&a| v[a] * v[a] > 0.01)
                    .map(|a| PARAMETERS[idx[a] % 7])
                    .collect::<Vec<_>>()
            })
            .collect();
        kinds.sort();
        kinds.dedup();
        out.common.push(if kinds.iter().all(|k| k.starts_with("position")) && gauges.len() <= 3 {
            "the common translation of all positions: not observable from accelerometers (σ0 absorbs it); the origin is held where the nominal positions put it".to_string()
        } else {
            format!(
                "{} combinations of {} that this record cannot tell apart (held at nominal: among them the common translation, and without a reference the common rotation and size)",
                gauges.len(),
                kinds.join(", ")
            )
        });
    }
    for a in 0..q {
        out.delta[idx[a]] = x[a] * d[a];
        if !mostly_held[a] {
            out.sd[idx[a]] = var[a].max(0.0).sqrt() * d[a];
        }
    }
    out.basis = eig.eigenvectors.select_columns(kept.iter());
    out.held_basis = eig.eigenvectors.select_columns(held_dirs.iter());
    out.gauge_basis = eig.eigenvectors.select_columns(gauges.iter());
    let inverse = DMatrix::from_diagonal(&DVector::from_iterator(
        kept.len(),
        kept.iter().map(|&e| 1.0 / eig.eigenvalues[e]),
    ));
    out.cov =
        &out.basis * inverse * out.basis.transpose() + &out.held_basis * out.held_basis.transpose();
    out
}

/// Applies a step in [`PARAMETERS`] order.
fn apply(g: &mut Geometry, d: &SVector<f64, 7>) {
    let (u1, u2) = tilt_basis(&g.axis);
    g.scale += d[0];
    g.axis = (g.axis + u1 * d[1] + u2 * d[2]).normalize();
    g.position += Vector3::new(d[3], d[4], d[5]);
    g.bias += d[6];
}

/// What a geometry leaves unexplained in a record (the field re-estimated for it).
#[derive(Clone, Debug, Default)]
pub struct Residuals {
    /// Per channel, the RMS residual (m/s²): motion samples one by one, each pose by its
    /// mean weighted by its samples.
    pub per_channel: Vec<f64>,
    /// Per sample used (its index in the record), the RMS over the channels of the residual
    /// (m/s²); in a pose, of the pose's mean residual (what the noise does not average away).
    pub per_sample: Vec<(usize, f64)>,
}

/// The residuals of every channel with the geometry `geo` ([`Residuals`]).
pub fn residuals(
    geo: &[Geometry],
    record: &Record,
    rate: &RateSource,
) -> Result<Residuals, String> {
    let omega = initial_rates(geo, record, rate)?;
    let fields = motion_fields(geo, record, &omega, omega_unknown(rate, record));
    let gravity = pose_gravity(geo, record.poses, &Scatter::white(geo));
    let n = geo.len();
    let mut sum = vec![0.0; n];
    let mut count = vec![0usize; n];
    let mut per_sample = Vec::new();
    for (pose, gk) in record.poses.iter().zip(gravity.iter()) {
        let res: Vec<f64> = (0..n).map(|i| pose.mean[i] - geo[i].reading(gk)).collect();
        for (i, r) in res.iter().enumerate() {
            if r.is_finite() {
                sum[i] += r * r * pose.samples.len() as f64;
                count[i] += pose.samples.len();
            }
        }
        if let Some(v) = finite_rms(&res) {
            per_sample.extend(pose.samples.clone().map(|k| (k, v)));
        }
    }
    for (&k, field) in record.motion.iter().zip(fields.iter()) {
        let Some(field) = field else {
            continue;
        };
        let m = field.m(&record.gamma);
        let res: Vec<f64> = (0..n)
            .map(|i| {
                let g = &geo[i];
                record.rows[k][i] - field.reading(g, &m)
            })
            .collect();
        for (i, r) in res.iter().enumerate() {
            if r.is_finite() {
                sum[i] += r * r;
                count[i] += 1;
            }
        }
        if let Some(v) = finite_rms(&res) {
            per_sample.push((k, v));
        }
    }
    per_sample.sort_by_key(|(k, _)| *k);
    let per_channel = sum
        .iter()
        .zip(count.iter())
        .map(|(s, &c)| {
            if c > 0 {
                (s / c as f64).sqrt()
            } else {
                f64::NAN
            }
        })
        .collect();
    Ok(Residuals {
        per_channel,
        per_sample,
    })
}

/// The RMS of the finite values of `r` (`None` if there are none).
fn finite_rms(r: &[f64]) -> Option<f64> {
    let (s, c) = r
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, c), v| (s + v * v, c + 1));
    (c > 0).then(|| (s / c as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The joint normal matrix with the field projected out is positive semi-definite (a
    /// Schur complement), to round-off.
    #[test]
    fn the_projected_normal_matrix_is_positive_semidefinite() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut u = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let geo: Vec<Geometry> = (0..12)
            .map(|i| {
                let c = [
                    [1.0, 1.0, 1.0],
                    [1.0, -1.0, -1.0],
                    [-1.0, 1.0, -1.0],
                    [-1.0, -1.0, 1.0],
                ][i / 3];
                let mut axis = Vector3::new(u() * 0.01, u() * 0.01, u() * 0.01);
                axis[i % 3] = 1.0;
                Geometry {
                    position: Vector3::from(c) * 0.1,
                    axis: axis.normalize(),
                    scale: 1.0,
                    bias: 0.0,
                    noise: 1e-3,
                }
            })
            .collect();
        let n_samples = 2000;
        let rows: Vec<Vec<f64>> = (0..n_samples)
            .map(|_| (0..12).map(|_| u() * 10.0).collect())
            .collect();
        let motion: Vec<usize> = (0..n_samples).collect();
        let poses: Vec<Pose> = (0..10)
            .map(|k| Pose {
                samples: k * 300..(k + 1) * 300,
                mean: (0..12).map(|_| u() * 10.0).collect(),
            })
            .collect();
        let gravity: Vec<Vector3<f64>> = (0..10)
            .map(|_| Vector3::new(u(), u(), u()).normalize() * G0)
            .collect();
        let record = Record {
            rows: &rows,
            times: &[],
            poses: &poses,
            motion: &motion,
            gamma: Matrix3::zeros(),
            progress: &|_| {},
            rate_prior: None,
        };
        let fields: Vec<Option<Field>> = (0..n_samples)
            .map(|_| {
                Some(Field {
                    sigma0: Vector3::new(u(), u(), u()) * 20.0,
                    domega: Vector3::new(u(), u(), u()) * 4.0,
                    omega: Vector3::new(u(), u(), u()) * 6.0,
                    omega_var: 0.0,
                })
            })
            .collect();
        for with_omega in [false, true] {
            let (normal, _) = joint_normal_equations(
                &geo,
                &record,
                &fields,
                &gravity,
                with_omega,
                &Scatter::white(&geo),
            );
            let tol = Tolerance::default();
            let d = DVector::from_fn(84, |p, _| tol.of(p % 7));
            let ns = DMatrix::from_fn(84, 84, |a, b| normal[(a, b)] * d[a] * d[b]);
            let e = SymmetricEigen::new(ns).eigenvalues;
            println!(
                "with_omega {with_omega}: eigenvalues {:.3e} .. {:.3e}",
                e.min(),
                e.max()
            );
            assert!(
                e.min() > -1e-9 * e.max(),
                "min {:e} max {:e}",
                e.min(),
                e.max()
            );
        }
    }
}
