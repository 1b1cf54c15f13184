//! The one builder of the firmware's configuration ([`AppConfig`]) on the host: from an
//! arrangement and the parts that carry its channels. A board's `build.rs` (through
//! [`crate::board_file`]) and the host simulator (from a scenario) both build it here, so a
//! part's range, rate and sync are chosen by the same rules for the same description.

use ballisto_fw::config::{
    Alignment, AppConfig, PartConfig, PartKind, SamplingConfig, MAX_CHANNELS, MAX_PARTS,
};
use ballisto_fw::drivers::{adxl355, lis3dh};
use estimator_core::{Arrangement, ConfigError, Model};

use crate::arrangement_file::LoadedArrangement;

/// The parts the firmware drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Analog Devices ADXL355 (SPI).
    Adxl355,
    /// ST LIS3DH (I²C).
    Lis3dh,
}

impl Part {
    /// The part an arrangement file's `type` names (case-insensitive).
    pub fn from_type(name: Option<&str>) -> Result<Part, String> {
        match name.map(str::to_ascii_uppercase).as_deref() {
            Some("ADXL355") => Ok(Part::Adxl355),
            Some("LIS3DH") => Ok(Part::Lis3dh),
            Some(other) => Err(format!(
                "type = \"{other}\" is not a part the firmware drives (\"ADXL355\", \"LIS3DH\")"
            )),
            None => {
                Err("no type: the board needs the part (type = \"ADXL355\" or \"LIS3DH\")".into())
            }
        }
    }
}

/// One part as the firmware is to drive it: its channels are `<name>.x`, `.y`, `.z` of the
/// arrangement.
#[derive(Clone, Debug, PartialEq)]
pub struct PartSpec {
    /// The part's name (its channels' prefix).
    pub name: String,
    /// Its type.
    pub part: Part,
    /// The full scale it must hold (m/s², the arrangement file's `range`); its smallest
    /// range where none is given.
    pub range: Option<f64>,
    /// The output data rate it must reach (Hz): the lowest at or above it is configured.
    pub odr_hz: f32,
    /// An ADXL355 converts on the SYNC line's pulses (ignored for the LIS3DH, which always
    /// runs on its own clock).
    pub sync: bool,
}

impl PartSpec {
    /// The firmware's settings for the part: the smallest range whose full scale holds
    /// [`PartSpec::range`], the lowest output data rate at or above [`PartSpec::odr_hz`].
    pub fn kind(&self) -> Result<PartKind, String> {
        Ok(match self.part {
            Part::Adxl355 => PartKind::Adxl355 {
                range: smallest_range(
                    self.range,
                    &[
                        (2, adxl355::Range::G2),
                        (4, adxl355::Range::G4),
                        (8, adxl355::Range::G8),
                    ],
                    |r| r.full_scale(),
                )?,
                odr: adxl355::Odr::at_least(self.odr_hz),
                sync: self.sync,
            },
            Part::Lis3dh => PartKind::Lis3dh {
                range: smallest_range(
                    self.range,
                    &[
                        (2, lis3dh::Range::G2),
                        (4, lis3dh::Range::G4),
                        (8, lis3dh::Range::G8),
                        (16, lis3dh::Range::G16),
                    ],
                    |r| r.full_scale(),
                )?,
                odr: lis3dh::Odr::at_least(self.odr_hz),
            },
        })
    }
}

/// The first of a part's ranges (nominal g and range, narrowest first) whose full scale (m/s², the driver's: the
/// largest reading the part's output can carry) holds `range`; the narrowest without one. A
/// range written as the part's own full scale (what `ballisto sim` writes) selects that range:
/// the comparison allows the f32 rounding of the driver's figure.
fn smallest_range<R: Copy>(
    range: Option<f64>,
    ranges: &[(u32, R)],
    full_scale: impl Fn(R) -> f32,
) -> Result<R, String> {
    let wanted = range.unwrap_or(0.0);
    let holds = |r: R| f64::from(full_scale(r)) * (1.0 + 1e-6);
    ranges
        .iter()
        .map(|(_, r)| *r)
        .find(|r| wanted <= holds(*r))
        .ok_or_else(|| {
            let (g, widest) = ranges
                .last()
                .map_or((0, 0.0), |(g, r)| (*g, f64::from(full_scale(*r))));
            format!(
                "range = {wanted} m/s² is more than the part's widest ({g} g, full scale \
                 {widest:.2} m/s²)"
            )
        })
}

