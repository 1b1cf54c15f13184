//! `docs/architecture.md` agrees with the workspace: its crate table lists every member of the
//! workspace, at its path, with exactly the workspace crates it depends on (normal and
//! target-specific dependencies; dev-dependencies are not part of the architecture).

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

/// A manifest's package name and the names of its normal and target dependencies.
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
            || (section.starts_with("[target.") && section.ends_with(".dependencies]"));
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
