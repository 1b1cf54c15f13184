//! A board's parts and arrangement from an arrangement file, at build time: what a
//! board's `build.rs` reads when `BALLISTO_ARRANGEMENT` names a file, so that an engineer
//! flashes their own geometry — or the calibrated arrangement `ballisto calibrate` wrote —
//! without editing Rust.
//!
//! The file is read and validated by [`crate::arrangement_file`], with the errors `ballisto
//! estimate` gives for the same file; then the board's needs: every channel in a `[[sensor]]`
//! table (the firmware samples tri-axial parts) whose `type` names a part the firmware drives,
//! and each channel's declared noise (the fault monitor tests against it). A calibration —
//! the file `ballisto calibrate` writes from it, `[[channel]]` tables named `<sensor>.x` … —
//! may be given beside it: its geometry, bias, scale, frame uncertainty and model replace the
//! nominal ones channel by channel, and it must name exactly the nominal file's channels. The
//! result is an [`AppConfig`], validated by the firmware's own check, and the Rust source
//! ([`rust_source`]) that builds it on the board.

use std::fmt::Write;
use std::path::Path;

use ballisto_fw::config::{Alignment, AppConfig, PartKind, MAX_CHANNELS, MAX_PARTS};
use estimator_core::{Arrangement, Model};

use crate::arrangement_file::{load_arrangement, ArrangementFile};
use crate::firmware_config::{firmware_config, Part, PartSpec, Sampling};
use crate::model_choice::recommend;

/// The firmware configuration of the arrangement file at `path`, sampled at `rate_hz`: its
/// `[[sensor]]` tables in file order as the parts, its channels, calibration, frame
/// uncertainty and model — or, with `calibration`, that file's for the same channels — and,
/// where the model is not the file's, the note saying why ([`recommend`]). Errors name the file
/// and what is wrong.
pub fn board_config(
    path: &Path,
    calibration: Option<&Path>,
    rate_hz: f32,
) -> Result<(AppConfig, Option<String>), String> {
    let file = path.display().to_string();
    let loaded = load_arrangement(path).map_err(|e| e.to_string())?;
    let err = |message: String| format!("{file}: {message}");
    // The tables as written, for the parts' types and ranges (validated above).
    let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
    let spec = ArrangementFile::parse(&text, &file).map_err(|e| e.to_string())?;
    if !spec.channels.is_empty() {
        return Err(err(format!(
            "[[channel]] \"{}\": the board samples tri-axial parts; give every channel in a \
             [[sensor]] table",
            spec.channels[0].name
        )));
    }
    if !loaded.noise_given {
        return Err(err(
            "every sensor needs its noise (m/s² RMS per sample): the fault monitor tests \
             the readings against it"
                .into(),
        ));
    }
    if spec.sensors.len() > MAX_PARTS {
        return Err(err(format!(
            "{} sensors: the firmware takes at most {MAX_PARTS}",
            spec.sensors.len()
        )));
    }
    if loaded.arrangement.len() > MAX_CHANNELS {
        return Err(err(format!(
            "{} channels: the firmware takes at most {MAX_CHANNELS}",
            loaded.arrangement.len()
        )));
    }
    let calibrated = match calibration {
        None => None,
        Some(c) => Some(load_arrangement(c).map_err(|e| e.to_string())?),
    };
    let source = calibrated.as_ref().unwrap_or(&loaded);
    if let Some(cal) = &calibrated {
        let cal_file = calibration
            .map(|c| c.display().to_string())
            .unwrap_or_default();
        let missing: Vec<&String> = loaded
            .names
            .iter()
            .filter(|n| !cal.names.contains(n))
            .collect();
        let extra: Vec<&String> = cal
            .names
            .iter()
            .filter(|n| !loaded.names.contains(n))
            .collect();
        if !missing.is_empty() || !extra.is_empty() {
            return Err(format!(
                "{cal_file}: not a calibration of {file}: channels missing {missing:?}, not in \
                 it {extra:?}"
            ));
        }
    }
    // The board file's channels in its own order, from the calibration where there is one.
    let order = loaded
        .names
        .iter()
        .enumerate()
        .map(|(i, name)| source.names.iter().position(|n| n == name).unwrap_or(i));
    let arrangement = Arrangement::<MAX_CHANNELS>::select(&source.arrangement, order)
        .map_err(|e| err(e.to_string()))?;
    let parts = spec
        .sensors
        .iter()
        .map(|s| {
            Ok(PartSpec {
                name: s.name.clone(),
                part: Part::from_type(s.part.as_deref())
                    .map_err(|m| err(format!("sensor \"{}\": {m}", s.name)))?,
                range: s.range,
                odr_hz: rate_hz,
                sync: true,
            })
        })
        .collect::<Result<Vec<_>, String>>()?;
    let source_file = calibration.unwrap_or(path);
    let (model, note) = recommend(None, source, source_file)?;
    let sampling = Sampling {
        rate_hz,
        alignment: Alignment::Interpolate,
    };
    let config =
        firmware_config(&loaded, arrangement, &parts, sampling, model, None).map_err(err)?;
    Ok((
        config,
        note.map(|n| format!("{}: {n}", source_file.display())),
    ))
}

