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
