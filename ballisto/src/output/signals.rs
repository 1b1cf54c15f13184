//! What an interruption leaves: on SIGINT, SIGTERM or SIGHUP the temporary files of outputs not
//! yet complete are removed before the process ends as the signal ends it (their previous
//! files stay as they were); a reader of stdout that goes away (`| head`) ends the command
//! quietly instead of in a panic.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// The temporary files of outputs being written.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Whether a write to stdout found its reader gone.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Adds a temporary file (or a scratch directory) to those removed on a signal.
pub(super) fn register(path: &Path) {
    if let Ok(mut t) = TEMPORARIES.lock() {
        t.push(path.to_path_buf());
    }
}

/// Takes a temporary file off the list (renamed into place, or removed).
pub(super) fn unregister(path: &Path) {
    if let Ok(mut t) = TEMPORARIES.lock() {
        t.retain(|p| p != path);
    }
}

/// Starts the thread that removes the temporaries on SIGINT, SIGTERM and SIGHUP, then ends the
/// process as the signal would have (a shell sees 130 for Ctrl-C). Called once, by `main`.
pub fn remove_temporaries_on_signals() -> std::io::Result<()> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])?;
    std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                // The lock is never held across a write: at worst this waits for a push.
                let held = TEMPORARIES.lock();
                if let Ok(list) = &held {
                    for p in list.iter() {
                        if p.is_dir() {
                            let _ = std::fs::remove_dir_all(p);
                        } else {
                            let _ = std::fs::remove_file(p);
                        }
                    }
                }
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                std::process::exit(128 + signal);
            }
        })?;
    Ok(())
}

/// Whether stdout's reader went away during the command: its error is then no failure of the
/// command's (`main` ends quietly, exit 0).
pub fn stdout_closed() -> bool {
    STDOUT_CLOSED.load(Ordering::Relaxed)
}

/// Stdout, noting a reader that went away ([`stdout_closed`]).
pub struct Stdout;

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        noted(std::io::stdout().lock().write(buf))
    }

    fn flush(&mut self) -> std::io::Result<()> {
        noted(std::io::stdout().lock().flush())
    }
}

fn noted<T>(r: std::io::Result<T>) -> std::io::Result<T> {
    if let Err(e) = &r {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            STDOUT_CLOSED.store(true, Ordering::Relaxed);
        }
    }
    r
}

/// Prints `text` on stdout (a command's result, e.g. `compare`'s figures).
pub fn print(text: &str) -> Result<(), String> {
    let mut out = Stdout;
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(|e| format!("stdout: write failed: {e}"))
}
