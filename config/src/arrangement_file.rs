//! The arrangement file (TOML) of docs/formats.md: `[[channel]]` and `[[sensor]]` tables.

use std::collections::HashSet;
use std::fmt;
use std::path::Path;

use estimator_core::thermal::Thermal;
use estimator_core::{Arrangement, Model};
use serde::{Deserialize, Serialize};

/// The capacity of host arrangements (channels).
pub const HOST_CAP: usize = 32;

/// The identity orientation (sensor axes along the body axes).
pub const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Part axis `k` in the body frame: column `k` of the sensor-to-body matrix `m` (row by row).
pub fn body_axis(m: &[[f64; 3]; 3], k: usize) -> [f64; 3] {
    [m[0][k], m[1][k], m[2][k]]
}

/// What keeps a sensor-to-body matrix from being a proper rotation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RotationDefect {
    /// `MᵀM` differs from the identity by more than the tolerance.
    NotOrthonormal,
    /// The determinant (not positive): a reflection.
    Improper(f64),
}

/// Checks that `m` (row by row, finite entries) is a proper rotation: `MᵀM = I` within `tol`,
/// `det M > 0`.
pub fn rotation_defect(m: &[[f64; 3]; 3], tol: f64) -> Option<RotationDefect> {
    for i in 0..3 {
        for j in 0..3 {
            let d: f64 = (0..3).map(|k| m[k][i] * m[k][j]).sum();
            let want = if i == j { 1.0 } else { 0.0 };
            if (d - want).abs() > tol {
                return Some(RotationDefect::NotOrthonormal);
            }
        }
    }
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    (det <= 0.0).then_some(RotationDefect::Improper(det))
}

/// One single-axis channel as written in the file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSpec {
    /// Unique name; matches a column of samples.csv.
    pub name: String,
    /// Seismic point R (m, body frame).
    pub position: [f64; 3],
    /// Sensitive axis s (body frame); normalised on load.
    pub axis: [f64; 3],
    /// White noise, m/s² RMS per sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<f64>,
    /// Bias (m/s²): the channel reports `scale · (s·f) + bias` (written by calibration).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias: Option<f64>,
    /// Scale factor (written by calibration).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    /// Standard deviation of an identified position (m per component).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_sd: Option<[f64; 3]>,
    /// Standard deviation of an identified axis direction (rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis_sd: Option<f64>,
    /// Standard deviation of an identified bias (m/s²).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_sd: Option<f64>,
    /// Standard deviation of an identified scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_sd: Option<f64>,
    /// Full scale (m/s²): the largest magnitude the reading takes; a reading at it is clipped
    /// (the own-signal check's range limit). Absent: no limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<f64>,
    /// The temperature (°C) `bias` and `scale` refer to; required with `bias_tc` or
    /// `scale_tc` (`estimator_core::thermal`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_ref: Option<f64>,
    /// The bias's change per °C (m/s² per °C); 0 if absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_tc: Option<f64>,
    /// The scale's relative change per °C (1/°C); 0 if absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_tc: Option<f64>,
}

/// A tri-axial part: expands to channels `<name>.x`, `<name>.y`, `<name>.z`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// Part name.
    pub name: String,
    /// Position (m, body frame).
    pub position: [f64; 3],
    /// Sensor-to-body rotation, row by row (identity if absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation: Option<[[f64; 3]; 3]>,
    /// Noise: one value for all three axes, or one per axis.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<Noise>,
    /// Part type (e.g. "ADXL355"); informational here.
    #[serde(default, rename = "type", skip_serializing_if = "Option::is_none")]
    pub part: Option<String>,
    /// Bus address or chip select; informational here.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub address: Option<toml::Value>,
    /// Full scale of every axis (m/s²), as a channel's `range`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<f64>,
}

/// Noise of a tri-axial part.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Noise {
    /// Same for all axes.
    Same(f64),
    /// Per axis.
    PerAxis([f64; 3]),
}

/// The whole file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArrangementFile {
    /// Default model: "general" or "free-float".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// Standard deviation (rad per axis) of the common rotation of the whole arrangement
    /// relative to the body: what a calibration could not tie down (written by `calibrate`;
    /// added to the estimates' reported deviations).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_rotation_sd: Option<f64>,
    /// Standard deviation (m per axis) of the common translation of all positions (the
    /// origin).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_translation_sd: Option<f64>,
    /// Standard deviation of the common relative size of all positions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_size_sd: Option<f64>,
    /// Standard deviation (rad per axis) of the rotation of the axes relative to the lever
    /// arms (what a self-calibration sees only through the angular acceleration).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_relative_rotation_sd: Option<f64>,
    /// Single-axis channels.
    #[serde(default, rename = "channel", skip_serializing_if = "Vec::is_empty")]
    pub channels: Vec<ChannelSpec>,
    /// Tri-axial parts.
    #[serde(default, rename = "sensor", skip_serializing_if = "Vec::is_empty")]
    pub sensors: Vec<SensorSpec>,
}

