//! Identification without a reference (source 2): in a torque-free tumble with the
//! inertia given, the motion is fitted with the geometry.
//!
//! Euler's equations, `J Ω′ = −Ω × J Ω` (no torque), carry the rate at the window's start,
//! `Ω0`, to every later sample; with it the field `L = Γ + {Ω}² + {Ω′}` of every sample is known,
//! and for a given `Ω0` each channel's geometry is the solve over the window's sums
//! ([`identify`], the same as with a reference). So the joint least squares over `Ω0` and the
//! geometry is a search over `Ω0` alone (variable projection). Its cost is the constrained
//! solve's whitened residual `Σ (rmsᵢ / σᵢ)²` where that solve settles, and above every such
//! value the residual of the linear model `p = qᵀ k` (the field's ten numbers without the
//! geometry's constraints) where it does not, so that it is defined at every start. Nelder–Mead,
//! which needs no derivative, runs three rounds of shrinking simplex from each start until one
//! ends at the noise: the `Ω0` whose motion follows the estimator's rates (when the window kept
//! them), the one that follows their negatives, the estimator's first rate and its negative (an
//! estimator on an uncalibrated geometry can hold Ω's sign wrong), each also 20 % of `|Ω0|` off
//! along each axis; in stages over the window's first quarter, half and whole, every start
//! that ends at the noise carried through them. Two that end at motions whose geometries are
//! apart by more than half a tolerance leave the window undecided ([`TumbleError::Ambiguous`]).
//! The geometry is then solved at the rate found, and the rate's uncertainty carried into it.
//! A window that determines fewer than half of the geometry is refused
//! ([`TumbleError::NotExcited`]).
//!
//! Nothing of the frame is left free: the inertia fixes its rotation (its principal axes are in
//! the body frame) and `σ(0) = 0` at the centre of mass its origin. What a torque-free window
//! cannot determine — one combination of tilt, lever arm and bias per channel (energy and
//! angular momentum fix two combinations of the `Ωᵢ²`) — is held and named by the solve, as
//! with a reference.
//!
//! **Never silently wrong.** A search can end in a local minimum (measured: a whole 40 s window
//! of a `tumble_variants` case searched without stages ended 168× the noise off). Then no
//! geometry fits: the solution is refused when any channel's residual exceeds
//! [`RESIDUAL_LIMIT`] times its noise, the limit the commit applies. A window that determines
//! `Ω0` too loosely for the geometry is refused too ([`TumbleError::MotionUncertain`]).
//!
//! The window's sample sets are kept by the caller ([`Sets`]): each evaluation of the cost runs
//! over all of them. They may be means of consecutive sets ([`Sets::averaged`]), as a board
//! keeps a long window.

use super::cholesky::{cholesky, cholesky_solve};
use super::fit::ALWAYS_HELD;
use super::model::{too_few_determined, Param, Tolerance, PARAMS};
use super::result::{ChannelFit, Identified, IdentifyError};
use super::search::{distinct_candidates, nelder_mead, stage_spans, STEPS};
use super::solve::identify;
use super::sums::{field_terms, FieldSums, TERMS};
use crate::arrangement::Arrangement;
use crate::linalg::{Sym3, Vec3};
use crate::real::Real;

/// A channel whose residual RMS exceeds this many times its noise refuses the solution (the
/// commit's limit).
pub const RESIDUAL_LIMIT: f64 = 3.0;

/// Added to the linear cost of a start where the geometry's solve does not settle, so that the
/// search prefers any start where it does.
const UNSOLVED: f64 = 1e12;

/// The window's sample sets, oldest first.
pub trait Sets {
    /// Calls `f(t, p)` for every set: `t` in seconds, `p` one reading per channel (m/s²,
    /// non-finite where the channel was not read).
    fn for_each(&self, f: &mut dyn FnMut(f64, &[f64]));

    /// Calls `f(t, Ω)` with the estimator's rate at every set, if the window kept it: the
    /// search then starts from the start rate whose motion follows those rates best over the
    /// whole window, not from the first set's alone.
    fn rates(&self, f: &mut dyn FnMut(f64, &Vec3<f64>)) {
        let _ = f;
    }

    /// How many consecutive sample sets each set is the mean of (1: raw sets). Its noise is
    /// then the channel's over the square root of that: a board that cannot keep every set of
    /// a long window keeps their means, which lose almost nothing of its information
    /// (measured on `orbit-identify`'s tumble: means of 4 sets give the raw sets' geometry
    /// within a tenth of a tolerance and their deviations within 25 %).
    fn averaged(&self) -> u32 {
        1
    }
}

