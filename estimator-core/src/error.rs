//! Configuration errors, each naming what is wrong.

use core::fmt;

use crate::arrangement::Model;

/// A component of the linear unknowns `x = [σ0; Ω′; d]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Unknown {
    /// Specific force at the origin, component 0..3.
    Sigma0(u8),
    /// Angular acceleration, component 0..3.
    DOmega(u8),
    /// Diagonal `d` of model G (paper eq. 10), component 0..3.
    D(u8),
}

impl Unknown {
    /// The unknown of design-matrix column `col` (0..9).
    pub const fn of_column(col: usize) -> Self {
        let axis = (col % 3) as u8;
        match col / 3 {
            0 => Unknown::Sigma0(axis),
            1 => Unknown::DOmega(axis),
            _ => Unknown::D(axis),
        }
    }
}

const AXES: [char; 3] = ['x', 'y', 'z'];

impl fmt::Display for Unknown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Unknown::Sigma0(a) => write!(f, "σ0_{}", AXES[a as usize % 3]),
            Unknown::DOmega(a) => write!(f, "Ω′_{}", AXES[a as usize % 3]),
            Unknown::D(a) => write!(f, "d_{}", AXES[a as usize % 3]),
        }
    }
}

/// Why the arrangement, mask or command cannot be used.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// More channels than the compile-time capacity.
    TooManyChannels {
        /// The capacity.
        capacity: usize,
    },
    /// A position component is NaN or infinite.
    PositionNotFinite {
        /// Channel index.
        channel: usize,
    },
    /// An axis component is NaN or infinite.
    AxisNotFinite {
        /// Channel index.
        channel: usize,
    },
    /// The axis has zero length.
    AxisZero {
        /// Channel index.
        channel: usize,
    },
    /// The noise is not a positive finite number.
    NoiseInvalid {
        /// Channel index.
        channel: usize,
    },
    /// Fewer (included) channels than the model needs.
    TooFewChannels {
        /// The model.
        model: Model,
        /// Channels included.
        have: usize,
        /// Channels needed.
        need: usize,
    },
    /// A channel index beyond the arrangement.
    NoSuchChannel {
        /// Channel index.
        channel: usize,
    },
    /// A column of the design matrix is zero for every channel (paper eq. 11): the unknown
    /// cannot be seen at all.
    NotObservable {
        /// The unknown.
        unknown: Unknown,
    },
    /// The design matrix is rank deficient (or too ill-conditioned for single precision):
    /// a combination of unknowns cannot be separated. `involved` has bit `c` set for each
    /// column `c` that takes part in the unobservable combination.
    Degenerate {
        /// Columns (bit set) of the unobservable combination.
        involved: u16,
        /// Condition number of the whitened design matrix.
        condition: f64,
        /// Estimation frame (0 = body frame).
        frame: u8,
    },
    /// A channel's calibration is not usable: bias not finite, or scale not in (0.5, 2).
    CalibrationInvalid {
        /// Channel index.
        channel: usize,
    },
    /// The frame uncertainty of a calibration has a negative or non-finite deviation.
    FrameUncertaintyInvalid,
    /// A vector given to the estimator (rate hint, Γ) has a NaN or infinite component.
    NotFinite {
        /// What it was.
        what: &'static str,
    },
    /// An option that must be a positive number (the jerk density) is not.
    NotPositive {
        /// What it was.
        what: &'static str,
    },
    /// An option that must be a probability strictly between 0 and 1 is not.
    NotProbability {
        /// What it was.
        what: &'static str,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ConfigError::TooManyChannels { capacity } => {
                write!(f, "too many channels: at most {capacity} are supported")
            }
            ConfigError::PositionNotFinite { channel } => {
                write!(f, "channel {channel}: position is not finite")
            }
            ConfigError::AxisNotFinite { channel } => {
                write!(f, "channel {channel}: axis is not finite")
            }
            ConfigError::AxisZero { channel } => {
                write!(f, "channel {channel}: axis has zero length")
            }
            ConfigError::NoiseInvalid { channel } => {
                write!(
                    f,
                    "channel {channel}: noise must be a positive finite number"
                )
            }
            ConfigError::TooFewChannels { model, have, need } => write!(
                f,
                "model {} needs at least {need} channels, {have} are included",
                model.name()
            ),
            ConfigError::NoSuchChannel { channel } => write!(f, "there is no channel {channel}"),
            ConfigError::CalibrationInvalid { channel } => write!(
                f,
                "channel {channel}: bias must be finite and scale a finite number in (0.5, 2)"
            ),
            ConfigError::FrameUncertaintyInvalid => write!(
                f,
                "the frame uncertainty's deviations must be finite numbers ≥ 0"
            ),
            ConfigError::NotObservable { unknown } => {
                let axis = match unknown {
                    Unknown::Sigma0(a) | Unknown::DOmega(a) | Unknown::D(a) => AXES[a as usize % 3],
                };
                let expr_is = match unknown {
                    Unknown::Sigma0(_) => "s_",
                    Unknown::DOmega(_) => "(R×s)_",
                    Unknown::D(_) => "s_",
                };
                match unknown {
                    Unknown::D(_) => write!(
                        f,
                        "{unknown} is not observable: every channel has s_{axis}·R_{axis} = 0"
                    ),
                    _ => write!(
                        f,
                        "{unknown} is not observable: every channel has {expr_is}{axis} = 0"
                    ),
                }
            }
            ConfigError::Degenerate {
                involved,
                condition,
                frame,
            } => {
                write!(f, "the combination of ")?;
                let mut first = true;
                for col in 0..9 {
                    if involved & (1 << col) != 0 {
                        if !first {
                            write!(f, ", ")?;
                        }
                        write!(f, "{}", Unknown::of_column(col))?;
                        first = false;
                    }
                }
                write!(f, " is not observable (condition number {condition:.2e}")?;
                if frame != 0 {
                    write!(f, ", estimation frame {frame}")?;
                }
                write!(f, ")")
            }
            ConfigError::NotFinite { what } => write!(f, "{what} is not finite"),
            ConfigError::NotPositive { what } => write!(f, "{what} is not a positive number"),
            ConfigError::NotProbability { what } => {
                write!(f, "{what} is not a probability strictly between 0 and 1")
            }
        }
    }
}

impl core::error::Error for ConfigError {}
