//! The solve: each channel's seven parameters by Gauss–Newton over the sums, what the window
//! did not excite held and named, the centre of mass from the positions.

use super::sums::{FieldSums, TERMS};
use crate::arrangement::{Arrangement, Channel};
use crate::error::ConfigError;
use crate::frame_uncertainty::FrameUncertainty;
use crate::linalg::{cross, norm2, Vec3};
use crate::real::Real;

/// Parameters per channel.
pub const PARAMS: usize = 7;

/// A channel's parameters, in the order of [`ChannelFit::sd`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Param {
    /// Scale factor.
    Scale,
    /// Axis tilt towards the first direction perpendicular to the axis (rad).
    TiltA,
    /// Axis tilt towards the second (rad).
    TiltB,
    /// Position, x (m).
    PositionX,
    /// Position, y (m).
    PositionY,
    /// Position, z (m).
    PositionZ,
    /// Bias (m/s²).
    Bias,
}

impl Param {
    /// All, in order.
    pub const ALL: [Param; PARAMS] = [
        Param::Scale,
        Param::TiltA,
        Param::TiltB,
        Param::PositionX,
        Param::PositionY,
        Param::PositionZ,
        Param::Bias,
    ];

    /// Its bit in [`ChannelFit::held`].
    pub const fn bit(self) -> u8 {
        1 << self as u8
    }

    /// Its name in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Param::Scale => "scale",
            Param::TiltA => "tilt a",
            Param::TiltB => "tilt b",
            Param::PositionX => "position x",
            Param::PositionY => "position y",
            Param::PositionZ => "position z",
            Param::Bias => "bias",
        }
    }
}

/// How far from nominal each parameter may be (the parts' datasheet and the mounting): a
/// parameter the window determines to worse than half of it is held at nominal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Scale factor (relative).
    pub scale: f64,
    /// Axis tilt, rad.
    pub axis: f64,
    /// Position, m.
    pub position: f64,
    /// Bias, m/s².
    pub bias: f64,
}

impl Tolerance {
    /// The host calibration's tolerances (`ballisto calibrate`): scale 0.02, axis 10 mrad,
    /// position 1 mm, bias 0.5 m/s² (an ADXL355's ±25 mg offset is 0.25 m/s²).
    pub const DATASHEET: Tolerance = Tolerance {
        scale: 0.02,
        axis: 0.01,
        position: 1e-3,
        bias: 0.5,
    };

    #[inline]
    fn of(&self, p: usize) -> f64 {
        match p {
            0 => self.scale,
            1 | 2 => self.axis,
            6 => self.bias,
            _ => self.position,
        }
    }
}

/// One channel's identified parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChannelFit {
    /// The identified channel: position (from the instrument origin), axis, bias and scale;
    /// its noise is the nominal one.
    pub channel: Channel,
    /// Standard deviation per parameter ([`Param`] order); a held parameter's is its
    /// tolerance (it is only as good as the drawing).
    pub sd: [f64; PARAMS],
    /// Parameters the window did not determine to half their tolerance, held at nominal
    /// (bit [`Param::bit`]).
    pub held: u8,
    /// RMS of the channel's residual over the window, m/s².
    pub residual_rms: f64,
}

impl ChannelFit {
    /// Whether `p` was held at nominal.
    pub fn is_held(&self, p: Param) -> bool {
        self.held & p.bit() != 0
    }
}

/// Why there is no identification.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IdentifyError {
    /// The sums are for another number of channels than the arrangement.
    ChannelCount {
        /// Channels in the sums.
        sums: usize,
        /// Channels in the arrangement.
        arrangement: usize,
    },
    /// Fewer sample sets than a channel has parameters, plus one.
    TooFewSets {
        /// Sets in the window.
        have: u32,
    },
    /// A channel's Gauss–Newton did not settle (its last step still moved a parameter by
    /// more than 10⁻⁴ of its tolerance).
    NotConverged {
        /// The channel.
        channel: usize,
    },
}

/// The identification of every channel, and the centre of mass.
#[derive(Clone, Debug)]
pub struct Identified<const CAP: usize> {
    fits: [ChannelFit; CAP],
    len: usize,
    /// The centre of mass from the instrument origin (m, paper §8), with the positions'
    /// common translation held by convention (their mean mounting error is zero).
    pub centre_of_mass: Vec3<f64>,
    /// Its standard deviation per axis (the convention's included).
    pub centre_of_mass_sd: Vec3<f64>,
    /// Sample sets in the window.
    pub sets: u32,
    /// The tolerances the hold decisions used.
    pub tolerance: Tolerance,
}