/// An error in an arrangement file, naming the file and what is wrong.
#[derive(Debug)]
pub struct ArrangementError {
    /// File (or `"<string>"`).
    pub file: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ArrangementError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.file, self.message)
    }
}

impl std::error::Error for ArrangementError {}

/// A loaded arrangement: channel names and the validated estimator arrangement.
#[derive(Clone, Debug)]
pub struct LoadedArrangement {
    /// Channel names, in estimator channel order.
    pub names: Vec<String>,
    /// The validated arrangement.
    pub arrangement: Arrangement<HOST_CAP>,
    /// Model given in the file, if any.
    pub model: Option<Model>,
    /// True if every channel had a noise value (otherwise equal weights were used).
    pub noise_given: bool,
    /// Each channel's full scale (m/s², infinite where the file gives none).
    pub ranges: Vec<f64>,
    /// The sensors given without an `orientation` (taken as the identity: their axes along
    /// the body's), for a warning.
    pub unoriented: Vec<String>,
}

impl LoadedArrangement {
    /// Each channel's declared noise (m/s²), in estimator channel order.
    pub fn noises(&self) -> Vec<f64> {
        self.arrangement
            .channels()
            .iter()
            .map(|c| c.noise)
            .collect()
    }

    /// The channel of axis `axis` (0 = x, 1 = y, 2 = z) of the part named `part` (channel
    /// names are `part.x`, `part.y`, `part.z`), if the arrangement has it.
    pub fn channel(&self, part: &str, axis: usize) -> Option<usize> {
        let name = format!("{part}.{}", ["x", "y", "z"].get(axis)?);
        self.names.iter().position(|n| *n == name)
    }
}

/// Each channel's part, numbered by first appearance: the channels `name.x`, `name.y`,
/// `name.z` are one part (`name`), a channel named otherwise a part of its own;
/// [`estimator_core::parity::NO_PART`] beyond 254 parts.
pub fn parts_of(names: &[String]) -> Vec<u8> {
    let mut parts: Vec<&str> = Vec::new();
    names
        .iter()
        .map(|n| {
            let sensor = n.rsplit_once('.').map_or(n.as_str(), |(s, _)| s);
            let i = parts.iter().position(|p| *p == sensor).unwrap_or_else(|| {
                parts.push(sensor);
                parts.len() - 1
            });
            u8::try_from(i).unwrap_or(estimator_core::parity::NO_PART)
        })
        .collect()
}

/// Parses a model name.
pub fn parse_model(s: &str) -> Option<Model> {
    match s {
        "general" => Some(Model::General),
        "free-float" => Some(Model::FreeFloat),
        _ => None,
    }
}

