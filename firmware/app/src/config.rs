//! What the firmware runs: the parts on their buses (type, range, rate, timing) with the
//! estimator channel of each axis, the sample rate, the alignment of free-running parts, the
//! arrangement, the model and the rate hint. Given at start-up from the built-in table
//! ([`builtin`]) or by a command (the host simulator builds one from its scenario).

use estimator_core::{Arrangement, Model, Real};

use crate::drivers::{adxl355, lis3dh};

/// Most parts on one board.
pub const MAX_PARTS: usize = ballisto_link::ids::PART_SLOTS;
/// Most estimator channels (three per part).
pub const MAX_CHANNELS: usize = ballisto_link::ids::MAX_CHANNELS;
// Every channel of every part fits the link's channel masks and arrangement command.
const _: () = assert!(3 * MAX_PARTS <= MAX_CHANNELS);

/// A part type and its settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PartKind {
    /// ADXL355 on SPI.
    Adxl355 {
        /// Range.
        range: adxl355::Range,
        /// Output data rate (on its own clock) and filter.
        odr: adxl355::Odr,
        /// One sample per pulse of the SYNC line, at the sample instants.
        sync: bool,
    },
    /// LIS3DH on I²C (always on its own clock).
    Lis3dh {
        /// Range.
        range: lis3dh::Range,
        /// Output data rate.
        odr: lis3dh::Odr,
    },
}

impl PartKind {
    /// True if the part samples on its own clock (not on the SYNC line).
    pub fn free_running(self) -> bool {
        !matches!(self, PartKind::Adxl355 { sync: true, .. })
    }

    /// The largest magnitude a reading takes at the configured range (m/s²): an axis reading
    /// it is clipped (the own-signal check's range limit).
    pub fn full_scale(self) -> f32 {
        match self {
            PartKind::Adxl355 { range, .. } => range.full_scale(),
            PartKind::Lis3dh { range, .. } => range.full_scale(),
        }
    }

    /// The nominal output data rate (Hz).
    pub fn odr_hz(self) -> f32 {
        match self {
            PartKind::Adxl355 { odr, .. } => odr.hz(),
            PartKind::Lis3dh { odr, .. } => odr.hz(),
        }
    }
}

/// One part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartConfig {
    /// Type and settings.
    pub kind: PartKind,
    /// The estimator channel of each part axis (x, y, z), or none if the axis is unused.
    pub channels: [Option<u8>; 3],
}

/// How samples of free-running parts are brought to the common instants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Alignment {
    /// Timestamp each FIFO sample with the part's tracked conversion clock and interpolate
    /// to the common instant.
    Interpolate,
    /// Take the latest output at the common instant as if it had been sampled then (the
    /// reference for showing what alignment gains).
    Latest,
}

/// Sampling: the rate and the parts, in bus order.
#[derive(Clone, Copy, Debug)]
pub struct SamplingConfig {
    /// Sample sets per second.
    pub rate_hz: f32,
    /// Alignment of free-running parts.
    pub alignment: Alignment,
    /// The parts (`parts[..count]`).
    pub parts: [Option<PartConfig>; MAX_PARTS],
}

impl SamplingConfig {
    /// The sample period (ns).
    pub fn period_ns(&self) -> u64 {
        (1e9 / f64::from(self.rate_hz)) as u64
    }

    /// The configured parts with their index.
    pub fn parts(&self) -> impl Iterator<Item = (usize, &PartConfig)> {
        self.parts
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.as_ref().map(|p| (i, p)))
    }
}

/// The whole configuration.
#[derive(Clone, Debug)]
pub struct AppConfig {
    /// Sampling.
    pub sampling: SamplingConfig,
    /// Positions, axes and noise of the channels.
    pub arrangement: Arrangement<MAX_CHANNELS>,
    /// Estimation model.
    pub model: Model,
    /// Approximate Ω at start (settles the sign), rad/s.
    pub hint: Option<[f64; 3]>,
}

/// What is wrong with a configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AppConfigError {
    /// The sample rate is not a positive finite number up to 10 kHz.
    Rate,
    /// No part is configured.
    NoParts,
    /// A part axis names a channel beyond the arrangement.
    ChannelOutOfRange {
        /// Part index.
        part: u8,
        /// The channel named.
        channel: u8,
    },
    /// Two part axes name the same channel.
    ChannelTwice {
        /// The channel.
        channel: u8,
    },
    /// A channel of the arrangement is fed by no part axis.
    ChannelUnfed {
        /// The channel.
        channel: u8,
    },
    /// A free-running part's output data rate is below the sample rate.
    OdrBelowRate {
        /// Part index.
        part: u8,
    },
    /// A free-running part's FIFO would overflow between two sample sets.
    FifoTooSmall {
        /// Part index.
        part: u8,
    },
}

impl core::fmt::Display for AppConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            AppConfigError::Rate => write!(f, "sample rate must be in (0, 10 000] Hz"),
            AppConfigError::NoParts => write!(f, "no part configured"),
            AppConfigError::ChannelOutOfRange { part, channel } => write!(
                f,
                "part {part}: channel {channel} is beyond the arrangement"
            ),
            AppConfigError::ChannelTwice { channel } => {
                write!(f, "channel {channel} is fed by two part axes")
            }
            AppConfigError::ChannelUnfed { channel } => {
                write!(f, "channel {channel} is fed by no part axis")
            }
            AppConfigError::OdrBelowRate { part } => {
                write!(f, "part {part}: output data rate below the sample rate")
            }
            AppConfigError::FifoTooSmall { part } => write!(
                f,
                "part {part}: its FIFO would overflow between two sample sets (lower the ODR)"
            ),
        }
    }
}

