//! Outputs written without losing data. An output that is one of the command's
//! inputs — the same file by identity (`same-file`: device and inode), not by name, so a
//! second path, a hard link, or the file stdin or stdout is — is refused before anything is
//! written. A regular output is written to a temporary file beside it and renamed into place
//! only when it is complete, with the previous file's mode and owner: a failed or interrupted
//! run (SIGINT, SIGTERM, SIGHUP included: [`signals`]) leaves the previous file (or none),
//! never half of one, and no temporary. An output the user may not write is refused, as `cp`
//! refuses it. A symbolic link is written through (the file it points to is replaced, the link
//! stays); a device, a FIFO or a socket is written in place, as it goes.
//!
//! `-` names stdout as an output (and stdin as an input, [`open_input`]), written as it goes; a
//! reader that goes away (`| head`) ends the command quietly ([`signals::stdout_closed`]).

mod pending;
pub mod signals;

pub use pending::{create, finish, write, Pending, Sink};

/// A scratch directory inside an output directory, for records not kept: removed when dropped,
/// and on SIGINT, SIGTERM or SIGHUP ([`signals`]).
pub struct Scratch(tempfile::TempDir);

impl Scratch {
    /// A new hidden directory in `dir`.
    pub fn new(dir: &Path) -> Result<Self, String> {
        let d = tempfile::Builder::new()
            .prefix(".ballisto-scratch.")
            .tempdir_in(dir)
            .map_err(|e| format!("{}: cannot create a scratch directory: {e}", dir.display()))?;
        signals::register(d.path());
        Ok(Scratch(d))
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        self.0.path()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        signals::unregister(self.0.path());
    }
}

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// Whether `path` is `-`: stdin as an input, stdout as an output.
pub fn is_std(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// The first octets of a gzip stream (RFC 1952).
const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// Opens an input for buffered reading: the file, or stdin for `-`. A gzip-compressed input
/// (recognised by its first octets, whatever its name) is decompressed as it is read, so a
/// recording can be kept as `samples.csv.gz` and read without unpacking it first.
pub fn open_input(path: &Path) -> std::io::Result<Box<dyn BufRead + Send>> {
    let mut reader: Box<dyn BufRead + Send> = if is_std(path) {
        Box::new(BufReader::with_capacity(1 << 16, std::io::stdin()))
    } else {
        Box::new(BufReader::with_capacity(1 << 16, File::open(path)?))
    };
    if reader.fill_buf()?.starts_with(&GZIP_MAGIC) {
        let decoder = flate2::bufread::MultiGzDecoder::new(reader);
        return Ok(Box::new(BufReader::with_capacity(1 << 16, decoder)));
    }
    Ok(reader)
}

/// Reads a whole input: the file, or stdin for `-`.
pub fn read_input(path: &Path) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    open_input(path)
        .map_err(|e| format!("{}: cannot open: {e}", path.display()))?
        .read_to_end(&mut bytes)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    Ok(bytes)
}

/// Refuses outputs that are the same file as an input, or as each other (two outputs both on
/// stdout included), an output that is the file stdin reads (an input `-`) or an input that
/// is the file stdout writes (an output `-`), outputs that are directories, and outputs in a
/// directory that does not exist (before any work is done, not after it).
pub fn check_distinct(outputs: &[&Path], inputs: &[&Path]) -> Result<(), String> {
    for out in outputs.iter().filter(|p| !is_std(p)) {
        if out.is_dir() {
            return Err(format!("{}: is a directory: name a file", out.display()));
        }
        let dir = out.parent().filter(|d| !d.as_os_str().is_empty());
        if let Some(dir) = dir.filter(|d| !d.is_dir()) {
            return Err(format!(
                "{}: the directory {} does not exist",
                out.display(),
                dir.display()
            ));
        }
    }
    let stdin_read = inputs.iter().any(|p| is_std(p));
    for (i, out) in outputs.iter().enumerate() {
        for input in inputs.iter().filter(|p| !is_std(p)) {
            if same_file(out, input) {
                return Err(format!(
                    "{}: is the input {}: refusing to overwrite an input (name another output)",
                    if is_std(out) {
                        "stdout".to_string()
                    } else {
                        out.display().to_string()
                    },
                    input.display()
                ));
            }
        }
        if stdin_read && !is_std(out) && is_stdin(out) {
            return Err(format!(
                "{}: is the input read on stdin: refusing to overwrite an input (name another output)",
                out.display()
            ));
        }
        for other in &outputs[..i] {
            if same_file(out, other) || out == other {
                return Err(format!(
                    "{}: named for two outputs (the other as {})",
                    out.display(),
                    other.display()
                ));
            }
        }
    }
    Ok(())
}