impl ArrangementFile {
    /// Reads and parses a file.
    pub fn read(path: &Path) -> Result<Self, ArrangementError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ArrangementError {
            file: file.clone(),
            message: format!("cannot read: {e}"),
        })?;
        Self::parse(&text, &file)
    }

    /// Parses TOML text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Self, ArrangementError> {
        toml::from_str(text).map_err(|e| ArrangementError {
            file: file.to_string(),
            message: one_line(&e.to_string()),
        })
    }

    /// The file as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Expands sensors to channels (channels first, then sensors, in file order).
    pub fn expanded_channels(&self, file: &str) -> Result<Vec<ChannelSpec>, ArrangementError> {
        let err = |message: String| ArrangementError {
            file: file.to_string(),
            message,
        };
        let mut out = self.channels.clone();
        for s in &self.sensors {
            let m = s.orientation.unwrap_or(IDENTITY);
            if !m.iter().flatten().all(|v| v.is_finite()) {
                return Err(err(format!(
                    "sensor \"{}\": orientation is not finite",
                    s.name
                )));
            }
            // Must be a rotation: MᵀM = I within 1e-3, det > 0.
            if let Some(defect) = rotation_defect(&m, 1e-3) {
                let what = match defect {
                    RotationDefect::NotOrthonormal => {
                        "is not a rotation matrix (columns not orthonormal)".to_string()
                    }
                    RotationDefect::Improper(det) => {
                        format!("has determinant {det:.3}, not a proper rotation")
                    }
                };
                return Err(err(format!("sensor \"{}\": orientation {what}", s.name)));
            }
            let noise = match &s.noise {
                None => [None; 3],
                Some(Noise::Same(v)) => [Some(*v); 3],
                Some(Noise::PerAxis(v)) => [Some(v[0]), Some(v[1]), Some(v[2])],
            };
            for (j, suffix) in ["x", "y", "z"].iter().enumerate() {
                out.push(ChannelSpec {
                    name: format!("{}.{}", s.name, suffix),
                    position: s.position,
                    axis: body_axis(&m, j),
                    noise: noise[j],
                    range: s.range,
                    ..Default::default()
                });
            }
        }
        Ok(out)
    }

    /// Validates and converts to the estimator's arrangement.
    pub fn load(&self, file: &str) -> Result<LoadedArrangement, ArrangementError> {
        let err = |message: String| ArrangementError {
            file: file.to_string(),
            message,
        };
        let model = match &self.model {
            None => None,
            Some(m) => Some(parse_model(m).ok_or_else(|| {
                err(format!(
                    "model = \"{m}\" is not one of \"general\", \"free-float\""
                ))
            })?),
        };
        let chans = self.expanded_channels(file)?;
        if chans.is_empty() {
            return Err(err("no [[channel]] or [[sensor]] tables".into()));
        }
        let mut seen = HashSet::new();
        let noise_given = chans.iter().all(|c| c.noise.is_some());
        let mut arr = Arrangement::<HOST_CAP>::new();
        let mut names = Vec::new();
        let mut ranges = Vec::new();
        for c in &chans {
            if c.name.is_empty() || c.name == "t" || c.name.contains(',') {
                return Err(err(format!(
                    "channel name \"{}\" is not allowed (empty, \"t\" or contains a comma)",
                    c.name
                )));
            }
            if !seen.insert(c.name.clone()) {
                return Err(err(format!("channel \"{}\" is defined twice", c.name)));
            }
            let noise = if noise_given {
                c.noise.unwrap_or(1.0)
            } else {
                1.0
            };
            arr.push(c.position, c.axis, noise).map_err(|e| {
                let what = match e {
                    estimator_core::ConfigError::TooManyChannels { capacity } => {
                        format!("too many channels (at most {capacity})")
                    }
                    estimator_core::ConfigError::PositionNotFinite { .. } => {
                        "position is not finite".into()
                    }
                    estimator_core::ConfigError::AxisNotFinite { .. } => {
                        "axis is not finite".into()
                    }
                    estimator_core::ConfigError::AxisZero { .. } => "axis has zero length".into(),
                    estimator_core::ConfigError::NoiseInvalid { .. } => {
                        format!(
                            "noise = {} must be a positive finite number",
                            c.noise.unwrap_or(f64::NAN)
                        )
                    }
                    other => other.to_string(),
                };
                err(format!("channel \"{}\": {what}", c.name))
            })?;
            if c.bias.is_some() || c.scale.is_some() {
                let (bias, scale) = (c.bias.unwrap_or(0.0), c.scale.unwrap_or(1.0));
                arr.set_calibration(arr.len() - 1, bias, scale)
                    .map_err(|_| {
                        err(format!(
                            "channel \"{}\": bias = {bias} must be finite and scale = {scale} a finite number in (0.5, 2)",
                            c.name
                        ))
                    })?;
            }
            if let Some(r) = c.range {
                if !(r > 0.0 && r.is_finite()) {
                    return Err(err(format!(
                        "channel \"{}\": range = {r} must be a positive finite full scale (m/s²)",
                        c.name
                    )));
                }
            }
            let coefficients = (c.t_ref, c.bias_tc, c.scale_tc);
            let thermal = match coefficients {
                (None, None, None) => None,
                (Some(t_ref), bias_tc, scale_tc) => Some(
                    Thermal::new(t_ref, bias_tc.unwrap_or(0.0), scale_tc.unwrap_or(0.0))
                        .map_err(|e| err(format!("channel \"{}\": {e}", c.name)))?,
                ),
                (None, _, _) => {
                    return Err(err(format!(
                        "channel \"{}\": bias_tc and scale_tc need t_ref, the temperature (°C) they refer to",
                        c.name
                    )))
                }
            };
            arr.set_thermal(arr.len() - 1, thermal)
                .map_err(|e| err(e.to_string()))?;
            names.push(c.name.clone());
            ranges.push(c.range.unwrap_or(f64::INFINITY));
        }
        let frame = estimator_core::FrameUncertainty {
            rotation: self.frame_rotation_sd.unwrap_or(0.0),
            translation: self.frame_translation_sd.unwrap_or(0.0),
            size: self.frame_size_sd.unwrap_or(0.0),
            relative_rotation: self.frame_relative_rotation_sd.unwrap_or(0.0),
        };
        arr.set_frame_uncertainty(frame).map_err(|_| {
            err(format!(
                "frame_rotation_sd = {}, frame_translation_sd = {}, frame_size_sd = {}, frame_relative_rotation_sd = {}: each must be a finite number ≥ 0",
                frame.rotation, frame.translation, frame.size, frame.relative_rotation
            ))
        })?;
        arr.set_parts(&parts_of(&names));
        Ok(LoadedArrangement {
            names,
            arrangement: arr,
            model,
            noise_given,
            ranges,
            unoriented: self
                .sensors
                .iter()
                .filter(|s| s.orientation.is_none())
                .map(|s| s.name.clone())
                .collect(),
        })
    }
}

