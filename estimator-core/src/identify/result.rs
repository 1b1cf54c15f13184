//! What an identification gives: each channel's parameters with their deviations and what was
//! held, the centre of mass, the frame's uncertainty, the calibrated arrangement.

use crate::arrangement::{Arrangement, Channel};
use crate::error::ConfigError;
use crate::frame_uncertainty::{motions, FrameUncertainty};
use crate::linalg::Vec3;

use super::model::{Param, Tolerance, PARAMS};

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

impl AsRef<Channel> for ChannelFit {
    fn as_ref(&self) -> &Channel {
        &self.channel
    }
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
    pub(super) fits: [ChannelFit; CAP],
    pub(super) len: usize,
    /// ρ of paper eq. 12 (m): the instrument origin seen from the centre of mass — the
    /// centre of mass is at −ρ from the origin; `ballisto com`'s ρ and hal-sim's
    /// `origin_offset` are the same vector — with the positions' common translation held by
    /// convention (their mean mounting error is zero).
    pub rho: Vec3<f64>,
    /// Its standard deviation per axis (the convention's included).
    pub rho_sd: Vec3<f64>,
    /// Sample sets in the window.
    pub sets: u32,
    /// The tolerances the hold decisions used.
    pub tolerance: Tolerance,
}

impl<const CAP: usize> Identified<CAP> {
    /// Multiplies every channel's noise and residual RMS by `factor`: a solve over the means
    /// of `k` sample sets reports them as of one set (`factor = √k`, the residual taken as
    /// white).
    pub(super) fn scale_noise(&mut self, factor: f64) {
        for f in self.fits.iter_mut().take(self.len) {
            f.channel.noise *= factor;
            f.residual_rms *= factor;
        }
    }

    /// Every channel's fit, in arrangement order.
    pub fn channels(&self) -> &[ChannelFit] {
        &self.fits[..self.len]
    }

    /// How well the frame of the identified geometry is tied to the body: the frame motions
    /// fitted to the parameters' errors ([`motions::from_covariance`]). Each channel's
    /// errors are its own fit's (independent of the others'; a held parameter's one
    /// tolerance), with what the positions share:
    /// - their weighted mean offset is taken for the centre of mass ([`super::identify`]) and
    ///   removed, and the common translation put back by convention, only as good as the mean
    ///   mounting error (`tolerance / √k` per axis, `k` the channels whose position component
    ///   was free);
    /// - a held scale off by `δ` leaves its channel's lever arm from the centre of mass off by
    ///   `−δ (R + ρ)`, and the product right: Ω and Ω′ do not see it, σ0 at the origin sees
    ///   their mean, a translation (`tolerance² Σ (R + ρ)(R + ρ)ᵀ / n²`).
    #[inline]
    pub fn frame_uncertainty(&self) -> FrameUncertainty<f64> {
        let tol = &self.tolerance;
        let fits = self.channels();
        let free =
            |i: usize, l: usize| !fits[i].is_held(Param::ALL[3 + l]) && fits[i].sd[3 + l] > 0.0;
        let own = |i: usize, l: usize| fits[i].sd[3 + l] * fits[i].sd[3 + l];
        // What the positions share, per axis pair: the held scales' translation and the
        // convention's.
        let mut common = [[0.0f64; 3]; 3];
        let n2 = (fits.len() * fits.len()).max(1) as f64;
        for f in fits.iter().filter(|f| f.is_held(Param::Scale)) {
            let arm: Vec3<f64> = core::array::from_fn(|k| f.channel.position[k] + self.rho[k]);
            for (l, row) in common.iter_mut().enumerate() {
                for (m, v) in row.iter_mut().enumerate() {
                    *v += tol.scale * tol.scale * arm[l] * arm[m] / n2;
                }
            }
        }
        // The weighted mean (weights `1 / v` over the free components) has the variance
        // `1 / W`, which is also its covariance with each of them.
        let mut spread = [0.0f64; 3];
        for (l, s) in spread.iter_mut().enumerate() {
            let (mut sw, mut k) = (0.0, 0.0);
            for i in (0..fits.len()).filter(|&i| free(i, l)) {
                sw += 1.0 / own(i, l);
                k += 1.0;
            }
            if sw > 0.0 {
                *s = 1.0 / sw;
            }
            common[l][l] += tol.position * tol.position / f64::max(k, 1.0);
        }
        // cov(x_i − x̄ , x_j − x̄) + common.
        let position = |i: usize, l: usize, j: usize, m: usize| -> f64 {
            let mut c = common[l][m];
            if l == m {
                if i == j {
                    c += own(i, l);
                }
                let shared = |i: usize| if free(i, l) { spread[l] } else { 0.0 };
                c += spread[l] - shared(i) - shared(j);
            }
            c
        };
        motions::from_covariance(
            fits,
            &|p, r| {
                let (i, a, j, b) = (p / PARAMS, p % PARAMS, r / PARAMS, r % PARAMS);
                let pos = Param::PositionX as usize;
                if (pos..pos + 3).contains(&a) && (pos..pos + 3).contains(&b) {
                    position(i, a - pos, j, b - pos) / (tol.position * tol.position)
                } else if i == j && a == b {
                    let s = fits[i].sd[a] / tol.of(a);
                    s * s
                } else {
                    0.0
                }
            },
            tol,
        )
    }

    /// The calibrated arrangement: every channel as identified, with the frame's uncertainty
    /// `frame` ([`Self::frame_uncertainty`], passed in: it is the costly part, computed once
    /// where there is time for it — on the target, in the identification task, not in the
    /// command that commits).
    ///
    /// Errors: the estimator-core checks (an identified scale outside (0.5, 2) is refused by
    /// channel).
    #[inline]
    pub fn arrangement(
        &self,
        frame: &FrameUncertainty<f64>,
    ) -> Result<Arrangement<CAP>, ConfigError> {
        let mut a = Arrangement::new();
        for f in self.channels() {
            let c = &f.channel;
            let i = a.push(c.position, c.axis, c.noise)?;
            a.set_calibration(i, c.bias, c.scale)?;
        }
        a.set_frame_uncertainty(*frame)?;
        Ok(a)
    }
}