/// What the tumble tells of the body: its inertia and the gravity gradient.
#[derive(Clone, Copy, Debug)]
pub struct Body {
    /// Inertia tensor in the body frame (kg m², or any unit: only ratios matter).
    pub inertia: Sym3<f64>,
    /// Gravity gradient Γ, s⁻² (zero in a free-flight window far from a body).
    pub gamma: Sym3<f64>,
}

/// The joint solution.
#[derive(Clone, Debug)]
pub struct TumbleFit<const CAP: usize> {
    /// The geometry.
    pub identified: Identified<CAP>,
    /// The rate at the window's first set, rad/s.
    pub omega0: Vec3<f64>,
    /// Its standard deviations (from the cost's curvature; carried into every parameter's).
    pub omega0_sd: Vec3<f64>,
    /// The whitened cost `Σ (rmsᵢ / σᵢ)²` (about the number of channels when the fit is right).
    pub cost: f64,
    /// Cost evaluations the search took (each a pass over the window).
    pub evaluations: u32,
}

/// Why a tumble gives no solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TumbleError {
    /// The inertia is not positive definite (or not finite).
    Inertia,
    /// The solve failed at the best rate found.
    Identify(IdentifyError),
    /// The best rate found leaves a channel's residual above [`RESIDUAL_LIMIT`] times its noise:
    /// the window does not determine the motion from that start (too short, or the start too
    /// far off).
    NotDetermined {
        /// The channel with the largest whitened residual.
        channel: usize,
        /// Its residual RMS over its noise.
        ratio: f64,
    },
    /// Two start rates both explain the window at the noise, with geometries apart by more
    /// than half a tolerance in a parameter both determine: the window does not decide
    /// between them (a longer window, or another motion).
    Ambiguous {
        /// The two rates at the window's first set, rad/s (the cheaper first).
        omega0: [Vec3<f64>; 2],
    },
    /// The window determines the start rate too loosely: its uncertainty moves a parameter
    /// the window determined by more than half its tolerance (or the cost has no minimum in
    /// some direction: `ratio` infinite).
    MotionUncertain {
        /// The channel.
        channel: usize,
        /// The parameter.
        param: Param,
        /// Its deviation from the start rate's uncertainty over its tolerance.
        ratio: f64,
    },
    /// The window determined fewer than half of the parameters the tumble can
    /// ([`super::model::too_few_determined`]; the scale is never one): the geometry would be
    /// the nominal one with another name.
    NotExcited {
        /// The channel with the most parameters held.
        channel: usize,
        /// The first of them.
        param: Param,
    },
}

/// Euler's equations without torque: `Ω′ = J⁻¹ (J Ω × Ω)`.
fn euler(j: &Sym3<f64>, j_inv: &Sym3<f64>, w: &Vec3<f64>) -> Vec3<f64> {
    let h = j.mul_vec(w);
    let c = [
        h[1] * w[2] - h[2] * w[1],
        h[2] * w[0] - h[0] * w[2],
        h[0] * w[1] - h[1] * w[0],
    ];
    j_inv.mul_vec(&c)
}

/// One classical Runge–Kutta step of Euler's equations.
fn rk4(j: &Sym3<f64>, j_inv: &Sym3<f64>, w: &Vec3<f64>, h: f64) -> Vec3<f64> {
    let at = |k: &Vec3<f64>, s: f64| [w[0] + s * k[0], w[1] + s * k[1], w[2] + s * k[2]];
    let k1 = euler(j, j_inv, w);
    let k2 = euler(j, j_inv, &at(&k1, h / 2.0));
    let k3 = euler(j, j_inv, &at(&k2, h / 2.0));
    let k4 = euler(j, j_inv, &at(&k3, h));
    core::array::from_fn(|i| w[i] + h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]))
}

/// The problem: the window, the body and the nominal geometry.
struct Problem<'a, S: ?Sized, const CAP: usize> {
    sets: &'a S,
    /// The sets used: those within this many seconds of the first (the search's stages).
    span: core::cell::Cell<f64>,
    j: Sym3<f64>,
    j_inv: Sym3<f64>,
    gamma: Sym3<f64>,
    nominal: &'a Arrangement<CAP>,
    tolerance: &'a Tolerance,
}

