//! Outputs written without losing data. An output that is one of the command's
//! inputs — the same file, by identity (device and inode), not by name, so a second path or a
//! hard link to it counts — is refused before anything is written. Every output is written to
//! a temporary file beside its final path and renamed into place only when it is complete: a
//! failed or interrupted run leaves the previous file (or none), never half of one.
//!
//! `-` names stdout as an output (and stdin as an input, [`open_input`]): it is never the same
//! file as another path, and is written as it goes.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

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
/// stdout included), and outputs in a directory that does not exist (before any work is done,
/// not after it).
pub fn check_distinct(outputs: &[&Path], inputs: &[&Path]) -> Result<(), String> {
    for out in outputs.iter().filter(|p| !is_std(p)) {
        let dir = out.parent().filter(|d| !d.as_os_str().is_empty());
        if let Some(dir) = dir.filter(|d| !d.is_dir()) {
            return Err(format!(
                "{}: the directory {} does not exist",
                out.display(),
                dir.display()
            ));
        }
    }
    for (i, out) in outputs.iter().enumerate() {
        for input in inputs.iter().filter(|p| !is_std(p)) {
            if same_file(out, input) {
                return Err(format!(
                    "{}: is the input {}: refusing to overwrite an input (name another output)",
                    out.display(),
                    input.display()
                ));
            }
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

/// Whether `a` and `b` name one existing file (stdout is no file).
fn same_file(a: &Path, b: &Path) -> bool {
    if is_std(a) || is_std(b) {
        return false;
    }
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        match (a.canonicalize(), b.canonicalize()) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        }
    }
}

/// An output being written: a temporary file beside `dest`, renamed onto it by
/// [`Pending::commit`]; removed if dropped uncommitted. For `-` (stdout) there is nothing to
/// rename.
#[derive(Debug)]
pub struct Pending {
    tmp: PathBuf,
    dest: PathBuf,
    committed: bool,
}

/// Where an output's bytes go: its temporary file, or stdout.
pub enum Sink {
    /// The temporary file beside the destination.
    File(BufWriter<File>),
    /// Stdout (`-`).
    Stdout(BufWriter<std::io::Stdout>),
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Sink::File(w) => w.write(buf),
            Sink::Stdout(w) => w.write(buf),
        }
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        match self {
            Sink::File(w) => w.write_all(buf),
            Sink::Stdout(w) => w.write_all(buf),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            Sink::File(w) => w.flush(),
            Sink::Stdout(w) => w.flush(),
        }
    }
}

impl Pending {
    /// A temporary path beside `dest`, with its extension (plot writers choose the format by
    /// it): `dir/.name.<pid>.tmp.ext`.
    pub fn new(dest: &Path) -> Self {
        let dir = dest.parent().unwrap_or(Path::new(""));
        let stem = dest
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let ext = dest
            .extension()
            .map(|e| format!(".{}", e.to_string_lossy()))
            .unwrap_or_default();
        let tmp = dir.join(format!(".{stem}.{}.tmp{ext}", std::process::id()));
        Pending {
            tmp,
            dest: dest.to_path_buf(),
            committed: false,
        }
    }

    /// Where to write.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// The final path.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Puts the complete file in place (one rename: atomic on one file system).
    pub fn commit(mut self) -> Result<(), String> {
        if is_std(&self.dest) {
            self.committed = true;
            return Ok(());
        }
        std::fs::rename(&self.tmp, &self.dest)
            .map_err(|e| format!("{}: cannot write: {e}", self.dest.display()))?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if !self.committed && !is_std(&self.dest) {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// An output opened for writing (buffered), and its [`Pending`] to commit once it is
/// flushed; `-` is stdout.
pub fn create(dest: &Path) -> Result<(Pending, Sink), String> {
    let pending = Pending::new(dest);
    if is_std(dest) {
        return Ok((
            pending,
            Sink::Stdout(BufWriter::with_capacity(1 << 16, std::io::stdout())),
        ));
    }
    let file = File::create(pending.path())
        .map_err(|e| format!("{}: cannot create: {e}", dest.display()))?;
    Ok((pending, Sink::File(BufWriter::with_capacity(1 << 16, file))))
}

/// Flushes `w` (to disk) and puts the file in place.
pub fn finish(pending: Pending, w: Sink) -> Result<(), String> {
    let dest = pending.dest().display().to_string();
    let failed = |e: std::io::Error| format!("{dest}: write failed: {e}");
    match w {
        Sink::File(w) => {
            let file = w.into_inner().map_err(|e| failed(e.into_error()))?;
            file.sync_all().map_err(failed)?;
        }
        Sink::Stdout(mut w) => w.flush().map_err(failed)?,
    }
    pending.commit()
}

/// Writes `bytes` to `dest` through a temporary file.
pub fn write(dest: &Path, bytes: &[u8]) -> Result<(), String> {
    let (pending, mut w) = create(dest)?;
    w.write_all(bytes)
        .map_err(|e| format!("{}: write failed: {e}", dest.display()))?;
    finish(pending, w)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(Pending::new(&d.join("plot.png"))
            .path()
            .to_string_lossy()
            .ends_with(".tmp.png"));
    }
}
