//! Scenario files (TOML): the body and its motion, the environment, the buses and the parts on
//! them (type, address or chip select, mount, error model), scheduled faults, the sampling rate
//! and the duration. The format is documented in `hal-sim/scenarios/README.md`; the named
//! scenarios shipped with the binary are in [`named`].

mod fault_spec;
pub mod named;
mod validate;

pub use fault_spec::FaultSpec;

use std::collections::HashSet;
use std::fmt;
use std::path::Path;

use serde::Deserialize;

use crate::faults::{Fault, FaultKind};
use crate::motion::{Burn, Environment, Motion, Rotation, Segment, SegmentKind, Torque};
use crate::sensors::errors::G0;
use crate::sensors::thermal::{PartThermal, Surroundings};
use crate::sensors::SensorErrors;
use ballisto_config::arrangement_file::{
    body_axis, rotation_defect, ArrangementFile, ChannelSpec, Noise, SensorSpec, IDENTITY,
};

/// An error in a scenario, naming the scenario and what is wrong.
#[derive(Debug)]
pub struct ScenarioError {
    /// Scenario file or name.
    pub source: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.source, self.message)
    }
}

impl std::error::Error for ScenarioError {}

/// A whole scenario file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// One line for people.
    #[serde(default)]
    pub description: String,
    /// Rate at which the controller reads every part (Hz).
    pub rate: f64,
    /// Length of the record (s).
    pub duration: f64,
    /// Seed from which the parts' noise seeds derive.
    #[serde(default)]
    pub seed: u64,
    /// Estimator model for `--estimate`: "general" or "free-float" (default: general).
    #[serde(default)]
    pub model: Option<String>,
    /// Approximate Ω at the start for `--estimate` (rad/s), as from a primary IMU.
    #[serde(default)]
    pub initial_omega: Option<[f64; 3]>,
    /// The body and its rotation.
    pub body: BodySpec,
    /// Where the body is.
    pub environment: EnvironmentSpec,
    /// The buses.
    #[serde(rename = "bus")]
    pub buses: Vec<BusSpec>,
    /// The parts.
    #[serde(rename = "part")]
    pub parts: Vec<PartSpec>,
    /// Scheduled faults.
    #[serde(default, rename = "fault")]
    pub faults: Vec<FaultSpec>,
    /// An optional reference rate sensor (a gyro or a turntable encoder), written as
    /// `reference.csv`.
    #[serde(default)]
    pub reference: Option<ReferenceSpec>,
    /// The parts' surroundings' temperature (°C; default a constant 25 °C, where the
    /// temperature coefficients do nothing).
    #[serde(default)]
    pub temperature: Option<Surroundings>,
}

/// A reference rate sensor: the true Ω (body frame) plus a constant bias and white noise.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceSpec {
    /// White-noise density (rad/s/√Hz); the per-sample noise is over half the output rate.
    #[serde(default)]
    pub noise_density: f64,
    /// Constant bias (rad/s, body frame).
    #[serde(default)]
    pub bias: [f64; 3],
    /// Output rate (Hz): the scenario's rate divided by a whole number (default: the rate).
    #[serde(default)]
    pub rate: Option<f64>,
}

/// One segment of a calibration schedule (`body.schedule`).
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum SegmentSpec {
    /// At rest for `duration` s (a static pose).
    Rest {
        /// s.
        duration: f64,
    },
    /// A turn by `angle` rad about the body axis `axis` in `duration` s, from rest to rest.
    Rotate {
        /// Body axis.
        axis: [f64; 3],
        /// rad.
        angle: f64,
        /// s.
        duration: f64,
    },
    /// A spin at `rate` rad/s about the body axis `axis` for `duration` s, with `ramp` s of
    /// spin-up and of spin-down inside it.
    Spin {
        /// Body axis.
        axis: [f64; 3],
        /// rad/s.
        rate: f64,
        /// s (default 1).
        #[serde(default)]
        ramp: Option<f64>,
        /// s.
        duration: f64,
    },
}

