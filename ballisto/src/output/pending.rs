//! An output being written, and where it goes: stdout, a special file in place, or a
//! temporary file beside a regular one, renamed onto it when complete.

use std::fs::{File, Metadata, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::{is_std, signals};

/// An output being written, committed by [`Pending::commit`] (or [`finish`]); dropped
/// uncommitted, its temporary file is removed and the previous file stays as it was.
#[derive(Debug)]
pub struct Pending {
    /// The path as the user named it (for messages).
    dest: PathBuf,
    target: Target,
}

#[derive(Debug)]
enum Target {
    /// `-`.
    Stdout,
    /// A device, a FIFO or a socket: written in place (it has no previous contents to keep,
    /// and replacing it by a regular file would destroy it).
    Special(PathBuf),
    /// A regular file, or none yet: a temporary beside `real` (the file a symbolic link
    /// points to, else the path), removed on drop.
    Temporary {
        tmp: Option<tempfile::TempPath>,
        real: PathBuf,
    },
}

/// Where an output's bytes go: its temporary file, a special file, or stdout.
pub enum Sink {
    /// The temporary file beside the destination, or the special file itself.
    File(BufWriter<File>),
    /// Stdout (`-`).
    Stdout(BufWriter<signals::Stdout>),
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

/// Most symbolic links followed to the file an output names (the kernel's own limit).
const MAX_LINKS: usize = 40;

/// The file `dest` names through its symbolic links, whether or not it exists yet.
fn through_links(dest: &Path) -> Result<PathBuf, String> {
    let mut path = dest.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.file_type().is_symlink() => {
                let to = std::fs::read_link(&path)
                    .map_err(|e| format!("{}: cannot read the link: {e}", dest.display()))?;
                path = path.parent().unwrap_or(Path::new("")).join(to);
            }
            _ => return Ok(path),
        }
    }
    Err(format!(
        "{}: more than {MAX_LINKS} symbolic links in a row",
        dest.display()
    ))
}

/// Whether the user may write `path` (as `cp` and `>` decide: the access the kernel would give).
fn writable(path: &Path) -> bool {
    use std::os::unix::ffi::OsStrExt;
    let Ok(c) = std::ffi::CString::new(path.as_os_str().as_bytes()) else {
        return false;
    };
    // SAFETY: `c` is a valid NUL-terminated path; access(2) only reads it.
    unsafe { libc::access(c.as_ptr(), libc::W_OK) == 0 }
}

/// A temporary file beside `real` for an output that replaces `previous` (if any): its
/// extension kept (plot writers choose the format by it), the previous file's mode and owner
/// given to it.
fn temporary(
    dest: &Path,
    real: &Path,
    previous: Option<&Metadata>,
) -> Result<(File, tempfile::TempPath), String> {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let dir = real.parent().filter(|d| !d.as_os_str().is_empty());
    let stem = real
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = real
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let named = tempfile::Builder::new()
        .prefix(&format!(".{stem}."))
        .suffix(&format!(".tmp{ext}"))
        // A new output is created as `>` creates it: 0666 less the umask.
        .permissions(std::fs::Permissions::from_mode(0o666))
        .tempfile_in(dir.unwrap_or(Path::new(".")))
        .map_err(|e| format!("{}: cannot create: {e}", dest.display()))?;
    let (file, tmp) = named.into_parts();
    signals::register(&tmp);
    if let Some(m) = previous {
        file.set_permissions(m.permissions())
            .map_err(|e| format!("{}: cannot keep its mode: {e}", dest.display()))?;
        let own = file
            .metadata()
            .map_err(|e| format!("{}: cannot create: {e}", dest.display()))?;
        if (own.uid(), own.gid()) != (m.uid(), m.gid()) {
            std::os::unix::fs::fchown(&file, Some(m.uid()), Some(m.gid())).map_err(|e| {
                format!(
                    "{}: cannot keep its owner (uid {}, gid {}): {e}; write it as its owner or remove it first",
                    dest.display(),
                    m.uid(),
                    m.gid()
                )
            })?;
        }
    }
    Ok((file, tmp))
}

