//! Progress bars for long runs, on stderr and only on a terminal (indicatif draws nothing
//! when stderr is a file or a pipe, so scripts and logs see only the summaries).

/// A bar of `len` steps drawn with `template` (indicatif's syntax); hidden unless `show`.
pub fn bar(show: bool, len: u64, template: &str) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
        bar.set_style(style);
    }
    bar
}

/// The bar of a command reading `input`: the bytes read of its size, or (compressed, stdin) the
/// bytes read alone; `verb` names the command.
pub fn reading(show: bool, input: &std::path::Path, verb: &str) -> indicatif::ProgressBar {
    let plain_size = std::fs::metadata(input)
        .ok()
        .filter(|m| m.is_file() && !crate::output::is_std(input))
        .filter(|_| input.extension().is_none_or(|e| e != "gz"))
        .map(|m| m.len());
    match plain_size {
        Some(len) => bar(
            show,
            len,
            &format!("{verb} {{bar:30}} {{bytes}}/{{total_bytes}} ({{elapsed}}, {{eta}} left)"),
        ),
        None => bar(
            show,
            u64::MAX,
            &format!("{verb} {{spinner}} {{bytes}} read ({{elapsed}})"),
        ),
    }
}