impl<S: Sets + ?Sized, const CAP: usize> Problem<'_, S, CAP> {
    /// The window's sums for a start rate.
    fn sums(&self, w0: &Vec3<f64>) -> FieldSums<CAP> {
        let mut sums = FieldSums::<CAP>::new();
        sums.clear(self.nominal.len());
        let mut w = *w0;
        let (mut first, mut last) = (None::<f64>, None::<f64>);
        let span = self.span.get();
        self.sets.for_each(&mut |t, p| {
            let t_first = *first.get_or_insert(t);
            if t - t_first > span {
                return;
            }
            if let Some(t0) = last {
                let h = t - t0;
                if h > 0.0 {
                    w = rk4(&self.j, &self.j_inv, &w, h);
                }
            }
            last = Some(t);
            let dw = euler(&self.j, &self.j_inv, &w);
            sums.add(&field_terms(&w, &dw, &self.gamma), p);
        });
        sums
    }

    /// The geometry for a start rate, and its whitened cost.
    fn solve(&self, w0: &Vec3<f64>) -> Result<(f64, Identified<CAP>), IdentifyError> {
        self.geometry(&self.sums(w0))
    }

    /// The geometry from a start rate's sums, and its whitened cost.
    fn geometry(&self, sums: &FieldSums<CAP>) -> Result<(f64, Identified<CAP>), IdentifyError> {
        let id = identify(sums, self.nominal, self.tolerance)?;
        let cost = id
            .channels()
            .iter()
            .zip(self.nominal.channels())
            .map(|(f, c)| {
                let r = f.residual_rms / c.noise;
                r * r
            })
            .sum();
        Ok((cost, id))
    }

    /// The cost for the search: the whitened residual of each channel's linear least squares
    /// in the field's ten numbers, `Σ p² − gᵀ G⁻¹ g` over the sets and the channel's noise²
    /// (the model `p = qᵀ k` without its constraints: a unit axis, a scale). Unlike the
    /// channels' Gauss–Newton it is defined at every start, so the search is not stranded where
    /// no geometry fits (measured: from the estimator's rate at 15 s or 35 s of the
    /// `orbit-identify` tumble every vertex of the first simplex failed the full solve). `G` is
    /// singular in a torque-free tumble (energy and angular momentum tie the `Ωᵢ²` to the
    /// constant), so it carries a ridge of 10⁻⁹ of its largest diagonal term; `g` has nothing
    /// along those directions, so the residual is unchanged.
    fn cost(&self, w0: &Vec3<f64>, evaluations: &mut u32) -> f64 {
        *evaluations += 1;
        let sums = self.sums(w0);
        if let Ok((c, _)) = self.geometry(&sums) {
            return c;
        }
        let mut l = sums.gram();
        let top = (0..TERMS).map(|i| l[i][i]).fold(0.0f64, f64::max);
        for (i, row) in l.iter_mut().enumerate() {
            row[i] += 1e-9 * top;
        }
        if !cholesky(&mut l, TERMS) {
            return f64::INFINITY;
        }
        let sets = f64::from(sums.sets());
        let mut cost = 0.0;
        for (i, c) in self.nominal.channels().iter().enumerate() {
            let (g, sq) = sums.channel(i);
            let x = cholesky_solve(&l, TERMS, &g);
            let fit: f64 = g.iter().zip(x.iter()).map(|(a, b)| a * b).sum();
            cost += (sq - fit).max(0.0) / (sets * c.noise * c.noise);
        }
        if cost.is_finite() {
            UNSOLVED + cost
        } else {
            f64::INFINITY
        }
    }
}