/// How the firmware samples: the rate of the sample sets and the alignment of free-running
/// parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    /// Sample sets per second.
    pub rate_hz: f32,
    /// How free-running parts' samples are brought to the sets' instants.
    pub alignment: Alignment,
}

/// The firmware configuration of `arrangement` (the firmware's copy of `loaded`'s channels,
/// in `loaded`'s order: [`firmware_arrangement`], or a calibration of them) carried by
/// `parts`, under `model`, with the rate `hint` for the first set. Checked as the unit checks
/// it at boot: the parts feed every channel once, and the estimator accepts the arrangement
/// under the model. Errors say what is wrong; the caller names the file.
pub fn firmware_config(
    loaded: &LoadedArrangement,
    arrangement: Arrangement<MAX_CHANNELS>,
    parts: &[PartSpec],
    sampling: Sampling,
    model: Model,
    hint: Option<[f64; 3]>,
) -> Result<AppConfig, String> {
    if parts.len() > MAX_PARTS {
        return Err(format!(
            "{} parts: the firmware takes at most {MAX_PARTS}",
            parts.len()
        ));
    }
    let mut slots = [None; MAX_PARTS];
    for (slot, p) in slots.iter_mut().zip(parts) {
        let kind = p
            .kind()
            .map_err(|m| format!("sensor \"{}\": {m}", p.name))?;
        let channels = [0, 1, 2].map(|k| loaded.channel(&p.name, k).map(|c| c as u8));
        *slot = Some(PartConfig { kind, channels });
    }
    let config = AppConfig {
        sampling: SamplingConfig {
            rate_hz: sampling.rate_hz,
            alignment: sampling.alignment,
            parts: slots,
        },
        arrangement,
        model,
        hint,
    };
    config
        .validate()
        .map_err(|e| format!("firmware configuration: {e}"))?;
    // What the unit does with it at boot: a configuration the estimator refuses (model G on
    // fewer than 12 channels, a degenerate geometry) is refused here, not on the unit.
    ballisto_fw::estimation::Estimation::new(&config)
        .map_err(|e| format!("the estimator refuses it: {e}"))?;
    Ok(config)
}

/// An arrangement file's arrangement as the firmware holds it: every channel's geometry,
/// noise, calibration and temperature coefficients, and the frame's uncertainty. An
/// arrangement of more than [`MAX_CHANNELS`] channels is an error.
pub fn firmware_arrangement(
    loaded: &LoadedArrangement,
) -> Result<Arrangement<MAX_CHANNELS>, ConfigError> {
    let a = &loaded.arrangement;
    Arrangement::select(a, 0..a.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(part: Part, range: Option<f64>) -> PartSpec {
        PartSpec {
            name: "u0".into(),
            part,
            range,
            odr_hz: 100.0,
            sync: true,
        }
    }

    #[test]
    fn a_range_picks_the_narrowest_that_holds_it() {
        let g = estimator_core::G0;
        let adxl = |r| spec(Part::Adxl355, r).kind().unwrap();
        let range_of = |k: PartKind| match k {
            PartKind::Adxl355 { range, .. } => range,
            _ => unreachable!(),
        };
        assert_eq!(range_of(adxl(None)), adxl355::Range::G2);
        assert_eq!(range_of(adxl(Some(2.0 * g))), adxl355::Range::G2);
        // The part's own full scale (2.048 g at ±2 g), as the simulator writes it.
        let full = f64::from(adxl355::Range::G2.full_scale());
        assert_eq!(range_of(adxl(Some(full))), adxl355::Range::G2);
        assert_eq!(range_of(adxl(Some(full * 1.01))), adxl355::Range::G4);
        assert_eq!(range_of(adxl(Some(7.9 * g))), adxl355::Range::G8);
        let e = spec(Part::Adxl355, Some(9.0 * g)).kind().unwrap_err();
        assert!(e.contains("more than the part's widest"), "{e}");
        let lis = spec(Part::Lis3dh, Some(16.0 * g)).kind().unwrap();
        assert!(matches!(
            lis,
            PartKind::Lis3dh {
                range: lis3dh::Range::G16,
                ..
            }
        ));
    }

    #[test]
    fn part_types_are_named_or_refused() {
        assert_eq!(Part::from_type(Some("adxl355")), Ok(Part::Adxl355));
        assert_eq!(Part::from_type(Some("LIS3DH")), Ok(Part::Lis3dh));
        assert!(Part::from_type(Some("MPU9150"))
            .unwrap_err()
            .contains("MPU9150"));
        assert!(Part::from_type(None).unwrap_err().contains("no type"));
    }
}
