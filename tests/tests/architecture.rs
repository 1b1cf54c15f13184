//! `docs/architecture.md` agrees with the workspace: its crate table lists every member of the
//! workspace, at its path, with exactly the workspace crates it depends on (normal,
//! target-specific and build dependencies: what the crate, or a build script that shapes it,
//! is made from; dev-dependencies are not part of the architecture). No board depends on the
//! simulator in any way.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Backquoted names in a table cell.
fn quoted(cell: &str) -> Vec<String> {
    cell.split('`')
        .skip(1)
        .step_by(2)
        .map(|s| s.trim_end_matches('/').to_string())
        .collect()
}

/// The crate table: name → (path, workspace dependencies).
fn documented() -> BTreeMap<String, (String, BTreeSet<String>)> {
    let doc = read(&root().join("docs/architecture.md"));
    let mut rows = BTreeMap::new();
    let mut in_table = false;
    for line in doc.lines() {
        if line.starts_with("| crate | path | depends on") {
            in_table = true;
            continue;
        }
        if in_table {
            if !line.starts_with('|') {
                break;
            }
            let cells: Vec<&str> = line.split('|').map(str::trim).collect();
            if cells.len() < 5 || cells[1].starts_with("---") {
                continue;
            }
            let name = quoted(cells[1]);
            let path = quoted(cells[2]);
            // Only the backquoted crate names (a parenthesis may quote a feature).
            let deps: BTreeSet<String> = cells[3]
                .split(',')
                .filter_map(|d| quoted(d).into_iter().next())
                .collect();
            assert_eq!((name.len(), path.len()), (1, 1), "malformed row: {line}");
            rows.insert(name[0].clone(), (path[0].clone(), deps));
        }
    }
    assert!(!rows.is_empty(), "no crate table in docs/architecture.md");
    rows
}

/// The workspace members' paths (root Cargo.toml).
fn members() -> BTreeSet<String> {
    let toml = read(&root().join("Cargo.toml"));
    let start = toml.find("members = [").expect("members");
    let end = start + toml[start..].find(']').expect("end of members");
    toml[start..end]
        .split('"')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// A manifest's package name and the names of its normal, target and build dependencies.
fn manifest(path: &str) -> (String, BTreeSet<String>) {
    let toml = read(&root().join(path).join("Cargo.toml"));
    let mut name = None;
    let mut deps = BTreeSet::new();
    let mut section = String::new();
    for line in toml.lines().map(str::trim) {
        if line.starts_with('[') {
            section = line.to_string();
            continue;
        }
        if section == "[package]" && line.starts_with("name") {
            name = line.split('"').nth(1).map(str::to_string);
        }
        let normal = section == "[dependencies]"
            || section == "[build-dependencies]"
            || (section.starts_with("[target.")
                && (section.ends_with(".dependencies]")
                    || section.ends_with(".build-dependencies]")));
        if normal {
            if let Some((dep, _)) = line.split_once('=') {
                deps.insert(dep.trim().to_string());
            }
        }
    }
    (name.expect("package name"), deps)
}

#[test]
fn the_crate_table_matches_the_workspace() {
    let doc = documented();
    let members = members();
    let names: BTreeSet<String> = doc.keys().cloned().collect();
    let paths: BTreeSet<String> = doc.values().map(|(p, _)| p.clone()).collect();
    assert_eq!(
        paths, members,
        "paths in docs/architecture.md vs workspace members"
    );
    for (name, (path, deps)) in &doc {
        let (package, all) = manifest(path);
        assert_eq!(&package, name, "{path}: package name");
        let workspace: BTreeSet<String> = all.intersection(&names).cloned().collect();
        assert_eq!(&workspace, deps, "{name}: workspace dependencies");
    }
}

/// Every crate named in a manifest's dependency tables of any kind (normal, build, dev, and
/// their target-specific forms).
fn all_dependencies(path: &str) -> BTreeSet<String> {
    let m = manifest_toml(path);
    let mut tables: Vec<&toml::Table> = Vec::new();
    let kinds = ["dependencies", "build-dependencies", "dev-dependencies"];
    for kind in kinds {
        tables.extend(m.get(kind).and_then(toml::Value::as_table));
    }
    if let Some(targets) = m.get("target").and_then(toml::Value::as_table) {
        for t in targets.values() {
            for kind in kinds {
                tables.extend(t.get(kind).and_then(toml::Value::as_table));
            }
        }
    }
    tables.iter().flat_map(|t| t.keys().cloned()).collect()
}

/// A board is the flashed product's wiring: it takes its configuration from `ballisto-config`
/// and never builds, links or tests against the simulator (or the ground tool, which pulls it
/// in). Checked for every dependency kind, build scripts included.
#[test]
fn no_board_depends_on_the_simulator() {
    let boards: Vec<String> = members()
        .into_iter()
        .filter(|p| p.starts_with("firmware/boards/"))
        .collect();
    assert!(boards.len() >= 2, "boards: {boards:?}");
    for board in boards {
        let deps = all_dependencies(&board);
        for forbidden in ["hal-sim", "ballisto", "e2e-tests", "test-fixtures"] {
            assert!(
                !deps.contains(forbidden),
                "{board} depends on {forbidden}: a board takes its configuration from \
                 ballisto-config"
            );
        }
    }
}

/// The simulator's register models are the check of the driver crates: they share nothing
/// with them (the bench reader, beside them, reads through the drivers).
#[test]
fn the_register_models_are_independent_of_the_drivers() {
    let dir = root().join("hal-sim/src/sensors");
    let mut files = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let text = read(&path);
        files += 1;
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for driver in ["adxl355::", "lis3dh::", "ballisto_fw"] {
                let uses = code.match_indices(driver).any(|(at, _)| {
                    !code[..at].ends_with("sensors::") && !code[..at].ends_with("super::")
                });
                assert!(!uses, "{}:{}: {line}", path.display(), i + 1);
            }
        }
    }
    assert!(files >= 2, "models in {}", dir.display());
    let bench = read(&root().join("hal-sim/src/bench.rs"));
    assert!(bench.contains("adxl355::Adxl355") && bench.contains("lis3dh::Lis3dh"));
}