/// Fits the rate at the window's start and every channel's geometry to a torque-free tumble
/// (see the module documentation), starting from `omega0` (the estimator's rate at the first
/// set, with the geometry in use).
pub fn identify_tumble<S: Sets + ?Sized, const CAP: usize>(
    sets: &S,
    body: &Body,
    omega0: &Vec3<f64>,
    nominal: &Arrangement<CAP>,
    tolerance: &Tolerance,
) -> Result<TumbleFit<CAP>, TumbleError> {
    let j = body.inertia;
    // Positive definite: the leading minors (Sylvester), all finite.
    let [xx, yy, _, xy, _, _] = j.0;
    let definite =
        j.0.iter().all(|v| v.is_finite()) && xx > 0.0 && xx * yy - xy * xy > 0.0 && j.det() > 0.0;
    let j_inv = match j.inverse(0.0) {
        Some(inv) if definite => inv,
        _ => return Err(TumbleError::Inertia),
    };
    // Means of `averaged` sets: their noise, and the deviations reported as of one sample set.
    let averaged = f64::from(sets.averaged().max(1));
    let scaled;
    let nominal = if averaged > 1.0 {
        scaled = nominal.with_noise_scaled(1.0 / Real::sqrt(averaged));
        &scaled
    } else {
        nominal
    };
    let problem = Problem {
        sets,
        span: core::cell::Cell::new(f64::INFINITY),
        j,
        j_inv,
        gamma: body.gamma,
        nominal,
        tolerance,
    };
    let mut evaluations = 0u32;
    let scale = Real::sqrt(omega0.iter().map(|v| v * v).sum::<f64>()).max(1e-3);
    // The starts: the motions that follow the estimator's rates over the window and their
    // negatives, the first rate and its negative. The centripetal terms do not see Ω's sign,
    // and an estimator on an uncalibrated geometry can hold the wrong one (measured: on 12
    // drawn tumbles the estimator's first rate had the wrong sign in 6; with these four starts
    // 6 of the 12 are identified at 0.98–1.04 × ideal parts, with the first alone 3).
    let starts = starts(&problem, omega0, scale);
    let mut best = starts[0];
    // The search from those starts and, unless one ends at the noise, from six more each, 20 % of |Ω0|
    // off along each axis (measured: from the estimator's rates at 15 s and at 35 s of the
    // `orbit-identify` tumble, 0.50 and 0.34 rad/s off, the first search ended in a local
    // minimum where no geometry fits); the cheapest end wins.
    //
    // In stages (a continuation): the window's first quarter, half, then all of it, each stage
    // starting where the last ended — an error in Ω0 grows along the tumble, so the longer the
    // window the more rugged the cost (measured: a 40 s window of one `tumble_variants` case,
    // searched whole, ended 168× the noise off; 20 s found it). No stage is shorter than
    // [`MIN_STAGE_S`].
    let (spans, stages) = stage_spans(sets);
    // A fit at the noise: whitened cost within twice the channel count.
    let at_noise = 2.0 * nominal.len() as f64;
    let search = |x: Vec3<f64>, evaluations: &mut u32| {
        let mut x = x;
        for step in STEPS {
            x = nelder_mead(&mut |w| problem.cost(w, evaluations), x, step * scale);
        }
        (x, problem.cost(&x, evaluations))
    };
    // From `first` and, until one ends at the noise, `offsets` of its six offsets, 20 % of
    // |Ω0| off along each axis: the cheapest end.
    let from = |first: &Vec3<f64>, offsets: usize, evaluations: &mut u32| {
        let mut end = (*first, f64::INFINITY);
        for s in 0..=offsets {
            let mut x = *first;
            if s > 0 {
                x[(s - 1) / 2] += if s % 2 == 1 { 0.2 } else { -0.2 } * scale;
            }
            let (x, c) = search(x, evaluations);
            if c < end.1 {
                end = (x, c);
            }
            if c <= at_noise {
                break;
            }
        }
        end
    };
    // The first stage from every start, in order, each with its offsets until one ends at
    // the noise — once one has, the later starts from themselves alone (to find a second
    // motion that explains the window, below). Each start's cheapest end is a candidate.
    problem.span.set(spans[0]);
    let mut candidates = [(best, f64::INFINITY); 4];
    for (first, i) in starts.iter().zip(0..) {
        let found = candidates[..i].iter().any(|c| c.1 <= at_noise);
        candidates[i] = from(first, if found { 0 } else { 6 }, &mut evaluations);
    }
    // Ω and −Ω give the same field (Euler's equations and the centripetal terms are even in
    // Ω): one candidate of each such pair, and of ends closer than 1 % of |Ω0|.
    let same = |a: &Vec3<f64>, b: &Vec3<f64>| {
        let d = |sign: f64| {
            (0..3)
                .map(|k| (a[k] - sign * b[k]) * (a[k] - sign * b[k]))
                .sum::<f64>()
        };
        Real::sqrt(d(1.0).min(d(-1.0))) < 0.01 * scale
    };
    let kept = distinct_candidates(&mut candidates, &same, at_noise, best);
    // The later stages from each candidate's end.
    for span in spans.iter().take(stages).skip(1) {
        problem.span.set(*span);
        for candidate in candidates[..kept].iter_mut() {
            *candidate = from(&candidate.0, 6, &mut evaluations);
        }
    }
    let (mut best_cost, mut best_at) = (f64::INFINITY, 0);
    for (i, c) in candidates[..kept].iter().enumerate() {
        if c.1 < best_cost {
            (best_cost, best_at) = (c.1, i);
        }
    }
    best = candidates[best_at].0;
    // Never silently wrong: two motions that both explain the window at the noise with
    // geometries apart by more than half a tolerance in a parameter both determine — the rule
    // that holds a parameter — leave the geometry undecided (measured: a drawn tumble kept as
    // means of 4 sets had its first start end at a rate whose geometry was 56 mm off, at the
    // noise, Ω then 45 × ideal; another start ended near the true one).
    let (cost, identified) = problem.solve(&best).map_err(TumbleError::Identify)?;
    evaluations += 1;
    let others = candidates[..kept]
        .iter()
        .filter(|c| c.1 <= at_noise && !same(&c.0, &best));
    for other in others {
        evaluations += 1;
        let (_, b) = problem.solve(&other.0).map_err(TumbleError::Identify)?;
        if apart(&identified, &b, tolerance) {
            return Err(TumbleError::Ambiguous {
                omega0: [best, other.0],
            });
        }
    }
    check_determined(&identified, nominal)?;
    let mut identified = identified;
    let omega0_sd =
        carry_start_uncertainty(&problem, &best, scale, &mut identified, &mut evaluations)?;
    identified.scale_noise(Real::sqrt(averaged));
    Ok(TumbleFit {
        identified,
        omega0: best,
        omega0_sd,
        cost,
        evaluations,
    })
}

