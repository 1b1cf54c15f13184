//! The README is documentation for users: its first two lines are the fresh-machine commands
//! (and the scripts they name exist), it stays under 400 lines, and neither it nor `docs/`
//! reads as a development diary ("stop N").

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn the_readme_starts_with_the_two_commands_and_stays_short() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines.len() <= 400, "README.md has {} lines", lines.len());
    assert!(
        lines[0]
            .trim_start()
            .starts_with("bash scripts/main-job.sh"),
        "{}",
        lines[0]
    );
    assert!(
        lines[1]
            .trim_start()
            .starts_with("bash scripts/setup.sh && bash scripts/test.sh"),
        "{}",
        lines[1]
    );
    for script in ["main-job.sh", "setup.sh", "test.sh", "validate.sh"] {
        assert!(root().join("scripts").join(script).exists(), "{script}");
    }
    let ci = std::fs::read_to_string(root().join(".ci/run")).unwrap();
    assert!(
        ci.contains("scripts/setup.sh") && ci.contains("scripts/test.sh"),
        "{ci}"
    );
}

#[test]
fn no_development_diary_in_the_documentation() {
    let mut pages = vec![root().join("README.md")];
    for e in std::fs::read_dir(root().join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            pages.push(p);
        }
    }
    for page in pages {
        let text = std::fs::read_to_string(&page).unwrap();
        for (i, line) in text.lines().enumerate() {
            let lower = line.to_lowercase();
            let diary = lower.match_indices("stop ").any(|(at, _)| {
                lower[at + 5..]
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_ascii_digit())
            });
            assert!(!diary, "{}:{}: {line}", page.display(), i + 1);
        }
    }
}