/// A manifest parsed.
fn manifest_toml(path: &str) -> toml::Table {
    read(&root().join(path).join("Cargo.toml"))
        .parse()
        .unwrap_or_else(|e| panic!("{path}/Cargo.toml: {e}"))
}

/// The features a manifest declares.
fn declared_features(path: &str) -> BTreeSet<String> {
    manifest_toml(path)
        .get("features")
        .and_then(toml::Value::as_table)
        .map(|t| t.keys().cloned().collect())
        .unwrap_or_default()
}

/// Every declaration of `dep` in a manifest (normal and target-specific dependencies): its
/// features and whether it keeps the default ones.
fn uses_of(path: &str, dep: &str) -> Vec<(BTreeSet<String>, bool)> {
    let m = manifest_toml(path);
    let mut tables: Vec<&toml::Table> = Vec::new();
    if let Some(t) = m.get("dependencies").and_then(toml::Value::as_table) {
        tables.push(t);
    }
    if let Some(targets) = m.get("target").and_then(toml::Value::as_table) {
        for t in targets.values() {
            if let Some(d) = t.get("dependencies").and_then(toml::Value::as_table) {
                tables.push(d);
            }
        }
    }
    tables
        .iter()
        .filter_map(|t| t.get(dep))
        .map(|v| {
            let features = v
                .get("features")
                .and_then(toml::Value::as_array)
                .map(|a| {
                    a.iter()
                        .filter_map(|f| f.as_str().map(str::to_string))
                        .collect()
                })
                .unwrap_or_default();
            let defaults = v
                .get("default-features")
                .and_then(toml::Value::as_bool)
                .unwrap_or(true);
            (features, defaults)
        })
        .collect()
}

fn set(names: &[&str]) -> BTreeSet<String> {
    names.iter().map(|s| s.to_string()).collect()
}

/// No cargo feature changes what the firmware does. The crates the flashed image is
/// made of declare only features that add without changing behaviour — `defmt` (the log's
/// transport), `ground` (the link's decoder), `double-fpu` (the same square roots by the M7's
/// instruction) — and no default features.
#[test]
fn no_feature_changes_what_the_firmware_does() {
    for (path, allowed) in [
        ("firmware/app", set(&["defmt"])),
        ("estimator-core", set(&["defmt", "double-fpu"])),
        ("link", set(&["defmt", "ground"])),
        ("firmware/calstore", set(&["defmt"])),
        ("drivers/adxl355", set(&["defmt"])),
        ("drivers/lis3dh", set(&["defmt"])),
    ] {
        let declared = declared_features(path);
        assert!(
            declared.is_subset(&allowed),
            "{path} declares {:?}: only {allowed:?} may exist (features that add, not change)",
            declared.difference(&allowed).collect::<Vec<_>>()
        );
        assert!(!declared.contains("default"), "{path}: default features");
    }
}

/// The STM32H743 flight image runs the application the QEMU board, the host
/// simulator and the ground tool run: each depends on `ballisto-fw` with its default features
/// and nothing but `defmt`, which only routes the log.
#[test]
fn the_flashed_application_is_the_tested_one() {
    let only_adding = set(&["defmt"]);
    let mut seen = BTreeMap::new();
    for path in [
        "firmware/boards/stm32h743",
        "firmware/boards/qemu",
        "hal-sim",
        "ballisto",
        "firmware/qemu-bench",
        "tests",
    ] {
        let uses = uses_of(path, "ballisto-fw");
        assert_eq!(uses.len(), 1, "{path}: one dependency on ballisto-fw");
        let (features, defaults) = &uses[0];
        assert!(
            *defaults,
            "{path}: ballisto-fw with default-features = false"
        );
        assert!(
            features.is_subset(&only_adding),
            "{path}: ballisto-fw with {features:?}"
        );
        seen.insert(path, features.clone());
    }
    assert_eq!(seen["firmware/boards/stm32h743"], set(&["defmt"]));
    // The estimator-core and link every build gets: no feature beyond those that add.
    for path in [
        "firmware/boards/stm32h743",
        "firmware/boards/qemu",
        "hal-sim",
    ] {
        for dep in ["estimator-core", "ballisto-link"] {
            for (features, _) in uses_of(path, dep) {
                assert!(
                    features.is_subset(&set(&["defmt", "double-fpu", "ground"])),
                    "{path}: {dep} with {features:?}"
                );
            }
        }
    }
}
