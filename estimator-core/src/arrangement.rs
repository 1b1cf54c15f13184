//! The arrangement: where each single-axis channel sits, which way it points, how noisy it is.

use crate::error::ConfigError;
use crate::frame_uncertainty::FrameUncertainty;
use crate::parity::NO_PART;
use crate::real::Real;
use crate::thermal::Thermal;

/// One single-axis accelerometer (a tri-axial part is three channels).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Channel {
    /// Seismic point `R` (m, body frame, from the instrument origin).
    pub position: [f64; 3],
    /// Unit sensitive axis `s` (body frame).
    pub axis: [f64; 3],
    /// White noise, m/s² RMS per sample (> 0).
    pub noise: f64,
    /// Bias (m/s²): the channel reports `scale · (s·f) + bias` (identified by calibration;
    /// 0 when uncalibrated).
    pub bias: f64,
    /// Scale factor (> 0; 1 when uncalibrated).
    pub scale: f64,
}

impl Channel {
    /// The channel's row of the linear design (paper eq. 10, unwhitened): `s`, `R × s` and
    /// the diagonal `s_k R_k`, the columns of σ0, Ω′ and the field's diagonal.
    pub fn design_row(&self) -> [f64; 9] {
        crate::internals::design::design_row(&self.axis, &self.position)
    }
}

impl AsRef<Channel> for Channel {
    fn as_ref(&self) -> &Channel {
        self
    }
}

/// The estimation model (paper section 7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Model {
    /// Model G: general field `A = ε{a}² + diag(d)`, 9 linear columns (σ0, Ω′, d); N ≥ 12.
    General,
    /// Model F: free float, `A = Γ + {Ω}²` with known `Γ`, 6 linear columns (σ0, Ω′),
    /// `a ≡ Ω`; N ≥ 9.
    FreeFloat,
}

impl Model {
    /// Number of linear unknowns (columns of the design matrix).
    pub const fn linear_unknowns(self) -> usize {
        match self {
            Model::General => 9,
            Model::FreeFloat => 6,
        }
    }

    /// Fewest channels the model can use (three quadratic forms for `a`).
    pub const fn min_channels(self) -> usize {
        self.linear_unknowns() + 3
    }

    /// The name used in files and on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Model::General => "general",
            Model::FreeFloat => "free-float",
        }
    }
}

/// Up to `CAP` channels, validated on insertion.
#[derive(Clone, Debug, PartialEq)]
pub struct Arrangement<const CAP: usize> {
    channels: [Channel; CAP],
    len: usize,
    frame: FrameUncertainty<f64>,
    /// Each channel's part ([`NO_PART`]: a part of its own): the channels one fault can
    /// reach together, for the protection levels ([`crate::integrity`]).
    part: [u8; CAP],
    /// Each channel's temperature coefficients (`t_ref`, `bias_tc`, `scale_tc`; all zero:
    /// none), applied to its readings before the estimate by whoever reads the temperatures.
    /// In f32: 12 octets a channel where `Option<Thermal>` took 32, in every copy of the
    /// arrangement the firmware keeps (the STM32H743 image's static RAM grew by 9.5 KiB with
    /// the latter); f32 holds a coefficient to 6·10⁻⁸ of itself.
    thermal: [[f32; 3]; CAP],
}

impl<const CAP: usize> Default for Arrangement<CAP> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const CAP: usize> Arrangement<CAP> {
    /// An empty arrangement.
    pub const fn new() -> Self {
        Arrangement {
            channels: [Channel {
                position: [0.0; 3],
                axis: [0.0; 3],
                noise: 0.0,
                bias: 0.0,
                scale: 1.0,
            }; CAP],
            len: 0,
            frame: FrameUncertainty {
                rotation: 0.0,
                translation: 0.0,
                size: 0.0,
                relative_rotation: 0.0,
            },
            part: [NO_PART; CAP],
            thermal: [[0.0; 3]; CAP],
        }
    }

    /// Adds a channel after checking it; the axis is normalised. Returns its index.
    ///
    /// Errors: capacity exceeded, non-finite position, zero or non-finite axis, noise not a
    /// positive finite number. On error nothing is added.
    pub fn push(
        &mut self,
        position: [f64; 3],
        axis: [f64; 3],
        noise: f64,
    ) -> Result<usize, ConfigError> {
        let channel = self.len;
        if channel >= CAP {
            return Err(ConfigError::TooManyChannels { capacity: CAP });
        }
        if !position.iter().all(|v| v.is_finite()) {
            return Err(ConfigError::PositionNotFinite { channel });
        }
        if !axis.iter().all(|v| v.is_finite()) {
            return Err(ConfigError::AxisNotFinite { channel });
        }
        let norm = Real::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
        if !(norm > 1e-9) || !norm.is_finite() {
            return Err(ConfigError::AxisZero { channel });
        }
        if !(noise > 0.0) || !noise.is_finite() {
            return Err(ConfigError::NoiseInvalid { channel });
        }
        self.channels[channel] = Channel {
            position,
            axis: [axis[0] / norm, axis[1] / norm, axis[2] / norm],
            noise,
            bias: 0.0,
            scale: 1.0,
        };
        self.len += 1;
        Ok(channel)
    }