impl<const CAP: usize> Identified<CAP> {
    /// Every channel's fit, in arrangement order.
    pub fn channels(&self) -> &[ChannelFit] {
        &self.fits[..self.len]
    }

    /// How well the frame of the identified geometry is tied to the body. The channels'
    /// errors are independent (each has its own normal equations), so the common ones are
    /// their means: the translation is the convention's (`tolerance / √n` of the free
    /// position components per axis, the largest) and that of the held scales (a scale off by
    /// `δ` moves its channel's lever arm from the centre of mass by `δ (R − ρ)`: their mean is
    /// a translation, `tolerance · rms|R − ρ| / √(3n)` per axis), the rotation the mean of
    /// the axis tilts, the size the mean of the relative position errors; the rotation of the
    /// axes against the lever arms is taken as the rotation (the reference ties both).
    #[inline]
    pub fn frame_uncertainty(&self) -> FrameUncertainty<f64> {
        let (mut tilt, mut nt, mut size, mut ns) = (0.0, 0.0, 0.0, 0.0);
        let mut free_axis = [0.0f64; 3];
        let mut scale_shift = 0.0;
        let n = self.len as f64;
        for f in self.channels() {
            for k in [1, 2] {
                if f.held & (1 << k) == 0 {
                    tilt += f.sd[k] * f.sd[k];
                    nt += 1.0;
                }
            }
            if f.is_held(Param::Scale) {
                let arm: Vec3<f64> =
                    core::array::from_fn(|l| f.channel.position[l] - self.centre_of_mass[l]);
                scale_shift += self.tolerance.scale * self.tolerance.scale * norm2(&arm) / 3.0;
            }
            let r2 = norm2(&f.channel.position);
            for (l, n) in free_axis.iter_mut().enumerate() {
                if f.held & (1 << (3 + l)) == 0 {
                    *n += 1.0;
                    if r2 > 0.0 {
                        size += f.sd[3 + l] * f.sd[3 + l] / r2;
                        ns += 1.0;
                    }
                }
            }
        }
        let pos = self.tolerance.position;
        let convention = free_axis
            .iter()
            .map(|n| if *n > 0.0 { pos / Real::sqrt(*n) } else { pos })
            .fold(0.0f64, f64::max);
        let translation = Real::sqrt(convention * convention + scale_shift / (n * n).max(1.0));
        let rotation = if nt > 0.0 {
            Real::sqrt(tilt / nt / nt)
        } else {
            self.tolerance.axis
        };
        let size = if ns > 0.0 {
            Real::sqrt(size / ns / ns)
        } else {
            0.0
        };
        FrameUncertainty {
            rotation,
            translation,
            size,
            relative_rotation: rotation,
        }
    }

    /// The calibrated arrangement: every channel as identified, with the frame's uncertainty.
    ///
    /// Errors: the estimator-core checks (an identified scale outside (0.5, 2) is refused by
    /// channel).
    #[inline]
    pub fn arrangement(&self) -> Result<Arrangement<CAP>, ConfigError> {
        let mut a = Arrangement::new();
        for f in self.channels() {
            let c = &f.channel;
            let i = a.push(c.position, c.axis, c.noise)?;
            a.set_calibration(i, c.bias, c.scale)?;
        }
        a.set_frame_uncertainty(self.frame_uncertainty())?;
        Ok(a)
    }
}

// Every function of the solve is `#[inline]`: its code is then generated in the crate that
// calls it, at that crate's optimisation level — the firmware's application, built for size —
// and not at estimator-core's speed level (`3` in the flight profile), where `normal` alone
// unrolled to 4.7 KB of the flight image. The solve runs once per telecommand.