/// Whether `path` is the file stdin reads.
fn is_stdin(path: &Path) -> bool {
    match (
        same_file::Handle::stdin(),
        same_file::Handle::from_path(path),
    ) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// Whether output `a` and `b` name one existing file; `-` is the file stdout writes (when it
/// is a file). Inputs `-` are checked by [`is_stdin`].
fn same_file(a: &Path, b: &Path) -> bool {
    let handle = |p: &Path| {
        if is_std(p) {
            same_file::Handle::stdout().ok()
        } else {
            same_file::Handle::from_path(p).ok()
        }
    };
    if is_std(a) && is_std(b) {
        return false;
    }
    matches!((handle(a), handle(b)), (Some(x), Some(y)) if x == y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::path::PathBuf;

    fn dir() -> PathBuf {
        let d = std::env::temp_dir().join(format!("ballisto-output-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_gzip_input_reads_as_its_text_and_a_plain_one_as_itself() {
        let d = dir();
        let text = "t,a\n0,1\n".repeat(5000);
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(text.as_bytes()).unwrap();
        let packed = d.join("gz-input.csv.gz");
        std::fs::write(&packed, gz.finish().unwrap()).unwrap();
        assert_eq!(read_input(&packed).unwrap(), text.as_bytes());
        let plain = d.join("plain-input.csv");
        std::fs::write(&plain, &text).unwrap();
        assert_eq!(read_input(&plain).unwrap(), text.as_bytes());
        // A truncated stream is an error, not a short text.
        let bytes = std::fs::read(&packed).unwrap();
        std::fs::write(&packed, &bytes[..bytes.len() / 2]).unwrap();
        assert!(read_input(&packed).is_err());
    }

    #[test]
    fn an_output_that_is_an_input_is_refused_by_identity() {
        let d = dir();
        let input = d.join("samples.csv");
        std::fs::write(&input, "t,a\n0,1\n").unwrap();
        // The same file by another name: a path through `.`, and a hard link.
        let dotted = d.join(".").join("samples.csv");
        let link = d.join("link.csv");
        let _ = std::fs::remove_file(&link);
        std::fs::hard_link(&input, &link).unwrap();
        for out in [&input, &dotted, &link] {
            let e = check_distinct(&[out], &[&input]).unwrap_err();
            assert!(e.contains("refusing to overwrite an input"), "{e}");
        }
        assert!(check_distinct(&[&d.join("estimates.csv")], &[&input]).is_ok());
        let e = check_distinct(&[&d.join("x.csv"), &d.join("x.csv")], &[]).unwrap_err();
        assert!(e.contains("two outputs"), "{e}");
    }

    #[test]
    fn an_output_is_in_place_whole_or_not_at_all() {
        let d = dir();
        let dest = d.join("out.csv");
        std::fs::write(&dest, "old").unwrap();
        {
            // Abandoned half-way (an error or a crash before the commit).
            let (p, mut w) = create(&dest).unwrap();
            w.write_all(b"half").unwrap();
            w.flush().unwrap();
            assert!(p.path().exists());
            assert_eq!(std::fs::read_to_string(&dest).unwrap(), "old");
        }
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "old");
        let leftovers = std::fs::read_dir(&d)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .contains(".tmp")
            })
            .count();
        assert_eq!(leftovers, 0, "no temporary file left");
        write(&dest, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "new");
        // The extension is kept (plot writers choose the format by it).
        let (plot, _) = Pending::new(&d.join("plot.png")).unwrap();
        assert!(plot.path().to_string_lossy().ends_with(".tmp.png"));
    }
}