/// Samples a FIFO holds: ADXL355 32 sets, LIS3DH 32 (31 counted).
const FIFO_SETS: f32 = 31.0;

impl AppConfig {
    /// Checks that the parts feed every channel exactly once and can be sampled at the rate.
    pub fn validate(&self) -> Result<(), AppConfigError> {
        let s = &self.sampling;
        if !(s.rate_hz > 0.0 && s.rate_hz <= 10_000.0) {
            return Err(AppConfigError::Rate);
        }
        let n = self.arrangement.len();
        let mut fed = [false; MAX_CHANNELS];
        let mut any = false;
        for (i, p) in s.parts() {
            any = true;
            let part = i as u8;
            for c in p.channels.iter().flatten() {
                let ci = usize::from(*c);
                if ci >= n {
                    return Err(AppConfigError::ChannelOutOfRange { part, channel: *c });
                }
                if fed[ci] {
                    return Err(AppConfigError::ChannelTwice { channel: *c });
                }
                fed[ci] = true;
            }
            if p.kind.free_running() {
                let odr = p.kind.odr_hz();
                if odr < s.rate_hz {
                    return Err(AppConfigError::OdrBelowRate { part });
                }
                // Up to 1.5 periods between reads (a probe late in one period, early in the
                // next), with margin.
                if s.alignment == Alignment::Interpolate && odr / s.rate_hz * 1.5 > FIFO_SETS {
                    return Err(AppConfigError::FifoTooSmall { part });
                }
            }
        }
        if !any {
            return Err(AppConfigError::NoParts);
        }
        if let Some(c) = (0..n).find(|&c| !fed[c]) {
            return Err(AppConfigError::ChannelUnfed { channel: c as u8 });
        }
        Ok(())
    }
}

/// A built-in configuration: its name and how to build it.
pub type Builtin = (&'static str, fn() -> AppConfig);

/// The built-in configurations.
pub const BUILTIN: [Builtin; 1] = [("tetra", tetra)];

/// A built-in configuration by name.
pub fn builtin(name: &str) -> Option<AppConfig> {
    BUILTIN.iter().find(|(n, _)| *n == name).map(|(_, f)| f())
}

/// Four ADXL355 (±2 g, external sync) on the vertices of a regular tetrahedron of
/// circumradius 0.15 m, each at its own angle: 12 channels, model G, 100 Hz. The hal-sim
/// scenario `tetra-orbit` simulates this board.
pub fn tetra() -> AppConfig {
    const POSITIONS: [[f64; 3]; 4] = [
        [0.086603, 0.086603, 0.086603],
        [0.086603, -0.086603, -0.086603],
        [-0.086603, 0.086603, -0.086603],
        [-0.086603, -0.086603, 0.086603],
    ];
    // Columns are the part axes in the body frame (rows of the orientation matrices).
    const ORIENTATIONS: [[[f64; 3]; 3]; 4] = [
        [
            [0.726315789474, 0.442105263158, 0.526315789474],
            [-0.315789473684, 0.894736842105, -0.315789473684],
            [-0.610526315789, 0.063157894737, 0.789473684211],
        ],
        [
            [0.506172839506, -0.790123456790, -0.345679012346],
            [0.197530864198, -0.283950617284, 0.938271604938],
            [-0.839506172840, -0.543209876543, 0.012345679012],
        ],
        [
            [0.218390804598, -0.942528735632, 0.252873563218],
            [-0.666666666667, -0.333333333333, -0.666666666667],
            [0.712643678161, -0.022988505747, -0.701149425287],
        ],
        [
            [-0.029702970297, 0.831683168317, -0.554455445545],
            [-0.831683168317, 0.287128712871, 0.475247524752],
            [0.554455445545, 0.475247524752, 0.683168316832],
        ],
    ];
    let odr = adxl355::Odr::at_least(100.0);
    // ADXL355 noise density 22.5 µg/√Hz (2.2e-4 m/s²/√Hz) over its ODR/4 bandwidth.
    let noise = 2.2e-4 * Real::sqrt(f64::from(odr.hz()) / 4.0);
    let mut arrangement = Arrangement::new();
    let mut parts = [None; MAX_PARTS];
    for (p, (pos, m)) in POSITIONS.iter().zip(ORIENTATIONS.iter()).enumerate() {
        let mut channels = [None; 3];
        for (k, ch) in channels.iter_mut().enumerate() {
            let axis = [m[0][k], m[1][k], m[2][k]];
            *ch = arrangement.push(*pos, axis, noise).ok().map(|c| c as u8);
        }
        parts[p] = Some(PartConfig {
            kind: PartKind::Adxl355 {
                range: adxl355::Range::G2,
                odr,
                sync: true,
            },
            channels,
        });
    }
    AppConfig {
        sampling: SamplingConfig {
            rate_hz: 100.0,
            alignment: Alignment::Interpolate,
            parts,
        },
        arrangement,
        model: Model::General,
        hint: None,
    }
}
