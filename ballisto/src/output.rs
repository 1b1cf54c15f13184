//! Outputs written without losing data (issue 44). An output that is one of the command's
//! inputs — the same file, by identity (device and inode), not by name, so a second path or a
//! hard link to it counts — is refused before anything is written. Every output is written to
//! a temporary file beside its final path and renamed into place only when it is complete: a
//! failed or interrupted run leaves the previous file (or none), never half of one.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Refuses outputs that are the same file as an input, or as each other.
pub fn check_distinct(outputs: &[&Path], inputs: &[&Path]) -> Result<(), String> {
    for (i, out) in outputs.iter().enumerate() {
        for input in inputs {
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

/// Whether `a` and `b` name one existing file.
fn same_file(a: &Path, b: &Path) -> bool {
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
/// [`Pending::commit`]; removed if dropped uncommitted.
#[derive(Debug)]
pub struct Pending {
    tmp: PathBuf,
    dest: PathBuf,
    committed: bool,
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
        std::fs::rename(&self.tmp, &self.dest)
            .map_err(|e| format!("{}: cannot write: {e}", self.dest.display()))?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// An output file opened for writing (buffered), and its [`Pending`] to commit once the file
/// is flushed.
pub fn create(dest: &Path) -> Result<(Pending, BufWriter<File>), String> {
    let pending = Pending::new(dest);
    let file = File::create(pending.path())
        .map_err(|e| format!("{}: cannot create: {e}", dest.display()))?;
    Ok((pending, BufWriter::with_capacity(1 << 16, file)))
}

/// Flushes `w` to disk and puts the file in place.
pub fn finish(pending: Pending, w: BufWriter<File>) -> Result<(), String> {
    let dest = pending.dest().display().to_string();
    let file = w
        .into_inner()
        .map_err(|e| format!("{dest}: write failed: {}", e.error()))?;
    file.sync_all()
        .map_err(|e| format!("{dest}: write failed: {e}"))?;
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