/// The searches' starts: the motions that follow the estimator's rates over the window and
/// their negatives, the first rate `omega0` and its negative (`scale`: |Ω0|).
fn starts<S: Sets + ?Sized, const CAP: usize>(
    problem: &Problem<'_, S, CAP>,
    omega0: &Vec3<f64>,
    scale: f64,
) -> [Vec3<f64>; 4] {
    let follow = |w0: &Vec3<f64>, sign: f64| {
        let (mut w, mut last, mut sum) = (*w0, None::<f64>, 0.0);
        problem.sets.rates(&mut |t, r| {
            if let Some(t0) = last {
                if t > t0 {
                    w = rk4(&problem.j, &problem.j_inv, &w, t - t0);
                }
            }
            last = Some(t);
            sum += (0..3)
                .map(|k| (w[k] - sign * r[k]) * (w[k] - sign * r[k]))
                .sum::<f64>();
        });
        if sum.is_finite() {
            sum
        } else {
            f64::INFINITY
        }
    };
    let followed = [1.0, -1.0].map(|sign| {
        let mut x = omega0.map(|v| sign * v);
        if follow(&x, sign) > 0.0 {
            for step in STEPS {
                x = nelder_mead(&mut |w| follow(w, sign), x, step * scale);
            }
        }
        x
    });
    [followed[0], followed[1], *omega0, omega0.map(|v| -v)]
}

/// Whether two identifications' geometries are apart by more than half a tolerance in a
/// parameter both determine (the rule that holds a parameter).
fn apart<const CAP: usize>(
    a: &Identified<CAP>,
    b: &Identified<CAP>,
    tolerance: &Tolerance,
) -> bool {
    a.channels().iter().zip(b.channels()).any(|(fa, fb)| {
        let d = difference(fa, fb);
        Param::ALL
            .iter()
            .enumerate()
            .any(|(k, p)| !fa.is_held(*p) && !fb.is_held(*p) && !(d[k] <= 0.5 * tolerance.of(k)))
    })
}

