//! The shape of the code: no source file over 800 lines, and no function of the product (any
//! source outside a `tests/` directory or a `tests.rs` module) over 150 lines, counted from
//! its `fn` line to its closing brace.

use std::path::{Path, PathBuf};

/// Longest source file, in lines.
const FILE_LINES: usize = 800;
/// Longest product function, in lines.
const FN_LINES: usize = 150;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every `.rs` file of the repository (build output and data left out).
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            if !matches!(name.as_str(), "target" | ".git" | "data" | "out" | "docs") {
                sources(&path, out);
            }
        } else if name.ends_with(".rs") {
            out.push(path);
        }
    }
}

/// Whether `line` opens a function: optional visibility and qualifiers, then `fn name`.
fn opens_fn(line: &str) -> Option<&str> {
    let mut rest = line.trim_start();
    loop {
        let before = rest;
        for prefix in [
            "pub(crate) ",
            "pub(super) ",
            "pub ",
            "const ",
            "async ",
            "unsafe ",
        ] {
            rest = rest.strip_prefix(prefix).unwrap_or(rest);
        }
        if let Some(r) = rest.strip_prefix("pub(in ") {
            rest = r.split_once(") ").map_or(r, |(_, tail)| tail);
        }
        rest = rest.strip_prefix("extern \"C\" ").unwrap_or(rest);
        if rest == before {
            break;
        }
    }
    let name = rest.strip_prefix("fn ")?;
    let end = name.find(|c: char| !(c.is_alphanumeric() || c == '_'))?;
    (end > 0).then(|| &name[..end])
}

/// The code of a line: string and character literals emptied, the comment left out.
fn code(line: &str) -> String {
    let mut out = String::new();
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '/' if chars.peek() == Some(&'/') => break,
            '"' => {
                while let Some(d) = chars.next() {
                    match d {
                        '\\' => {
                            chars.next();
                        }
                        '"' => break,
                        _ => {}
                    }
                }
            }
            '\'' => {
                // A character literal ('x', '\n', '{'), not a lifetime.
                let rest: String = chars.clone().take(3).collect();
                if rest.starts_with('\\') {
                    chars.next();
                    chars.next();
                    chars.next();
                } else if rest.chars().nth(1) == Some('\'') {
                    chars.next();
                    chars.next();
                }
            }
            _ => out.push(c),
        }
    }
    out
}

/// Each function of `text` longer than `limit` lines: (name, first line, lines).
fn long_functions(text: &str, limit: usize) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut long = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let Some(name) = opens_fn(line) else { continue };
        let (mut depth, mut opened) = (0i32, false);
        for (j, l) in lines.iter().enumerate().skip(i) {
            let c = code(l);
            for ch in c.chars() {
                match ch {
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            if !opened && c.trim_end().ends_with(';') {
                break;
            }
            if opened && depth <= 0 {
                if j - i + 1 > limit {
                    long.push((name.to_string(), i + 1, j - i + 1));
                }
                break;
            }
        }
    }
    long
}

#[test]
fn no_file_is_too_long_and_no_product_function_either() {
    let root = root();
    let mut files = Vec::new();
    sources(&root, &mut files);
    assert!(files.len() > 100, "{} sources found", files.len());
    let mut problems = Vec::new();
    for path in &files {
        let text = std::fs::read_to_string(path).unwrap();
        let rel = path
            .strip_prefix(&root)
            .unwrap_or(path)
            .display()
            .to_string();
        let lines = text.lines().count();
        if lines > FILE_LINES {
            problems.push(format!("{rel}: {lines} lines"));
        }
        let test_code = rel.split('/').any(|c| c == "tests") || rel.ends_with("tests.rs");
        if !test_code {
            for (name, at, n) in long_functions(&text, FN_LINES) {
                problems.push(format!("{rel}:{at}: fn {name} is {n} lines"));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_counter_sees_a_long_function_and_not_a_string() {
    let body = "    let x = 1;\n".repeat(FN_LINES);
    let text = format!("pub(super) fn long() {{\n{body}}}\nfn short() {{ let s = \"}}{{\"; }}\n");
    let long = long_functions(&text, FN_LINES);
    assert_eq!(long, [("long".to_string(), 1, FN_LINES + 2)]);
    assert!(long_functions("fn declared();\n", 0).is_empty());
    assert_eq!(opens_fn("    pub(in crate::x) async fn go<T>("), Some("go"));
    assert_eq!(opens_fn("    let f = fn_ptr;"), None);
}