/// Identifies every channel of `nominal` from the sums of a window (paper §6; see the module
/// documentation): two passes, the second with the positions' nominal values moved to the
/// centre of mass the first found.
#[inline(never)]
pub fn identify<const CAP: usize>(
    sums: &FieldSums<CAP>,
    nominal: &Arrangement<CAP>,
    tolerance: &Tolerance,
) -> Result<Identified<CAP>, IdentifyError> {
    let n = nominal.len();
    if sums.channels() != n {
        return Err(IdentifyError::ChannelCount {
            sums: sums.channels(),
            arrangement: n,
        });
    }
    if (sums.sets() as usize) <= PARAMS {
        return Err(IdentifyError::TooFewSets { have: sums.sets() });
    }
    let gram = sums.gram();
    let mut out = Identified {
        fits: [ChannelFit::default(); CAP],
        len: n,
        centre_of_mass: [0.0; 3],
        centre_of_mass_sd: [tolerance.position; 3],
        sets: sums.sets(),
        tolerance: *tolerance,
    };
    for _pass in 0..2 {
        let rho = out.centre_of_mass;
        for (i, ch) in nominal.channels().iter().enumerate() {
            let (g, sq) = sums.channel(i);
            let problem = Problem {
                gram: &gram,
                cross: &g,
                square: sq,
                sets: f64::from(sums.sets()),
                tolerance,
            };
            let position = [
                ch.position[0] - rho[0],
                ch.position[1] - rho[1],
                ch.position[2] - rho[2],
            ];
            let start = State::new(ch.scale, ch.axis, position, ch.bias);
            out.fits[i] = problem
                .fit(start, ch.noise)
                .ok_or(IdentifyError::NotConverged { channel: i })?;
        }
        // The centre of mass: the positions' mean offset from nominal, weighted per axis.
        for l in 0..3 {
            let (mut sw, mut swx, mut k) = (0.0, 0.0, 0.0);
            for (f, ch) in out.fits[..n].iter().zip(nominal.channels()) {
                if f.held & (1 << (3 + l)) == 0 && f.sd[3 + l] > 0.0 {
                    let w = 1.0 / (f.sd[3 + l] * f.sd[3 + l]);
                    sw += w;
                    swx += w * (ch.position[l] - f.channel.position[l]);
                    k += 1.0;
                }
            }
            if sw > 0.0 {
                out.centre_of_mass[l] = swx / sw;
                out.centre_of_mass_sd[l] =
                    Real::sqrt(1.0 / sw + tolerance.position * tolerance.position / k);
            }
        }
    }
    // Positions from the instrument origin.
    let rho = out.centre_of_mass;
    for f in out.fits[..n].iter_mut() {
        for l in 0..3 {
            f.channel.position[l] += rho[l];
        }
    }
    Ok(out)
}

/// A channel's parameters: scale, axis (the nominal axis tilted by `tilt` along the nominal
/// tilt directions, so that a held tilt stays exactly nominal), position from the centre of
/// mass, bias.
#[derive(Clone, Copy, Debug)]
struct State {
    scale: f64,
    nominal_axis: Vec3<f64>,
    basis: (Vec3<f64>, Vec3<f64>),
    tilt: [f64; 2],
    position: Vec3<f64>,
    bias: f64,
}

impl State {
    #[inline]
    fn new(scale: f64, axis: Vec3<f64>, position: Vec3<f64>, bias: f64) -> Self {
        State {
            scale,
            nominal_axis: axis,
            basis: tilt_basis(&axis),
            tilt: [0.0; 2],
            position,
            bias,
        }
    }

    /// The unit axis and its length before normalising.
    #[inline]
    fn axis(&self) -> (Vec3<f64>, f64) {
        let (t1, t2) = &self.basis;
        let v: Vec3<f64> = core::array::from_fn(|k| {
            self.nominal_axis[k] + self.tilt[0] * t1[k] + self.tilt[1] * t2[k]
        });
        let n = Real::sqrt(norm2(&v));
        ([v[0] / n, v[1] / n, v[2] / n], n)
    }

    /// `q = (vec(c s Rᵀ), b)`: the reading is `qᵀ k`.
    #[inline]
    fn q(&self) -> [f64; TERMS] {
        let (s, _) = self.axis();
        let mut q = [0.0; TERMS];
        for j in 0..3 {
            for l in 0..3 {
                q[3 * j + l] = self.scale * s[j] * self.position[l];
            }
        }
        q[9] = self.bias;
        q
    }

    /// `∂q/∂θ` (TERMS × PARAMS), θ = (scale, tilts, position, bias) (paper eq. 9 with scale
    /// and bias).
    #[inline]
    fn jacobian(&self) -> [[f64; PARAMS]; TERMS] {
        let (s, n) = self.axis();
        // ∂(v/|v|)/∂tilt = (t − s (s·t)) / |v|.
        let d = |t: &Vec3<f64>| -> Vec3<f64> {
            let st = s[0] * t[0] + s[1] * t[1] + s[2] * t[2];
            core::array::from_fn(|k| (t[k] - s[k] * st) / n)
        };
        let (d1, d2) = (d(&self.basis.0), d(&self.basis.1));
        let (c, r) = (self.scale, &self.position);
        let mut j = [[0.0; PARAMS]; TERMS];
        for a in 0..3 {
            for l in 0..3 {
                let row = &mut j[3 * a + l];
                row[0] = s[a] * r[l];
                row[1] = c * d1[a] * r[l];
                row[2] = c * d2[a] * r[l];
                row[3 + l] = c * s[a];
            }
        }
        j[9][6] = 1.0;
        j
    }