/// Rust source of `fn board_config() -> Option<AppConfig>` that builds `config` on the board
/// (for `include!` from a board file; `None` only if the firmware refused what the host
/// validated). Every value is written so that it reads back exactly (f64 `Debug`
/// round-trips).
pub fn rust_source(config: &AppConfig) -> String {
    let mut s = String::new();
    let rate = config.sampling.rate_hz;
    let _ = writeln!(
        s,
        "// Generated by the board's build.rs from BALLISTO_ARRANGEMENT."
    );
    let _ = writeln!(
        s,
        "fn board_config() -> Option<ballisto_fw::config::AppConfig> {{"
    );
    let _ = writeln!(s, "    #[allow(unused_imports)]");
    let _ = writeln!(s, "    use ballisto_fw::config::*;");
    let _ = writeln!(s, "    #[allow(unused_imports)]");
    let _ = writeln!(s, "    use ballisto_fw::drivers::{{adxl355, lis3dh}};");
    let _ = writeln!(
        s,
        "    let mut arrangement = estimator_core::Arrangement::new();"
    );
    for (i, c) in config.arrangement.channels().iter().enumerate() {
        let _ = writeln!(
            s,
            "    arrangement.push({:?}, {:?}, {:?}).ok()?;",
            c.position, c.axis, c.noise
        );
        if c.bias != 0.0 || c.scale != 1.0 {
            let _ = writeln!(
                s,
                "    arrangement.set_calibration({i}, {:?}, {:?}).ok()?;",
                c.bias, c.scale
            );
        }
        if let Some(t) = config.arrangement.thermal(i) {
            let _ = writeln!(
                s,
                "    arrangement.set_thermal({i}, estimator_core::thermal::Thermal::new({:?}, {:?}, {:?}).ok()).ok()?;",
                t.t_ref, t.bias_tc, t.scale_tc
            );
        }
    }
    let f = config.arrangement.frame_uncertainty();
    let _ = writeln!(
        s,
        "    arrangement.set_frame_uncertainty(estimator_core::FrameUncertainty {{ rotation: \
         {:?}, translation: {:?}, size: {:?}, relative_rotation: {:?} }}).ok()?;",
        f.rotation, f.translation, f.size, f.relative_rotation
    );
    let _ = writeln!(s, "    let mut parts = [None; MAX_PARTS];");
    for (i, p) in config.sampling.parts() {
        let kind = match p.kind {
            PartKind::Adxl355 { range, sync, .. } => format!(
                "PartKind::Adxl355 {{ range: adxl355::Range::{range:?}, odr: \
                 adxl355::Odr::at_least({rate:?}), sync: {sync} }}"
            ),
            PartKind::Lis3dh { range, .. } => format!(
                "PartKind::Lis3dh {{ range: lis3dh::Range::{range:?}, odr: \
                 lis3dh::Odr::at_least({rate:?}) }}"
            ),
        };
        let _ = writeln!(
            s,
            "    parts[{i}] = Some(PartConfig {{ kind: {kind}, channels: {:?} }});",
            p.channels
        );
    }
    let model = match config.model {
        Model::General => "General",
        Model::FreeFloat => "FreeFloat",
    };
    let _ = writeln!(
        s,
        "    Some(AppConfig {{ sampling: SamplingConfig {{ rate_hz: {rate:?}, alignment: \
         Alignment::Interpolate, parts }}, arrangement, model: estimator_core::Model::{model}, \
         hint: None }})"
    );
    let _ = writeln!(s, "}}");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use ballisto_fw::drivers::{adxl355, lis3dh};

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("board-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path
    }

    const TWO_PARTS: &str = r#"
model = "free-float"
[[sensor]]
name = "a"
type = "ADXL355"
position = [0.1, 0.0, 0.0]
noise = 0.002
[[sensor]]
name = "b"
type = "lis3dh"
range = 60.0
position = [0.0, 0.1, 0.0]
orientation = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
noise = 0.02
[[sensor]]
name = "c"
type = "ADXL355"
position = [0.0, 0.0, 0.1]
noise = 0.002
"#;

    #[test]
    fn sensors_become_the_boards_parts_in_file_order() {
        let c = board_config(&write("three.toml", TWO_PARTS), None, 200.0)
            .unwrap()
            .0;
        assert_eq!(c.arrangement.len(), 9);
        assert_eq!(c.model, Model::FreeFloat);
        let parts: Vec<_> = c.sampling.parts().collect();
        assert_eq!(parts.len(), 3);
        assert!(matches!(
            parts[0].1.kind,
            PartKind::Adxl355 {
                range: adxl355::Range::G2,
                sync: true,
                ..
            }
        ));
        // 60 m/s² is 6.1 g: the LIS3DH's 8 g range.
        assert!(matches!(
            parts[1].1.kind,
            PartKind::Lis3dh {
                range: lis3dh::Range::G8,
                ..
            }
        ));
        assert_eq!(parts[1].1.channels, [Some(3), Some(4), Some(5)]);
        // The part's y axis is the body's −x (the orientation's second column).
        assert_eq!(c.arrangement.channels()[4].axis, [-1.0, 0.0, 0.0]);
    }

    #[test]
    fn a_file_the_board_cannot_run_is_refused_by_name() {
        let cases = [
            (TWO_PARTS.replace("type = \"lis3dh\"\n", ""), "sensor \"b\": no type"),
            (
                TWO_PARTS.replace("\"lis3dh\"", "\"BMI088\""),
                "type = \"BMI088\" is not a part",
            ),
            (
                // The LIS3DH's widest range carries up to 2047 × 12 mg (240.89 m/s²).
                TWO_PARTS.replace("range = 60.0", "range = 250.0"),
                "more than the part's widest (16 g, full scale 240.89 m/s²)",
            ),
            (
                TWO_PARTS.replace("noise = 0.02\n", ""),
                "every sensor needs its noise",
            ),
            (
                format!("{TWO_PARTS}[[channel]]\nname = \"d\"\nposition = [0, 0, 0]\naxis = [1, 0, 0]\nnoise = 0.1\n"),
                "[[channel]] \"d\"",
            ),
            // Nine channels cannot carry model G: the request is refused, not changed.
            (
                TWO_PARTS.replace("free-float", "general"),
                "model = \"general\" needs at least 12 channels",
            ),
        ];
        for (i, (text, says)) in cases.iter().enumerate() {
            let path = write(&format!("bad{i}.toml"), text);
            let e = board_config(&path, None, 100.0).unwrap_err();
            assert!(e.contains(&*path.display().to_string()), "{e}");
            assert!(e.contains(says), "case {i}: {e}");
        }
    }

    /// The same errors as `ballisto estimate` for what the arrangement file itself gets wrong.
    #[test]
    fn the_arrangement_files_own_errors_are_those_of_estimate() {
        let text = TWO_PARTS.replace("position = [0.1, 0.0, 0.0]", "position = [0.1, 0.0]");
        let path = write("short.toml", &text);
        let board = board_config(&path, None, 100.0).unwrap_err();
        let estimate = load_arrangement(&path).unwrap_err().to_string();
        assert_eq!(board, estimate);
    }

    #[test]
    fn the_source_writes_every_value_so_that_it_reads_back() {
        let c = board_config(&write("src.toml", TWO_PARTS), None, 200.0)
            .unwrap()
            .0;
        let src = rust_source(&c);
        assert!(src.contains("fn board_config() -> Option<ballisto_fw::config::AppConfig>"));
        for ch in c.arrangement.channels() {
            assert!(src.contains(&format!("{:?}, {:?}, {:?}", ch.position, ch.axis, ch.noise)));
        }
        assert!(src.contains("lis3dh::Range::G8"));
        assert!(src.contains("estimator_core::Model::FreeFloat"));
        assert_eq!(src.matches("parts[").count(), 3);
    }

    /// A calibration as `ballisto calibrate` writes it (`[[channel]]` tables, bias and scale)
    /// replaces the nominal geometry channel by channel, whatever its order; one that is not
    /// of the same channels is refused.
    #[test]
    fn a_calibration_replaces_the_nominal_geometry() {
        let nominal = write("nominal.toml", TWO_PARTS);
        let mut cal = String::from("model = \"free-float\"\nframe_rotation_sd = 1e-3\n");
        let names = [
            "c.z", "c.y", "c.x", "b.x", "b.y", "b.z", "a.x", "a.y", "a.z",
        ];
        for name in names {
            let (part, axis) = name.split_at(1);
            let position = match part {
                "a" => "[0.101, 0.0, 0.0]",
                "b" => "[0.0, 0.101, 0.0]",
                _ => "[0.0, 0.0, 0.101]",
            };
            let axis = match axis {
                ".x" => "[1.0, 0.0, 0.0]",
                ".y" => "[0.0, 1.0, 0.0]",
                _ => "[0.0, 0.0, 1.0]",
            };
            cal.push_str(&format!(
                "[[channel]]\nname = \"{name}\"\nposition = {position}\naxis = {axis}\nnoise = 0.003\nbias = 0.01\nscale = 1.002\nt_ref = 21.5\nbias_tc = 0.001\nscale_tc = -0.0001\n"
            ));
        }
        let calibrated = write("calibrated.toml", &cal);
        let c = board_config(&nominal, Some(&calibrated), 100.0).unwrap().0;
        // Channel 0 is a.x: the calibration's seventh table.
        let a_x = &c.arrangement.channels()[0];
        assert_eq!(a_x.position, [0.101, 0.0, 0.0]);
        assert_eq!((a_x.bias, a_x.scale, a_x.noise), (0.01, 1.002, 0.003));
        assert_eq!(c.arrangement.frame_uncertainty().rotation, 1e-3);
        assert!(rust_source(&c).contains("set_calibration(0, 0.01, 1.002)"));
        // The temperature coefficients go into the image too (to f32's precision).
        let th = c.arrangement.thermal(0).unwrap();
        assert_eq!(th.t_ref, 21.5);
        assert!((th.bias_tc - 1e-3).abs() < 1e-10 && (th.scale_tc + 1e-4).abs() < 1e-11);
        assert!(
            rust_source(&c).contains("set_thermal(0, estimator_core::thermal::Thermal::new(21.5,")
        );
        let short = write(
            "short-cal.toml",
            &cal.replace("name = \"c.z\"", "name = \"d.z\""),
        );
        let e = board_config(&nominal, Some(&short), 100.0).unwrap_err();
        assert!(
            e.contains("not a calibration of") && e.contains("c.z") && e.contains("d.z"),
            "{e}"
        );
    }
}