    /// Gives channel `channel` its calibration: it reports `scale · (s·f) + bias`. The
    /// estimator removes it from every reading (`(p − bias) / scale`, both precomputed).
    ///
    /// Errors: no such channel; bias not finite, or scale not a finite number in
    /// (0.5, 2) (a part off by more than a factor of two is not a calibration matter). On
    /// error nothing changes.
    pub fn set_calibration(
        &mut self,
        channel: usize,
        bias: f64,
        scale: f64,
    ) -> Result<(), ConfigError> {
        if channel >= self.len {
            return Err(ConfigError::NoSuchChannel { channel });
        }
        if !(bias.is_finite() && scale.is_finite() && scale > 0.5 && scale < 2.0) {
            return Err(ConfigError::CalibrationInvalid { channel });
        }
        let c = &mut self.channels[channel];
        c.bias = bias;
        c.scale = scale;
        Ok(())
    }

    /// Gives channel `channel` its temperature coefficients (`None`: it has none). `t_ref` is
    /// the temperature its bias and scale ([`Arrangement::set_calibration`]) refer to.
    ///
    /// Errors: no such channel. On error nothing changes.
    pub fn set_thermal(
        &mut self,
        channel: usize,
        thermal: Option<Thermal>,
    ) -> Result<(), ConfigError> {
        if channel >= self.len {
            return Err(ConfigError::NoSuchChannel { channel });
        }
        self.thermal[channel] = thermal.map_or([0.0; 3], |t| {
            [t.t_ref, t.bias_tc, t.scale_tc].map(|v| v as f32)
        });
        Ok(())
    }

    /// Channel `channel`'s temperature coefficients, if it has them (to f32's precision).
    pub fn thermal(&self, channel: usize) -> Option<Thermal> {
        let t = self.thermal.get(..self.len)?.get(channel)?;
        (*t != [0.0; 3]).then(|| Thermal {
            t_ref: f64::from(t[0]),
            bias_tc: f64::from(t[1]),
            scale_tc: f64::from(t[2]),
        })
    }

    /// How well the frame of a calibrated arrangement is tied to the body (its common
    /// rotation, translation and size; see [`FrameUncertainty`]): added to every reported
    /// standard deviation.
    ///
    /// Errors: a deviation negative or not finite. On error nothing changes.
    pub fn set_frame_uncertainty(
        &mut self,
        frame: FrameUncertainty<f64>,
    ) -> Result<(), ConfigError> {
        if !frame.is_valid() {
            return Err(ConfigError::FrameUncertaintyInvalid);
        }
        self.frame = frame;
        Ok(())
    }

    /// A copy with every channel's noise multiplied by `factor` (> 0): the arrangement of
    /// sets that are each the mean of `k` sample sets has `factor = 1/√k`.
    pub fn with_noise_scaled(&self, factor: f64) -> Self {
        let mut a = self.clone();
        for c in a.channels.iter_mut().take(a.len) {
            c.noise *= factor;
        }
        a
    }

    /// The channels `order` of `source` (by index, in that order), each with its calibration
    /// and temperature coefficients, and `source`'s frame uncertainty: one arrangement taken
    /// into another capacity (the host's into the firmware's) or reordered (a board file's
    /// channels in its own order). An index beyond `source` is
    /// [`ConfigError::NoSuchChannel`]; other errors are [`Arrangement::push`]'s, naming the
    /// channel of the new arrangement.
    pub fn select<const M: usize>(
        source: &Arrangement<M>,
        order: impl IntoIterator<Item = usize>,
    ) -> Result<Self, ConfigError> {
        let mut out = Self::new();
        for at in order {
            let c = source
                .channels()
                .get(at)
                .ok_or(ConfigError::NoSuchChannel { channel: at })?;
            let i = out.push(c.position, c.axis, c.noise)?;
            out.set_calibration(i, c.bias, c.scale)?;
            out.set_thermal(i, source.thermal(at))?;
        }
        out.set_frame_uncertainty(source.frame_uncertainty())?;
        Ok(out)
    }

    /// The frame's uncertainty (zero unless set).
    pub fn frame_uncertainty(&self) -> FrameUncertainty<f64> {
        self.frame
    }