/// The body: Euler's equations (`inertia`, `omega0`, optional `torque`) or a `turntable`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Principal moments of inertia (kg·m²) along the body axes.
    #[serde(default)]
    pub inertia: Option<[f64; 3]>,
    /// Ω at t = 0 (rad/s, body).
    #[serde(default)]
    pub omega0: Option<[f64; 3]>,
    /// Attitude at t = 0, body → inertial quaternion `[w, x, y, z]`.
    #[serde(default)]
    pub attitude0: Option<[f64; 4]>,
    /// Instrument origin seen from the centre of mass / rotation centre (m, body): ρ.
    #[serde(default)]
    pub origin_offset: Option<[f64; 3]>,
    /// Body torque (Euler only).
    #[serde(default)]
    pub torque: Option<TorqueSpec>,
    /// A turntable instead of free rotation.
    #[serde(default)]
    pub turntable: Option<TurntableSpec>,
    /// A calibration schedule instead of free rotation or a turntable: segments from rest.
    #[serde(default)]
    pub schedule: Option<Vec<SegmentSpec>>,
}

/// A torque profile.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum TorqueSpec {
    /// `τ_k = amplitude_k sin(2π f t + phase_k)`.
    Sinusoid {
        /// N·m per axis.
        amplitude: [f64; 3],
        /// Hz.
        frequency: f64,
        /// rad per axis.
        #[serde(default)]
        phase: [f64; 3],
    },
    /// Piecewise constant torques from their start times.
    Steps {
        /// `[start, τx, τy, τz]` rows.
        steps: Vec<[f64; 4]>,
    },
}

/// A turntable.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TurntableSpec {
    /// Spin axis (body), normalised.
    pub axis: [f64; 3],
    /// Final rate (rad/s).
    pub rate: f64,
    /// Spin-up time from rest (s); 0: spinning from the start.
    #[serde(default)]
    pub spin_up: f64,
}

/// The environment: `kind` = "space", "orbit" (with `altitude`) or "ground"; optional drag
/// and burns.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    /// "space", "orbit" or "ground".
    pub kind: String,
    /// Orbit altitude (m).
    #[serde(default)]
    pub altitude: Option<f64>,
    /// Constant drag (specific force, inertial, m/s²).
    #[serde(default)]
    pub drag: Option<[f64; 3]>,
    /// Thruster burns.
    #[serde(default, rename = "burn")]
    pub burns: Vec<BurnSpec>,
}

/// A burn: body-fixed specific force over a time window.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BurnSpec {
    /// Start (s).
    pub start: f64,
    /// End (s).
    pub end: f64,
    /// Specific force (m/s², body).
    pub accel: [f64; 3],
}

/// A bus.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BusSpec {
    /// Name the parts refer to.
    pub name: String,
    /// "spi" or "i2c".
    pub kind: String,
    /// Bus clock (Hz), e.g. 10e6 for SPI, 400e3 for I²C.
    pub clock_hz: f64,
}

/// The part types modelled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PartType {
    /// Analog Devices ADXL355 (SPI).
    Adxl355,
    /// STMicroelectronics LIS3DH (I²C).
    Lis3dh,
}

impl PartType {
    /// The name written in arrangement files.
    pub fn label(self) -> &'static str {
        match self {
            PartType::Adxl355 => "ADXL355",
            PartType::Lis3dh => "LIS3DH",
        }
    }

    /// The output data rates the part offers (Hz), ascending.
    pub fn odrs(self) -> Vec<f64> {
        match self {
            PartType::Adxl355 => (0..=10).rev().map(|n| 4000.0 / f64::from(1 << n)).collect(),
            PartType::Lis3dh => vec![1.0, 10.0, 25.0, 50.0, 100.0, 200.0, 400.0, 1344.0],
        }
    }

    /// Full-scale ranges (g).
    pub fn ranges(self) -> &'static [u32] {
        match self {
            PartType::Adxl355 => &[2, 4, 8],
            PartType::Lis3dh => &[2, 4, 8, 16],
        }
    }

    /// The largest magnitude an axis reads at the range (m/s²): the output's positive rail,
    /// `2¹⁹ − 1` counts of the ADXL355's 20 bits, `2¹¹ − 1` digits of the LIS3DH's 12
    /// (high-resolution mode, as the bench reader and the firmware set it). Written to the
    /// arrangement file as each channel's `range`.
    pub fn full_scale(self, range_g: u32) -> f64 {
        let counts = match self {
            PartType::Adxl355 => f64::from(crate::sensors::adxl355::CODE_MAX),
            PartType::Lis3dh => f64::from((1u32 << 11) - 1),
        };
        counts * self.lsb(range_g)
    }

    /// One count of the output (m/s²) at the range.
    pub fn lsb(self, range_g: u32) -> f64 {
        match self {
            PartType::Adxl355 => G0 * f64::from(range_g) / 512_000.0,
            // High-resolution mode: 1, 2, 4, 12 mg per digit.
            PartType::Lis3dh => {
                G0 * 1e-3
                    * match range_g {
                        2 => 1.0,
                        4 => 2.0,
                        8 => 4.0,
                        _ => 12.0,
                    }
            }
        }
    }

    /// White-noise bandwidth as a fraction of the ODR.
    pub fn bandwidth_per_odr(self) -> f64 {
        match self {
            PartType::Adxl355 => 0.25,
            PartType::Lis3dh => 0.5,
        }
    }
}