    /// The parameters after the step `d`.
    #[inline]
    fn step(&self, d: &[f64; PARAMS]) -> State {
        State {
            scale: self.scale + d[0],
            tilt: [self.tilt[0] + d[1], self.tilt[1] + d[2]],
            position: [
                self.position[0] + d[3],
                self.position[1] + d[4],
                self.position[2] + d[5],
            ],
            bias: self.bias + d[6],
            ..*self
        }
    }
}

/// Two unit vectors perpendicular to the unit `s` and to each other (the tilt directions):
/// the first along `s × e`, `e` the coordinate axis least aligned with `s`.
#[inline]
fn tilt_basis(s: &Vec3<f64>) -> (Vec3<f64>, Vec3<f64>) {
    let a = [s[0].abs(), s[1].abs(), s[2].abs()];
    let e = if a[0] <= a[1] && a[0] <= a[2] {
        [1.0, 0.0, 0.0]
    } else if a[1] <= a[2] {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let u = cross(s, &e);
    let n = Real::sqrt(norm2(&u));
    let u = [u[0] / n, u[1] / n, u[2] / n];
    (u, cross(s, &u))
}

/// One channel's least squares over the window's sums.
struct Problem<'a> {
    gram: &'a [[f64; TERMS]; TERMS],
    cross: &'a [f64; TERMS],
    square: f64,
    sets: f64,
    tolerance: &'a Tolerance,
}

/// Iterations of one Gauss–Newton before it is declared unsettled.
const MAX_ITERATIONS: usize = 40;
/// A step below this share of every tolerance has settled.
const SETTLED: f64 = 1e-4;
/// A parameter whose deviation exceeds this share of its tolerance is held.
const HOLD_AT: f64 = 0.5;
/// The ridge added to the scaled normal matrix, relative to its largest diagonal.
const RIDGE: f64 = 1e-10;
/// Held always: in free fall a channel reads `c s·(L R)`, so its scale `c` and its distance
/// from the centre of mass are one product (`(αc, R/α)` reads the same in any field). The
/// scale stays at the arrangement's (the ground calibration's) value; the product, which is
/// what the estimate needs, is identified.
pub const ALWAYS_HELD: u8 = Param::Scale.bit();