    /// Gives the channels their parts (`part[i]` for channel `i`; [`NO_PART`]: a part of its
    /// own): a fault of a tri-axial part reaches its three channels at once, and the
    /// protection levels bound the error of such a fault. Entries beyond the channels are
    /// ignored; channels beyond `part` keep theirs.
    pub fn set_parts(&mut self, part: &[u8]) {
        for (slot, p) in self.part.iter_mut().zip(part).take(self.len) {
            *slot = *p;
        }
    }

    /// Channel `channel`'s part ([`NO_PART`] if none was given).
    pub fn part(&self, channel: usize) -> u8 {
        self.part.get(channel).copied().unwrap_or(NO_PART)
    }

    /// Number of channels.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no channel has been added.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The channels.
    pub fn channels(&self) -> &[Channel] {
        // `len <= CAP` always (`push` refuses beyond); `get` keeps a panic path out of the
        // many places this is inlined.
        self.channels.get(..self.len).unwrap_or(&[])
    }
}

/// Which channels take part in the solve (bit `i` = channel `i`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelMask(pub u64);

impl ChannelMask {
    /// All of the first `n` channels.
    pub const fn all(n: usize) -> Self {
        if n >= 64 {
            ChannelMask(u64::MAX)
        } else {
            ChannelMask((1u64 << n) - 1)
        }
    }

    /// True if channel `i` is included.
    pub const fn contains(self, i: usize) -> bool {
        i < 64 && self.0 & (1u64 << i) != 0
    }

    /// Number of included channels among the first `n`.
    pub const fn count(self, n: usize) -> usize {
        (self.0 & Self::all(n).0).count_ones() as usize
    }

    /// True if every one of the first `n` channels is included. The same as
    /// `self.count(n) == n` without counting: on the Cortex-M4F a 64-bit population count is
    /// about 20 instructions, once per sample in the estimator (`cargo qemu-bench`).
    pub const fn holds_all(self, n: usize) -> bool {
        let all = Self::all(n).0;
        n <= 64 && self.0 & all == all
    }

    /// This mask without channel `i`.
    pub const fn without(self, i: usize) -> Self {
        if i < 64 {
            ChannelMask(self.0 & !(1u64 << i))
        } else {
            self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::ChannelMask;

    /// `holds_all` is `count(n) == n` for every width, with a channel out anywhere, with bits
    /// beyond `n` set or clear, and for widths past the mask's 64 bits (never all held).
    #[test]
    fn holds_all_is_a_full_count() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for n in 0..=66 {
            let mut masks = vec![ChannelMask::all(n), ChannelMask(u64::MAX), ChannelMask(0)];
            masks.extend((0..n).map(|i| ChannelMask::all(n).without(i)));
            for _ in 0..16 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                masks.push(ChannelMask(x));
            }
            for m in masks {
                assert_eq!(m.holds_all(n), m.count(n) == n, "{m:?}, n = {n}");
            }
        }
    }

    /// A selection keeps each channel's geometry, calibration and temperature coefficients,
    /// in the order asked, with the frame's uncertainty; it says which index is missing, and
    /// refuses more channels than its capacity.
    #[test]
    fn a_selection_carries_every_channel_fact_in_its_order() {
        use super::{Arrangement, ConfigError, FrameUncertainty};
        let mut a = Arrangement::<6>::new();
        for k in 0..3 {
            let x = k as f64;
            let i = a
                .push([x, 0.1, 0.2], [0.0, 0.0, 1.0], 1e-3 * (x + 1.0))
                .unwrap();
            a.set_calibration(i, 0.01 * x, 1.0 + 0.001 * x).unwrap();
        }
        let thermal = crate::thermal::Thermal::new(20.0, 1e-4, 2e-5).unwrap();
        a.set_thermal(2, Some(thermal)).unwrap();
        let frame = FrameUncertainty {
            rotation: 1e-3,
            translation: 2e-4,
            size: 1e-4,
            relative_rotation: 5e-4,
        };
        a.set_frame_uncertainty(frame).unwrap();
        let b = Arrangement::<4>::select(&a, [2, 0]).unwrap();
        assert_eq!(b.len(), 2);
        for (i, at) in [2usize, 0].into_iter().enumerate() {
            let (x, y) = (&b.channels()[i], &a.channels()[at]);
            assert_eq!((x.position, x.axis, x.noise), (y.position, y.axis, y.noise));
            assert_eq!((x.bias, x.scale), (y.bias, y.scale));
            assert_eq!(b.thermal(i), a.thermal(at));
        }
        assert_eq!(b.frame_uncertainty(), frame);
        assert!(matches!(
            Arrangement::<4>::select(&a, [0, 5]),
            Err(ConfigError::NoSuchChannel { channel: 5 })
        ));
        assert!(matches!(
            Arrangement::<2>::select(&a, 0..3),
            Err(ConfigError::TooManyChannels { capacity: 2 })
        ));
    }
}