/// One tri-axial part.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartSpec {
    /// Unique name; channels are `<name>.x` etc.
    pub name: String,
    /// Part type.
    #[serde(rename = "type")]
    pub part: PartType,
    /// The bus it is on.
    pub bus: String,
    /// Chip select (SPI).
    #[serde(default)]
    pub cs: Option<usize>,
    /// 7-bit address (I²C).
    #[serde(default)]
    pub address: Option<u8>,
    /// Position (m, body).
    pub position: [f64; 3],
    /// Sensor-to-body rotation, row by row (identity if absent).
    #[serde(default)]
    pub orientation: Option<[[f64; 3]; 3]>,
    /// The axes used as channels (default all: "x", "y", "z").
    #[serde(default)]
    pub axes: Option<Vec<String>>,
    /// Full-scale range (g); default the smallest.
    #[serde(default)]
    pub range_g: Option<u32>,
    /// Output data rate (Hz), one the part offers; default the lowest at or above the rate
    /// (ADXL355: below twice the rate, so that its ODR/4 filter does not alias).
    #[serde(default)]
    pub odr: Option<f64>,
    /// ADXL355: sample on the controller's SYNC pulse at every read instant (default true).
    #[serde(default)]
    pub sync: Option<bool>,
    /// Scale factor per axis.
    #[serde(default)]
    pub scale: Option<[f64; 3]>,
    /// Bias (m/s²) per axis.
    #[serde(default)]
    pub bias: Option<[f64; 3]>,
    /// Cross-axis sensitivity (off-diagonal; rows = output axis).
    #[serde(default)]
    pub cross: Option<[[f64; 3]; 3]>,
    /// White-noise density (m/s²/√Hz).
    #[serde(default)]
    pub noise_density: Option<f64>,
    /// Clock offset (ppm).
    #[serde(default)]
    pub clock_ppm: Option<f64>,
    /// Jitter of each sample instant (s RMS).
    #[serde(default)]
    pub jitter: Option<f64>,
    /// Mounting position error (m, body): the part sits at `position + position_error`.
    #[serde(default)]
    pub position_error: Option<[f64; 3]>,
    /// Mounting orientation error: a small rotation vector (rad, body frame) applied to the
    /// nominal orientation.
    #[serde(default)]
    pub orientation_error: Option<[f64; 3]>,
    /// Bias temperature coefficient per axis (m/s² per °C, from 25 °C).
    #[serde(default)]
    pub bias_tc: Option<[f64; 3]>,
    /// Sensitivity temperature coefficient per axis (1/°C, from 25 °C).
    #[serde(default)]
    pub scale_tc: Option<[f64; 3]>,
    /// Time constant (s) with which the part's die follows `[temperature]` (default 0).
    #[serde(default)]
    pub thermal_lag: Option<f64>,
    /// What the part's temperature sensor reads above its die's temperature (°C, default 0).
    #[serde(default)]
    pub temp_offset: Option<f64>,
}

impl PartSpec {
    /// Nominal part axis `k` (0 = x) in the body frame: column `k` of the orientation.
    pub fn axis(&self, k: usize) -> [f64; 3] {
        body_axis(&self.orientation.unwrap_or(IDENTITY), k)
    }

    /// Where the part really sits: nominal position plus `position_error`.
    pub fn true_position(&self) -> [f64; 3] {
        let e = self.position_error.unwrap_or([0.0; 3]);
        [
            self.position[0] + e[0],
            self.position[1] + e[1],
            self.position[2] + e[2],
        ]
    }