impl Problem<'_> {
    /// `Σ (p − qᵀk)²`.
    #[inline]
    fn cost(&self, q: &[f64; TERMS]) -> f64 {
        let mut qmq = 0.0;
        for i in 0..TERMS {
            qmq += q[i] * dot_row(&self.gram[i], q);
        }
        (self.square - 2.0 * dot_row(self.cross, q) + qmq).max(0.0)
    }

    /// The tolerance-scaled normal matrix `D JᵀMJ D` and right-hand side `D Jᵀ(g − Mq)`.
    #[inline]
    fn normal(&self, st: &State) -> ([[f64; PARAMS]; PARAMS], [f64; PARAMS]) {
        let (j, q) = (st.jacobian(), st.q());
        let mut mj = [[0.0; PARAMS]; TERMS];
        let mut resid = [0.0; TERMS];
        for t in 0..TERMS {
            for p in 0..PARAMS {
                mj[t][p] = (0..TERMS).map(|u| self.gram[t][u] * j[u][p]).sum();
            }
            resid[t] = self.cross[t] - dot_row(&self.gram[t], &q);
        }
        let mut h = [[0.0; PARAMS]; PARAMS];
        let mut b = [0.0; PARAMS];
        for p in 0..PARAMS {
            let dp = self.tolerance.of(p);
            for r in 0..PARAMS {
                let s: f64 = (0..TERMS).map(|t| j[t][p] * mj[t][r]).sum();
                h[p][r] = dp * s * self.tolerance.of(r);
            }
            b[p] = dp * (0..TERMS).map(|t| j[t][p] * resid[t]).sum::<f64>();
        }
        // A ridge of 10⁻¹⁰ of the largest diagonal: a direction the window does not see
        // (a lever arm along the only spin axis) gets a deviation far above its tolerance and
        // is held, instead of failing the factorisation; the seen ones do not notice it.
        let top = (0..PARAMS).map(|p| h[p][p]).fold(0.0f64, f64::max);
        for (p, row) in h.iter_mut().enumerate() {
            row[p] += RIDGE * top;
        }
        (h, b)
    }

    /// Gauss–Newton from `start` on the parameters not in `held`; `None` if it does not settle.
    #[inline]
    fn settle(&self, start: State, held: u8) -> Option<State> {
        let mut st = start;
        for _ in 0..MAX_ITERATIONS {
            let (h, b) = self.normal(&st);
            let (mut a, idx, n) = compact(&h, held);
            let mut rhs = [0.0; PARAMS];
            for (k, &p) in idx[..n].iter().enumerate() {
                rhs[k] = b[p];
            }
            if !cholesky(&mut a, n) {
                return None;
            }
            let x = cholesky_solve(&a, n, &rhs);
            let mut d = [0.0; PARAMS];
            let mut largest = 0.0f64;
            for (k, &p) in idx[..n].iter().enumerate() {
                d[p] = x[k] * self.tolerance.of(p);
                largest = largest.max(x[k].abs());
            }
            if !largest.is_finite() {
                return None;
            }
            st = st.step(&d);
            if largest < SETTLED {
                return Some(st);
            }
        }
        None
    }

    /// The channel's fit: Gauss–Newton, then what the window did not determine held at
    /// nominal (the worst first) and Gauss–Newton again, until every
    /// free parameter is determined to half its tolerance. `None` if a Gauss–Newton does not
    /// settle.
    #[inline]
    fn fit(&self, nominal: State, noise: f64) -> Option<ChannelFit> {
        let mut held = ALWAYS_HELD;
        loop {
            let (h, _) = self.normal(&nominal);
            let (mut a, idx, n) = compact(&h, held);
            let worst = if n == 0 {
                None
            } else if !cholesky(&mut a, n) {
                // Not even positive definite: hold the least informed parameter.
                idx[..n]
                    .iter()
                    .copied()
                    .min_by(|&p, &r| h[p][p].total_cmp(&h[r][r]))
            } else {
                let st = self.settle(nominal, held)?;
                let (h, _) = self.normal(&st);
                let (mut a, idx, n) = compact(&h, held);
                if !cholesky(&mut a, n) {
                    idx[..n]
                        .iter()
                        .copied()
                        .min_by(|&p, &r| h[p][p].total_cmp(&h[r][r]))
                } else {
                    let sigma = self.sigma(&st, noise, n);
                    let mut worst: Option<(usize, f64)> = None;
                    let mut sd = [0.0; PARAMS];
                    for (k, &p) in idx[..n].iter().enumerate() {
                        let rel = sigma * Real::sqrt(inverse_diagonal(&a, n, k).max(0.0));
                        sd[p] = rel * self.tolerance.of(p);
                        if rel > HOLD_AT && worst.is_none_or(|(_, w)| rel > w) {
                            worst = Some((p, rel));
                        }
                    }
                    match worst {
                        None => return Some(self.report(&st, sd, held, noise)),
                        Some((p, _)) => Some(p),
                    }
                }
            };
            match worst {
                Some(p) => held |= 1 << p,
                // Everything held: the nominal channel.
                None => return Some(self.report(&nominal, [0.0; PARAMS], held, noise)),
            }
        }
    }

    /// The residual's deviation, not below the channel's declared noise.
    #[inline]
    fn sigma(&self, st: &State, noise: f64, free: usize) -> f64 {
        let dof = (self.sets - free as f64).max(1.0);
        Real::sqrt(self.cost(&st.q()) / dof).max(noise)
    }

    #[inline]
    fn report(&self, st: &State, mut sd: [f64; PARAMS], held: u8, noise: f64) -> ChannelFit {
        for (p, s) in sd.iter_mut().enumerate() {
            if held & (1 << p) != 0 {
                *s = self.tolerance.of(p);
            }
        }
        ChannelFit {
            channel: Channel {
                position: st.position,
                axis: st.axis().0,
                noise,
                bias: st.bias,
                scale: st.scale,
            },
            sd,
            held,
            residual_rms: Real::sqrt(self.cost(&st.q()) / self.sets.max(1.0)),
        }
    }
}

#[inline]
fn dot_row(a: &[f64; TERMS], b: &[f64; TERMS]) -> f64 {
    a.iter().zip(b.iter()).map(|(x, y)| x * y).sum()
}