impl Pending {
    /// Prepares the output `dest`: refused if it is a directory or the user may not write
    /// it; a temporary file beside a regular file (or where none is yet), its extension kept.
    pub fn new(dest: &Path) -> Result<(Self, Option<File>), String> {
        if is_std(dest) {
            return Ok((
                Pending {
                    dest: dest.to_path_buf(),
                    target: Target::Stdout,
                },
                None,
            ));
        }
        let real = through_links(dest)?;
        let (target, file) = match std::fs::metadata(&real) {
            Ok(m) if m.is_dir() => {
                return Err(format!("{}: is a directory: name a file", dest.display()))
            }
            Ok(_) if !writable(&real) => {
                return Err(format!(
                "{}: not writable: refusing to replace it (change its mode or name another output)",
                dest.display()
            ))
            }
            Ok(m) if !m.is_file() => (Target::Special(real), None),
            Ok(m) => {
                let (file, tmp) = temporary(dest, &real, Some(&m))?;
                let target = Target::Temporary {
                    tmp: Some(tmp),
                    real,
                };
                (target, Some(file))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let (file, tmp) = temporary(dest, &real, None)?;
                let target = Target::Temporary {
                    tmp: Some(tmp),
                    real,
                };
                (target, Some(file))
            }
            Err(e) => return Err(format!("{}: cannot write: {e}", dest.display())),
        };
        Ok((
            Pending {
                dest: dest.to_path_buf(),
                target,
            },
            file,
        ))
    }

    /// Where to write by path (a plot writer opens it itself): the temporary file, the
    /// special file, or `-`.
    pub fn path(&self) -> &Path {
        match &self.target {
            Target::Stdout => &self.dest,
            Target::Special(p) => p,
            Target::Temporary { tmp, real } => tmp.as_deref().unwrap_or(real),
        }
    }

    /// The output as the user named it.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Puts the complete file in place (one rename: atomic on one file system).
    pub fn commit(mut self) -> Result<(), String> {
        if let Target::Temporary { tmp, real } = &mut self.target {
            if let Some(t) = tmp.take() {
                let path = t.to_path_buf();
                t.persist(&*real)
                    .map_err(|e| format!("{}: cannot write: {}", self.dest.display(), e.error))?;
                signals::unregister(&path);
            }
        }
        Ok(())
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if let Target::Temporary { tmp: Some(t), .. } = &self.target {
            signals::unregister(t);
        }
    }
}

/// An output opened for writing (buffered), and its [`Pending`] to commit once it is
/// flushed; `-` is stdout.
pub fn create(dest: &Path) -> Result<(Pending, Sink), String> {
    let (pending, file) = Pending::new(dest)?;
    let file = match (&pending.target, file) {
        (Target::Stdout, _) => {
            let sink = Sink::Stdout(BufWriter::with_capacity(1 << 16, signals::Stdout));
            return Ok((pending, sink));
        }
        (_, Some(temporary)) => temporary,
        // A special file, written in place.
        (_, None) => OpenOptions::new()
            .write(true)
            .open(pending.path())
            .map_err(|e| format!("{}: cannot open: {e}", dest.display()))?,
    };
    Ok((pending, Sink::File(BufWriter::with_capacity(1 << 16, file))))
}

/// Flushes `w` (a regular file to disk) and puts the file in place.
pub fn finish(pending: Pending, w: Sink) -> Result<(), String> {
    let dest = pending.dest().display().to_string();
    let failed = |e: std::io::Error| format!("{dest}: write failed: {e}");
    match w {
        Sink::File(w) => {
            let file = w.into_inner().map_err(|e| failed(e.into_error()))?;
            if matches!(pending.target, Target::Temporary { .. }) {
                file.sync_all().map_err(failed)?;
            }
        }
        Sink::Stdout(mut w) => w.flush().map_err(failed)?,
    }
    pending.commit()
}

/// Writes `bytes` to `dest` as [`create`] and [`finish`] do.
pub fn write(dest: &Path, bytes: &[u8]) -> Result<(), String> {
    let (pending, mut w) = create(dest)?;
    w.write_all(bytes)
        .map_err(|e| format!("{}: write failed: {e}", dest.display()))?;
    finish(pending, w)
}