    /// The part's real axis `k` in the body frame: the nominal one turned by
    /// `orientation_error` (Rodrigues' formula).
    pub fn true_axis(&self, k: usize) -> [f64; 3] {
        rotate_by_vector(&self.orientation_error.unwrap_or([0.0; 3]), &self.axis(k))
    }
}

/// `v` turned by the rotation vector `r` (axis `r/|r|`, angle `|r|`).
pub fn rotate_by_vector(r: &[f64; 3], v: &[f64; 3]) -> [f64; 3] {
    let th = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    if th == 0.0 {
        return *v;
    }
    let k = [r[0] / th, r[1] / th, r[2] / th];
    let kxv = estimator_core::linalg::cross(&k, v);
    let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    let (s, c) = th.sin_cos();
    core::array::from_fn(|i| v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c))
}

const AXES: [&str; 3] = ["x", "y", "z"];

fn unit(v: &[f64; 3]) -> Option<[f64; 3]> {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (finite(v) && n > 1e-9).then(|| [v[0] / n, v[1] / n, v[2] / n])
}

/// The motion segments of a (validated) schedule, one after another from t = 0.
fn schedule_segments(specs: &[SegmentSpec]) -> Vec<Segment> {
    let mut t = 0.0;
    specs
        .iter()
        .map(|spec| {
            let (duration, kind) = match spec {
                SegmentSpec::Rest { duration } => (*duration, SegmentKind::Rest),
                SegmentSpec::Rotate {
                    axis,
                    angle,
                    duration,
                } => (
                    *duration,
                    SegmentKind::Rotate {
                        axis: unit(axis).unwrap_or([0.0, 0.0, 1.0]),
                        angle: *angle,
                    },
                ),
                SegmentSpec::Spin {
                    axis,
                    rate,
                    ramp,
                    duration,
                } => (
                    *duration,
                    SegmentKind::Spin {
                        axis: unit(axis).unwrap_or([0.0, 0.0, 1.0]),
                        rate: *rate,
                        ramp: ramp.unwrap_or(1.0),
                    },
                ),
            };
            let seg = Segment {
                start: t,
                end: t + duration,
                kind,
            };
            t += duration;
            seg
        })
        .collect()
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl Scenario {
    /// Parses and validates TOML text; `source` names it in errors.
    pub fn parse(text: &str, source: &str) -> Result<Self, ScenarioError> {
        let s: Scenario = toml::from_str(text).map_err(|e| ScenarioError {
            source: source.to_string(),
            message: e.to_string().lines().collect::<Vec<_>>().join(" "),
        })?;
        s.validate().map_err(|message| ScenarioError {
            source: source.to_string(),
            message,
        })?;
        Ok(s)
    }

    /// Reads a scenario file.
    pub fn read(path: &Path) -> Result<Self, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError {
            source: path.display().to_string(),
            message: format!("cannot read: {e}"),
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// A named scenario or, if no scenario has that name, a file.
    pub fn load(name_or_file: &str) -> Result<Self, ScenarioError> {
        match named::text(name_or_file) {
            Some(text) => Self::parse(text, name_or_file),
            None if Path::new(name_or_file).exists() => Self::read(Path::new(name_or_file)),
            None => Err(ScenarioError {
                source: name_or_file.to_string(),
                message: format!(
                    "no such scenario file, and not a named scenario ({})",
                    named::NAMES.join(", ")
                ),
            }),
        }
    }

    /// The scenario with ideal parts: every part's errors removed — bias, scale, cross-axis,
    /// mounting, and temperature coefficients — its noise and clock kept (what the figures
    /// call "ideal parts").
    pub fn with_ideal_parts(&self) -> Scenario {
        let mut s = self.clone();
        for p in &mut s.parts {
            p.bias = None;
            p.scale = None;
            p.cross = None;
            p.position_error = None;
            p.orientation_error = None;
            p.bias_tc = None;
            p.scale_tc = None;
        }
        s
    }

    /// Samples in the record: `t_k = k / rate` for `0 ≤ t_k ≤ duration`.
    pub fn samples(&self) -> usize {
        (self.duration * self.rate + 1e-9).floor() as usize + 1
    }

    /// Whether a part samples on the SYNC pulse.
    pub fn sync(&self, p: &PartSpec) -> bool {
        p.part == PartType::Adxl355 && p.sync.unwrap_or(true)
    }

    /// The part's ODR (Hz): given, or the lowest at or above the read rate.
    pub fn odr(&self, p: &PartSpec) -> f64 {
        if let Some(o) = p.odr {
            return o;
        }
        let odrs = p.part.odrs();
        odrs.iter()
            .copied()
            .find(|o| *o >= self.rate)
            .unwrap_or(odrs[odrs.len() - 1])
    }

    /// The part's range (g).
    pub fn range_g(&self, p: &PartSpec) -> u32 {
        p.range_g.unwrap_or(p.part.ranges()[0])
    }

    /// The part's error model; its noise seed derives from the scenario seed and its index.
    pub fn errors(&self, index: usize, p: &PartSpec) -> SensorErrors {
        let mut cross = p.cross.unwrap_or([[0.0; 3]; 3]);
        for (i, row) in cross.iter_mut().enumerate() {
            row[i] = 0.0;
        }
        SensorErrors {
            scale: p.scale.unwrap_or([1.0; 3]),
            bias: p.bias.unwrap_or([0.0; 3]),
            cross,
            noise_density: p.noise_density.unwrap_or(0.0),
            clock_ppm: p.clock_ppm.unwrap_or(0.0),
            jitter: p.jitter.unwrap_or(0.0),
            seed: self
                .seed
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .wrapping_add(index as u64 + 1),
            thermal: PartThermal {
                surroundings: self.temperature.unwrap_or_default(),
                lag: p.thermal_lag.unwrap_or(0.0),
                bias_tc: p.bias_tc.unwrap_or([0.0; 3]),
                scale_tc: p.scale_tc.unwrap_or([0.0; 3]),
                sensor_offset: p.temp_offset.unwrap_or(0.0),
            },
        }
    }

    /// The motion (truth).
    pub fn motion(&self) -> Motion {
        let b = &self.body;
        let rotation = match (&b.turntable, b.inertia) {
            _ if b.schedule.is_some() => {
                Rotation::Schedule(schedule_segments(b.schedule.as_deref().unwrap_or(&[])))
            }
            (Some(t), _) => {
                let n = t.axis.iter().map(|v| v * v).sum::<f64>().sqrt();
                Rotation::Turntable {
                    axis: [t.axis[0] / n, t.axis[1] / n, t.axis[2] / n],
                    rate: t.rate,
                    spin_up: t.spin_up,
                }
            }
            (None, inertia) => Rotation::Euler {
                inertia: inertia.unwrap_or([1.0; 3]),
                torque: match &b.torque {
                    None => Torque::None,
                    Some(TorqueSpec::Sinusoid {
                        amplitude,
                        frequency,
                        phase,
                    }) => Torque::Sinusoid {
                        amplitude: *amplitude,
                        frequency: *frequency,
                        phase: *phase,
                    },
                    Some(TorqueSpec::Steps { steps }) => {
                        Torque::Steps(steps.iter().map(|s| (s[0], [s[1], s[2], s[3]])).collect())
                    }
                },
            },
        };
        let e = &self.environment;
        let environment = match e.kind.as_str() {
            "orbit" => Environment::Orbit {
                altitude: e.altitude.unwrap_or(400e3),
            },
            "ground" => Environment::Ground,
            _ => Environment::Space,
        };
        Motion {
            rotation,
            environment,
            omega0: b.omega0.unwrap_or([0.0; 3]),
            attitude0: b.attitude0.unwrap_or([1.0, 0.0, 0.0, 0.0]),
            origin_offset: b.origin_offset.unwrap_or([0.0; 3]),
            non_grav: e.drag.unwrap_or([0.0; 3]),
            burns: e
                .burns
                .iter()
                .map(|b| Burn {
                    start: b.start,
                    end: b.end,
                    accel: b.accel,
                })
                .collect(),
        }
    }

    /// Per-sample white noise of a part's channels (m/s² RMS): its noise density over its
    /// bandwidth, and the quantisation step.
    pub fn channel_noise(&self, p: &PartSpec) -> f64 {
        let nd = p.noise_density.unwrap_or(0.0);
        let bw = self.odr(p) * p.part.bandwidth_per_odr();
        let q = p.part.lsb(self.range_g(p));
        (nd * nd * bw + q * q / 12.0).sqrt()
    }

    /// The channels of a part (`<name>.<axis>`), in the order of its `axes`.
    pub fn part_axes(p: &PartSpec) -> Vec<usize> {
        match &p.axes {
            None => vec![0, 1, 2],
            Some(a) => a
                .iter()
                .filter_map(|n| AXES.iter().position(|x| x == n))
                .collect(),
        }
    }

    /// Whether some part has a mounting or sensor error (then the simulator writes
    /// [`Scenario::truth_geometry`] next to the nominal arrangement).
    pub fn has_part_errors(&self) -> bool {
        self.parts.iter().any(|p| {
            p.position_error.is_some()
                || p.orientation_error.is_some()
                || p.scale.is_some()
                || p.bias.is_some()
                || p.cross.is_some()
        })
    }

    /// The true geometry of every channel, in the channel layout of
    /// [`Scenario::arrangement`] (sensors expanded x, y, z): where the part really sits, and
    /// the channel's effective axis, scale and bias. A part axis `i` reports
    /// `scale_i (a_i + Σ_j cross_ij a_j)·f + bias_i` with `a` its real axes, so the channel's
    /// axis is `v = a_i + Σ_j cross_ij a_j` normalised and its scale `scale_i |v|`.
    pub fn truth_geometry(&self) -> ArrangementFile {
        let nominal = self.arrangement();
        // The scenario's validation checked every orientation more tightly than the
        // expansion does, so the expansion cannot fail here.
        let expanded = nominal.expanded_channels("scenario").unwrap_or_default();
        let mut file = ArrangementFile {
            model: nominal.model,
            ..Default::default()
        };
        for c in expanded {
            let Some((part, axis)) = c.name.rsplit_once('.') else {
                continue;
            };
            let Some((index, p)) = self.parts.iter().enumerate().find(|(_, p)| p.name == part)
            else {
                continue;
            };
            let Some(i) = AXES.iter().position(|a| *a == axis) else {
                continue;
            };
            let errors = self.errors(index, p);
            let mut v = p.true_axis(i);
            for (j, row) in errors.cross[i].iter().enumerate() {
                let a = p.true_axis(j);
                for (vk, ak) in v.iter_mut().zip(a.iter()) {
                    *vk += row * ak;
                }
            }
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            file.channels.push(ChannelSpec {
                name: c.name.clone(),
                position: p.true_position(),
                axis: [v[0] / n, v[1] / n, v[2] / n],
                noise: Some(self.channel_noise(p)),
                bias: Some(errors.bias[i]),
                scale: Some(errors.scale[i] * n),
                ..Default::default()
            });
        }
        file
    }

    /// The arrangement file of the scenario: a `[[sensor]]` table per part that uses all its
    /// axes, `[[channel]]` tables for the axes of the others; noise per channel from
    /// [`Scenario::channel_noise`].
    pub fn arrangement(&self) -> ArrangementFile {
        let mut file = ArrangementFile {
            model: Some(self.model.clone().unwrap_or_else(|| "general".into())),
            ..Default::default()
        };
        for p in &self.parts {
            let noise = self.channel_noise(p);
            if p.axes.is_none() {
                file.sensors.push(SensorSpec {
                    name: p.name.clone(),
                    position: p.position,
                    // Written out even where it is the identity: an arrangement file without
                    // it is warned about (the identity taken silently hides a part mounted
                    // otherwise).
                    orientation: Some(p.orientation.unwrap_or(IDENTITY)),
                    noise: Some(Noise::Same(noise)),
                    part: Some(p.part.label().into()),
                    address: Some(match (p.cs, p.address) {
                        (Some(cs), _) => toml::Value::String(format!("{} cs {cs}", p.bus)),
                        (_, a) => toml::Value::String(format!("{} {:#04x}", p.bus, a.unwrap_or(0))),
                    }),
                    range: Some(p.part.full_scale(self.range_g(p))),
                });
            } else {
                for j in Self::part_axes(p) {
                    file.channels.push(ChannelSpec {
                        name: format!("{}.{}", p.name, AXES[j]),
                        position: p.position,
                        axis: p.axis(j),
                        noise: Some(noise),
                        range: Some(p.part.full_scale(self.range_g(p))),
                        ..Default::default()
                    });
                }
            }
        }
        file
    }
}