/// Refuses an identification whose worst channel's residual is beyond [`RESIDUAL_LIMIT`]
/// times its noise, or that determines too few of the parameters asked for (naming the
/// channel that holds the most, and a parameter it holds).
fn check_determined<const CAP: usize>(
    identified: &super::result::Identified<CAP>,
    nominal: &Arrangement<CAP>,
) -> Result<(), TumbleError> {
    let worst = identified
        .channels()
        .iter()
        .zip(nominal.channels())
        .map(|(f, c)| f.residual_rms / c.noise)
        .enumerate()
        .fold((0, 0.0), |acc, (i, r)| if r > acc.1 { (i, r) } else { acc });
    if !(worst.1 <= RESIDUAL_LIMIT) {
        return Err(TumbleError::NotDetermined {
            channel: worst.0,
            ratio: worst.1,
        });
    }
    let asked = identified.channels().len() * (PARAMS - ALWAYS_HELD.count_ones() as usize);
    let held = |f: &super::result::ChannelFit| (f.held & !ALWAYS_HELD).count_ones() as usize;
    let determined = asked - identified.channels().iter().map(held).sum::<usize>();
    if too_few_determined(determined, asked) {
        let (channel, fit) = identified
            .channels()
            .iter()
            .enumerate()
            .max_by_key(|(_, f)| held(f))
            .ok_or(TumbleError::Identify(IdentifyError::TooFewSets { have: 0 }))?;
        let param = Param::ALL
            .into_iter()
            .find(|p| *p != Param::Scale && fit.is_held(*p))
            .unwrap_or(Param::Scale);
        return Err(TumbleError::NotExcited { channel, param });
    }
    Ok(())
}

/// The start rate's uncertainty, carried into every parameter's deviation: its covariance
/// from the cost's curvature (`χ² = sets · cost`, `C = 2 (∂²χ²)⁻¹`, by central differences),
/// then each parameter's spread over `Ω0 ± ` each column of `C`'s Cholesky factor, added in
/// quadrature. Refused ([`TumbleError::MotionUncertain`]) where that spread exceeds half the
/// parameter's tolerance on a parameter the window determined — the rule that holds a
/// parameter — since the estimate would then rest on a geometry the window does not fix
/// (measured: a 5 s window of the `orbit-identify` tumble, accepted without this, left 36 % of
/// the rows silently wrong). Returns the start rate's deviations.
fn carry_start_uncertainty<S: Sets + ?Sized, const CAP: usize>(
    problem: &Problem<'_, S, CAP>,
    x: &Vec3<f64>,
    scale: f64,
    id: &mut Identified<CAP>,
    evaluations: &mut u32,
) -> Result<Vec3<f64>, TumbleError> {
    let uncertain = |ratio: f64| TumbleError::MotionUncertain {
        channel: 0,
        param: Param::Scale,
        ratio,
    };
    let h = 1e-4 * scale;
    let mut f = |d: [f64; 3]| -> Result<f64, TumbleError> {
        *evaluations += 1;
        let at = [x[0] + d[0], x[1] + d[1], x[2] + d[2]];
        problem
            .solve(&at)
            .map(|(c, _)| c)
            .map_err(TumbleError::Identify)
    };
    let f0 = f([0.0; 3])?;
    let e = |i: usize, s: f64| -> [f64; 3] {
        core::array::from_fn(|k| if k == i { s * h } else { 0.0 })
    };
    let mut hess = [[0.0; 3]; 3];
    for i in 0..3 {
        hess[i][i] = (f(e(i, 1.0))? - 2.0 * f0 + f(e(i, -1.0))?) / (h * h);
        for j in 0..i {
            let pp: [f64; 3] = core::array::from_fn(|k| e(i, 1.0)[k] + e(j, 1.0)[k]);
            let pm: [f64; 3] = core::array::from_fn(|k| e(i, 1.0)[k] + e(j, -1.0)[k]);
            let mp: [f64; 3] = core::array::from_fn(|k| e(i, -1.0)[k] + e(j, 1.0)[k]);
            let mm: [f64; 3] = core::array::from_fn(|k| e(i, -1.0)[k] + e(j, -1.0)[k]);
            let v = (f(pp)? - f(pm)? - f(mp)? + f(mm)?) / (4.0 * h * h);
            hess[i][j] = v;
            hess[j][i] = v;
        }
    }
    let sets = f64::from(id.sets);
    let curvature = Sym3([
        sets * hess[0][0],
        sets * hess[1][1],
        sets * hess[2][2],
        sets * hess[0][1],
        sets * hess[0][2],
        sets * hess[1][2],
    ]);
    // C = 2 (∂²χ²)⁻¹; its Cholesky factor's columns are the directions carried.
    let mut c = match curvature.inverse(0.0) {
        Some(inv) if curvature.0[0] > 0.0 && curvature.det() > 0.0 => {
            let m = inv.0.map(|v| 2.0 * v);
            [[m[0], m[3], m[4]], [m[3], m[1], m[5]], [m[4], m[5], m[2]]]
        }
        _ => return Err(uncertain(f64::INFINITY)),
    };
    let sd0 = [
        Real::sqrt(c[0][0].max(0.0)),
        Real::sqrt(c[1][1].max(0.0)),
        Real::sqrt(c[2][2].max(0.0)),
    ];
    if !cholesky(&mut c, 3) {
        return Err(uncertain(f64::INFINITY));
    }
    let n = id.len;
    let mut var = [[0.0; crate::identify::PARAMS]; CAP];
    for j in 0..3 {
        let d: [f64; 3] = core::array::from_fn(|k| if k >= j { c[k][j] } else { 0.0 });
        let plus = [x[0] + d[0], x[1] + d[1], x[2] + d[2]];
        let minus = [x[0] - d[0], x[1] - d[1], x[2] - d[2]];
        *evaluations += 2;
        let (_, a) = problem.solve(&plus).map_err(TumbleError::Identify)?;
        let (_, b) = problem.solve(&minus).map_err(TumbleError::Identify)?;
        for (ch, (fa, fb)) in a.fits[..n].iter().zip(b.fits[..n].iter()).enumerate() {
            let d = difference(fa, fb);
            for (v, s) in var[ch].iter_mut().zip(d) {
                *v += s * s / 4.0;
            }
        }
    }
    let tol = problem.tolerance;
    for (ch, fit) in id.fits[..n].iter_mut().enumerate() {
        for (k, p) in Param::ALL.iter().enumerate() {
            let limit = tol.of(k);
            let spread = Real::sqrt(var[ch][k]);
            if !fit.is_held(*p) && !(spread <= 0.5 * limit) {
                return Err(TumbleError::MotionUncertain {
                    channel: ch,
                    param: *p,
                    ratio: spread / limit,
                });
            }
            // A held parameter stays at the value in use, its deviation its tolerance: the
            // spread of the start rate's solutions is the free parameters' (two solutions that
            // hold differently would otherwise lift it above the tolerance).
            if !fit.is_held(*p) {
                fit.sd[k] = Real::sqrt(fit.sd[k] * fit.sd[k] + var[ch][k]);
            }
        }
    }
    Ok(sd0)
}

