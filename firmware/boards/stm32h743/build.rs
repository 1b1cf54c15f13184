//! Puts this board's memory map on the linker search path as `board-memory.x` (the
//! workspace's `memory.x` includes it), links defmt's linker script, and writes the board's
//! configuration to `$OUT_DIR/board_config.rs`: the built-in `tetra` board, or, where
//! `BALLISTO_ARRANGEMENT` names an arrangement file (a path from this directory, or absolute),
//! its parts and arrangement — with `BALLISTO_CALIBRATION` the calibrated geometry `ballisto
//! calibrate` wrote for it, and `BALLISTO_RATE_HZ` the sample rate (100 Hz if unset). The
//! files are read and validated as `ballisto estimate` reads them (`ballisto_config::board_file`);
//! this board's wiring is checked here. A file it cannot run stops the build, naming the file
//! and what is wrong.
use std::path::PathBuf;

use ballisto_fw::config::{AppConfig, PartKind};

fn main() {
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
        let memory = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("memory.x");
        std::fs::copy(&memory, out.join("board-memory.x")).unwrap();
        println!("cargo:rustc-link-search={}", out.display());
        println!("cargo:rustc-link-arg-bins=--nmagic");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
        println!("cargo:rerun-if-changed={}", memory.display());
    }
    println!("cargo:rerun-if-changed=build.rs");
    for var in [
        "BALLISTO_ARRANGEMENT",
        "BALLISTO_CALIBRATION",
        "BALLISTO_RATE_HZ",
    ] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    let source = match board_config() {
        Ok(None) => "/// The built-in `tetra` board.\nfn board_config() -> Option<ballisto_fw::config::AppConfig> {\n    ballisto_fw::config::builtin(\"tetra\")\n}\n".to_string(),
        Ok(Some(config)) => ballisto_config::board_file::rust_source(&config),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    std::fs::write(out.join("board_config.rs"), source).unwrap();
}

/// The configuration the environment names, if it names one.
fn board_config() -> Result<Option<AppConfig>, String> {
    let Some(path) = std::env::var_os("BALLISTO_ARRANGEMENT").map(PathBuf::from) else {
        return Ok(None);
    };
    let calibration = std::env::var_os("BALLISTO_CALIBRATION").map(PathBuf::from);
    for p in std::iter::once(&path).chain(calibration.as_ref()) {
        println!("cargo:rerun-if-changed={}", p.display());
    }
    let rate = match std::env::var("BALLISTO_RATE_HZ") {
        Err(_) => 100.0,
        Ok(r) => r
            .parse::<f32>()
            .map_err(|_| format!("BALLISTO_RATE_HZ = {r:?} is not a number (Hz)"))?,
    };
    let (config, model_note) =
        ballisto_config::board_file::board_config(&path, calibration.as_deref(), rate)?;
    if let Some(note) = model_note {
        println!("cargo:warning={note}");
    }
    wiring(&config).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(Some(config))
}

/// This board's wiring (`src/main.rs`): ADXL355 parts on SPI1 with four chip selects (PD14,
/// PD15, PF12, PF13: the first four sensors), LIS3DH parts on I2C1 at 0x18 (a sensor of even
/// place) or 0x19 (odd place).
fn wiring(config: &AppConfig) -> Result<(), String> {
    let mut address = [None; 2];
    for (i, p) in config.sampling.parts() {
        match p.kind {
            PartKind::Adxl355 { .. } if i >= 4 => {
                return Err(format!(
                    "sensor {} is an ADXL355: this board has four SPI chip selects, for the \
                     first four sensors",
                    i + 1
                ));
            }
            PartKind::Lis3dh { .. } => {
                if let Some(other) = address[i % 2].replace(i) {
                    return Err(format!(
                        "sensors {} and {} are LIS3DH at the same I2C address {:#04x} (0x18 \
                         for a sensor of odd number, 0x19 for even)",
                        other + 1,
                        i + 1,
                        0x18 + i % 2
                    ));
                }
            }
            PartKind::Adxl355 { .. } => {}
        }
    }
    Ok(())
}