/// Reads, parses and validates an arrangement file.
pub fn load_arrangement(path: &Path) -> Result<LoadedArrangement, ArrangementError> {
    let f = ArrangementFile::read(path)?;
    f.load(&path.display().to_string())
}

fn one_line(s: &str) -> String {
    // toml errors span several lines (with a source excerpt); keep them readable on one line.
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `text` parsed and loaded as the file `x.toml`; the error as its message.
    fn load_text(text: &str) -> Result<LoadedArrangement, String> {
        ArrangementFile::parse(text, "x.toml")
            .and_then(|f| f.load("x.toml"))
            .map_err(|e| e.to_string())
    }

    #[test]
    fn sensor_expands_to_three_channels_with_orientation_columns() {
        let text = r#"
[[sensor]]
name = "u0"
position = [0.1, 0.0, 0.0]
orientation = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
noise = 0.01
"#;
        let l = load_text(text).unwrap();
        assert_eq!(l.names, ["u0.x", "u0.y", "u0.z"]);
        assert_eq!(l.arrangement.channels()[0].axis, [0.0, 1.0, 0.0]);
        assert_eq!(l.arrangement.channels()[1].axis, [-1.0, 0.0, 0.0]);
    }

    /// `range` (a part's full scale) is carried to every channel of a sensor and to a channel;
    /// absent it is no limit; a non-positive one is refused naming the channel.
    #[test]
    fn range_is_read_per_channel_and_checked() {
        let text = r#"
[[channel]]
name = "c"
position = [0.0, 0.1, 0.0]
axis = [1.0, 0.0, 0.0]
noise = 0.01
range = 40.0

[[channel]]
name = "d"
position = [0.0, 0.1, 0.0]
axis = [0.0, 1.0, 0.0]
noise = 0.01

[[sensor]]
name = "u0"
position = [0.1, 0.0, 0.0]
noise = 0.01
range = 20.08
"#;
        let l = load_text(text).unwrap();
        assert_eq!(l.ranges, [40.0, f64::INFINITY, 20.08, 20.08, 20.08]);
        let bad = text.replace("range = 40.0", "range = -1.0");
        let e = load_text(&bad).unwrap_err();
        assert!(
            e.contains("x.toml") && e.contains("\"c\"") && e.contains("range = -1"),
            "{e}"
        );
    }

    /// The frame's uncertainty is read into the arrangement; a negative one is refused by
    /// name.
    #[test]
    fn frame_uncertainty_keys_are_read_and_checked() {
        let part = r#"
[[sensor]]
name = "u0"
position = [0.1, 0.0, 0.0]
noise = 0.01
"#;
        let good = format!("frame_rotation_sd = 1e-3\nframe_size_sd = 2e-3\n{part}");
        let l = load_text(&good).unwrap();
        let f = l.arrangement.frame_uncertainty();
        assert_eq!(
            (f.rotation, f.translation, f.size, f.relative_rotation),
            (1e-3, 0.0, 2e-3, 0.0)
        );
        let bad = format!("frame_translation_sd = -1e-4\n{part}");
        let e = load_text(&bad).unwrap_err();
        assert!(
            e.contains("x.toml") && e.contains("frame_translation_sd = -0.0001"),
            "{e}"
        );
    }
}
