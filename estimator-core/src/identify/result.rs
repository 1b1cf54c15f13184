//! What an identification gives: each channel's parameters with their deviations and what was
//! held, the centre of mass, the frame's uncertainty, the calibrated arrangement.

use crate::arrangement::{Arrangement, Channel};
use crate::error::ConfigError;
use crate::frame_uncertainty::FrameUncertainty;
use crate::linalg::{norm2, Vec3};
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
    pub(super) fn of(&self, p: usize) -> f64 {
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
    /// Every channel's fit, in arrangement order.
    pub fn channels(&self) -> &[ChannelFit] {
        &self.fits[..self.len]
    }

    /// How well the frame of the identified geometry is tied to the body. The channels'
    /// errors are independent (each has its own normal equations), so the common ones are
    /// their means: the translation is the convention's (`tolerance / √n` of the free
    /// position components per axis, the largest) and that of the held scales (a scale off by
    /// `δ` moves its channel's lever arm from the centre of mass by `δ (R + ρ)`: their mean is
    /// a translation, `tolerance · rms|R + ρ| / √(3n)` per axis), the rotation the mean of
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
                if !f.is_held(Param::ALL[k]) {
                    tilt += f.sd[k] * f.sd[k];
                    nt += 1.0;
                }
            }
            if f.is_held(Param::Scale) {
                // The lever arm from the centre of mass, at −ρ.
                let arm: Vec3<f64> = core::array::from_fn(|l| f.channel.position[l] + self.rho[l]);
                scale_shift += self.tolerance.scale * self.tolerance.scale * norm2(&arm) / 3.0;
            }
            let r2 = norm2(&f.channel.position);
            for (l, n) in free_axis.iter_mut().enumerate() {
                if !f.is_held(Param::ALL[3 + l]) {
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
