//! The README is for users: it states no measured figure (those live in the generated
//! `docs/validation.md`, so that no figure is typed twice and none drifts), the sections of the
//! report it names exist, and it points at nothing outside the repository.

use std::path::Path;

fn read(path: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Whether `line` has a digit directly before `unit` (a space between allowed).
fn number_before(line: &str, unit: &str) -> bool {
    line.match_indices(unit).any(|(i, _)| {
        line[..i]
            .trim_end()
            .chars()
            .last()
            .is_some_and(|c| c.is_ascii_digit())
    })
}

/// Whether `line` has a number in exponent notation (`2.2e-5`).
fn exponent(line: &str) -> bool {
    let b = line.as_bytes();
    (1..b.len().saturating_sub(2)).any(|i| {
        b[i - 1].is_ascii_digit()
            && b[i] == b'e'
            && (b[i + 1] == b'-' || b[i + 1] == b'+')
            && b[i + 2].is_ascii_digit()
    })
}

#[test]
fn the_readme_states_no_measured_figure() {
    let readme = read("README.md");
    let measured: Vec<(usize, &str)> = readme
        .lines()
        .enumerate()
        .filter(|(_, l)| {
            [
                "×",
                "instructions",
                "B flash",
                "B static RAM",
                "rad/s RMS",
                "rows/s",
            ]
            .iter()
            .any(|u| number_before(l, u))
                || exponent(l)
        })
        .map(|(i, l)| (i + 1, l))
        .collect();
    assert!(
        measured.is_empty(),
        "README lines with a measured figure (it belongs in docs/validation.md): {measured:#?}"
    );
}

#[test]
fn the_report_sections_the_readme_names_exist() {
    let readme = read("README.md");
    let report = read("docs/validation.md");
    let headings: Vec<&str> = report
        .lines()
        .filter_map(|l| l.strip_prefix("## ").or_else(|| l.strip_prefix("### ")))
        .collect();
    let mut named = 0;
    for (i, _) in readme.match_indices("`docs/validation.md`, \"") {
        let rest = &readme[i + "`docs/validation.md`, \"".len()..];
        let name = &rest[..rest.find('"').expect("closing quote")];
        let name = name.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(
            headings.iter().any(|h| h.starts_with(&name)),
            "README names the section \"{name}\" of docs/validation.md, which has {headings:?}"
        );
        named += 1;
    }
    assert!(named > 0, "the README points at no section of the report");
}

#[test]
fn nothing_points_outside_the_repository() {
    for path in [
        "README.md",
        "docs/formats.md",
        "docs/estimator.md",
        "scripts/validate.sh",
    ] {
        let text = read(path);
        assert!(
            // Spelt in two pieces so that this test is not itself a match.
            !text.contains(concat!("..", "/shared")),
            "{path} points outside the repository"
        );
        assert!(
            !text.contains("interfaces.md"),
            "{path} cites interfaces.md, which is not in the repository"
        );
    }
}