/// The rows and columns of `h` not in `held`, packed to the top left; their indices; how many.
#[inline]
fn compact(
    h: &[[f64; PARAMS]; PARAMS],
    held: u8,
) -> ([[f64; PARAMS]; PARAMS], [usize; PARAMS], usize) {
    let mut idx = [0usize; PARAMS];
    let mut n = 0;
    for p in 0..PARAMS {
        if held & (1 << p) == 0 {
            idx[n] = p;
            n += 1;
        }
    }
    let mut a = [[0.0; PARAMS]; PARAMS];
    for r in 0..n {
        for c in 0..n {
            a[r][c] = h[idx[r]][idx[c]];
        }
    }
    (a, idx, n)
}

// A 7×7 Cholesky of our own, not nalgebra's: estimator-core has no nalgebra in its target
// build (its SVD is its own, `svd.rs`), and the flight image had 244 B of flash left when this
// was written; these three functions are 40 lines.

/// Cholesky factor (lower) of the leading `n × n` block of the symmetric `a`, in place;
/// `false` unless positive definite with every pivot above 10⁻¹³ of the largest diagonal.
#[inline]
fn cholesky(a: &mut [[f64; PARAMS]; PARAMS], n: usize) -> bool {
    let top = (0..n).map(|i| a[i][i]).fold(0.0f64, f64::max);
    if !(top > 0.0) || !top.is_finite() {
        return false;
    }
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        if !(d > 1e-13 * top) {
            return false;
        }
        let d = Real::sqrt(d);
        a[j][j] = d;
        for i in (j + 1)..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k];
            }
            a[i][j] = s / d;
        }
    }
    true
}

/// Solves `L Lᵀ x = b` with the factor [`cholesky`] left in `l`.
#[inline]
fn cholesky_solve(l: &[[f64; PARAMS]; PARAMS], n: usize, b: &[f64; PARAMS]) -> [f64; PARAMS] {
    let mut y = [0.0; PARAMS];
    for i in 0..n {
        let s: f64 = (0..i).map(|k| l[i][k] * y[k]).sum();
        y[i] = (b[i] - s) / l[i][i];
    }
    let mut x = [0.0; PARAMS];
    for i in (0..n).rev() {
        let s: f64 = ((i + 1)..n).map(|k| l[k][i] * x[k]).sum();
        x[i] = (y[i] - s) / l[i][i];
    }
    x
}

/// `(L Lᵀ)⁻¹` at `(k, k)`.
#[inline]
fn inverse_diagonal(l: &[[f64; PARAMS]; PARAMS], n: usize, k: usize) -> f64 {
    let mut e = [0.0; PARAMS];
    e[k] = 1.0;
    cholesky_solve(l, n, &e)[k]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::dot;

    /// Whether the three are orthonormal.
    fn orthonormal(s: &Vec3<f64>, t1: &Vec3<f64>, t2: &Vec3<f64>) -> bool {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        close(dot(s, t1), 0.0)
            && close(dot(s, t2), 0.0)
            && close(dot(t1, t2), 0.0)
            && close(norm2(t1), 1.0)
            && close(norm2(t2), 1.0)
    }

    #[test]
    fn tilt_basis_is_orthonormal() {
        for s in [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.577, 0.577, 0.5774]] {
            let n = Real::sqrt(norm2(&s));
            let s = [s[0] / n, s[1] / n, s[2] / n];
            let (t1, t2) = tilt_basis(&s);
            assert!(orthonormal(&s, &t1, &t2));
        }
    }

    #[test]
    fn cholesky_solves_and_refuses_a_singular_matrix() {
        let mut a = [[0.0; PARAMS]; PARAMS];
        for i in 0..PARAMS {
            for j in 0..PARAMS {
                a[i][j] =
                    1.0 / (1.0 + (i as f64 - j as f64).abs()) + if i == j { 1.0 } else { 0.0 };
            }
        }
        let orig = a;
        let b = [1.0, -2.0, 0.5, 3.0, 0.0, 1.0, -1.0];
        assert!(cholesky(&mut a, PARAMS));
        let x = cholesky_solve(&a, PARAMS, &b);
        for i in 0..PARAMS {
            let r: f64 = (0..PARAMS).map(|j| orig[i][j] * x[j]).sum();
            assert!((r - b[i]).abs() < 1e-12);
        }
        let mut s = [[0.0; PARAMS]; PARAMS];
        s[0][0] = 1.0;
        s[0][1] = 1.0;
        s[1][0] = 1.0;
        s[1][1] = 1.0;
        assert!(!cholesky(&mut s, 2));
    }
}