/// How far apart two solutions of a channel are, per parameter ([`Param`] order; the tilt's
/// both components the axes' angle).
fn difference(a: &ChannelFit, b: &ChannelFit) -> [f64; PARAMS] {
    let (ca, cb) = (&a.channel, &b.channel);
    let tilt = Real::sqrt(
        (0..3)
            .map(|k| (ca.axis[k] - cb.axis[k]) * (ca.axis[k] - cb.axis[k]))
            .sum::<f64>(),
    );
    let d = |u: f64, v: f64| (u - v).abs();
    [
        d(ca.scale, cb.scale),
        tilt,
        tilt,
        d(ca.position[0], cb.position[0]),
        d(ca.position[1], cb.position[1]),
        d(ca.position[2], cb.position[2]),
        d(ca.bias, cb.bias),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nelder_mead_finds_a_quadratic_minimum_and_steps_over_infinities() {
        let mut f = |x: &Vec3<f64>| {
            if x[0] > 2.5 {
                return f64::INFINITY;
            }
            (x[0] - 1.0).powi(2) + 2.0 * (x[1] + 0.5).powi(2) + 3.0 * (x[2] - 0.25).powi(2)
        };
        let x = nelder_mead(&mut f, [2.0, 0.0, 0.0], 0.6);
        for (v, t) in x.iter().zip([1.0, -0.5, 0.25]) {
            assert!((v - t).abs() < 1e-6, "{x:?}");
        }
    }

    #[test]
    fn euler_keeps_energy_and_angular_momentum() {
        let j = Sym3([1.0, 1.8, 2.5, 0.1, 0.0, -0.05]);
        let j_inv = j.inverse(1e-12).unwrap();
        let mut w = [1.1, -0.7, 0.4];
        let inv = |w: &Vec3<f64>| {
            let h = j.mul_vec(w);
            (
                h.iter().zip(w).map(|(a, b)| a * b).sum::<f64>(),
                h.iter().map(|a| a * a).sum::<f64>(),
            )
        };
        let (e0, m0) = inv(&w);
        for _ in 0..2000 {
            w = rk4(&j, &j_inv, &w, 0.01);
        }
        let (e1, m1) = inv(&w);
        assert!((e1 - e0).abs() < 1e-9 * e0 && (m1 - m0).abs() < 1e-9 * m0);
    }
}
