//! Puts the QEMU board's memory map (mps2-an386) on the linker search path as
//! `board-memory.x` (the workspace's `memory.x` includes it).
use std::path::PathBuf;

fn main() {
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
        let memory = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap())
            .join("../boards/qemu/memory.x");
        std::fs::copy(&memory, out.join("board-memory.x")).unwrap();
        println!("cargo:rustc-link-search={}", out.display());
        println!("cargo:rerun-if-changed={}", memory.display());
    }
    println!("cargo:rerun-if-changed=build.rs");
}
