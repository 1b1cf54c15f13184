//! `docs/formats.md` keeps in step with what the ground tool writes and reads: every column of
//! the estimates, decoded, truth and centre-of-mass files, every flag bit and every key of the
//! arrangement file is listed there (a name added to the code and not to the page fails here).

use ballisto::estimate::FLAG_NAMES;
use ballisto::estimates_csv::{
    COLUMNS, EXCLUDED_COLUMNS, EXTRA_COLUMNS, GAMMA_COLUMNS, MARGIN_COLUMNS, PROTECTION_COLUMNS,
};
use ballisto_config::arrangement_file::{ArrangementFile, ChannelSpec, Noise, SensorSpec};

fn page() -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/formats.md");
    std::fs::read_to_string(path).unwrap()
}

fn missing<'a>(page: &str, names: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    names
        .into_iter()
        .filter(|n| !page.contains(&format!("`{n}`")))
        .collect()
}

#[test]
fn every_column_written_is_documented() {
    let page = page();
    let com: Vec<&str> = ballisto::com::COLUMNS.split(',').collect();
    let all = COLUMNS
        .iter()
        .chain(&EXTRA_COLUMNS)
        .chain(&GAMMA_COLUMNS)
        .chain(&MARGIN_COLUMNS)
        .chain(&EXCLUDED_COLUMNS)
        .chain(&PROTECTION_COLUMNS)
        .chain(&ballisto::decode::LINK_COLUMNS)
        .chain(&ballisto::truth_csv::TRUTH_EXTRA_COLUMNS)
        .chain(com.iter())
        .copied();
    let gaps = missing(&page, all);
    assert!(
        gaps.is_empty(),
        "docs/formats.md lacks the columns {gaps:?}"
    );
}

#[test]
fn every_flag_bit_is_documented() {
    let page = page();
    for (bit, name) in FLAG_NAMES {
        assert!(
            page.contains(&format!("\n| {bit} | ")),
            "docs/formats.md has no row for flag {bit} ({name})"
        );
    }
}

#[test]
fn every_arrangement_key_is_documented() {
    // A file with every optional key present, as the tool writes it.
    let file = ArrangementFile {
        model: Some("general".into()),
        frame_rotation_sd: Some(1e-3),
        frame_translation_sd: Some(1e-3),
        frame_size_sd: Some(1e-3),
        frame_relative_rotation_sd: Some(1e-3),
        channels: vec![ChannelSpec {
            name: "c".into(),
            position: [0.1, 0.0, 0.0],
            axis: [1.0, 0.0, 0.0],
            noise: Some(1e-3),
            bias: Some(0.0),
            scale: Some(1.0),
            position_sd: Some([0.0; 3]),
            axis_sd: Some(0.0),
            bias_sd: Some(0.0),
            scale_sd: Some(0.0),
            range: Some(20.0),
            t_ref: Some(25.0),
            bias_tc: Some(1e-3),
            scale_tc: Some(1e-4),
        }],
        sensors: vec![SensorSpec {
            name: "s".into(),
            position: [0.0; 3],
            orientation: Some([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
            noise: Some(Noise::Same(1e-3)),
            part: Some("ADXL355".into()),
            address: Some("spi1 cs 0".into()),
            range: Some(20.0),
        }],
    };
    let toml = file.to_toml();
    let mut keys: Vec<&str> = toml
        .lines()
        .filter_map(|l| l.split_once(" = ").map(|(k, _)| k.trim()))
        .collect();
    keys.sort();
    keys.dedup();
    assert!(keys.len() >= 17, "{keys:?}");
    let page = page();
    let gaps: Vec<&str> = keys
        .into_iter()
        .filter(|k| !page.contains(&format!("\n{k} = ")) && !page.contains(&format!("`{k}`")))
        .collect();
    assert!(
        gaps.is_empty(),
        "docs/formats.md lacks the arrangement keys {gaps:?}"
    );
}
