//! `ballisto capture`: the unit's link followed live — a serial port (or a pseudo-terminal), or
//! a file that grows — decoded as the bytes arrive ([`crate::decode::StreamDecoder`]: the
//! checks of `ballisto decode`), each motion report written to the estimates file and each
//! housekeeping, event and verification report to the log as it comes (flushed per chunk
//! read), with a status line on a terminal. A port that goes away (unplugged) is reopened
//! when it is back; a reset of the unit starts a new boot's rows, not lost packets.
//! Telecommand frames (`ballisto tc`'s files) can be sent on the same port first.
//!
//! The outputs are the live record, written as it goes: they must not exist yet (a capture
//! never replaces a previous one), and whatever was received is in them when the capture
//! ends — at `--idle` seconds without a byte (or without the port, once lost), at the end of
//! a file with `--idle 0`, or on Ctrl-C.

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use crate::decode::{is_boot, log_line, RowWriter, Stream, StreamDecoder};

/// What `ballisto capture` is asked to do.
pub struct CaptureJob<'a> {
    /// The serial port (a device or a pseudo-terminal), or a file that grows.
    pub port: &'a Path,
    /// The port's baud rate (8 data bits, no parity, one stop bit: docs/telemetry.md).
    pub baud: u32,
    /// The estimates file (must not exist).
    pub out: &'a Path,
    /// The log (must not exist).
    pub log: &'a Path,
    /// Also keep the raw bytes received here (must not exist), for `ballisto decode` later.
    pub raw: Option<&'a Path>,
    /// Seconds added to each packet's on-board time.
    pub time_offset: f64,
    /// End after this many seconds without a byte (`None`: run until interrupted).
    pub idle: Option<f64>,
    /// Telecommand frames to send on the port once it is open.
    pub send: Vec<Vec<u8>>,
    /// A status line on stderr (drawn only on a terminal).
    pub progress: bool,
    /// Called once the port is open, the outputs created and the frames sent: from here on
    /// nothing that arrives is missed (a script starts the unit then).
    pub on_open: &'a dyn Fn(),
}

/// What a capture received.
#[derive(Debug, Default)]
pub struct CaptureSummary {
    /// Bytes received.
    pub bytes: u64,
    /// Packets that passed every check.
    pub packets: u64,
    /// Motion reports written.
    pub rows: u64,
    /// Of them, rows the unit flagged (any estimate flag set).
    pub flagged: u64,
    /// Problems (damaged frames, lost packets), also in the log.
    pub problems: u64,
    /// Times the port was lost and opened again.
    pub reopened: u32,
    /// Boot events seen.
    pub boots: u32,
}

/// Where the bytes come from.
enum Source {
    Port(Box<dyn serialport::SerialPort>),
    File(File),
}

impl Source {
    /// Opens `path`: a regular file as a file that grows, anything else as a serial port.
    fn open(path: &Path, baud: u32) -> Result<Source, String> {
        let is_file = std::fs::metadata(path).is_ok_and(|m| m.is_file());
        if is_file {
            return File::open(path)
                .map(Source::File)
                .map_err(|e| format!("{}: cannot open: {e}", path.display()));
        }
        serialport::new(path.to_string_lossy(), baud)
            .timeout(Duration::from_millis(100))
            .open()
            .map(Source::Port)
            .map_err(|e| format!("{}: cannot open the port: {e}", path.display()))
    }

    /// Reads what has arrived: `Ok(0)` when nothing did (a timeout, or a file's end).
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            // A port's read waits up to its timeout for a byte: no byte is a timeout, and
            // an end of file is the line hung up (the other side gone).
            Source::Port(p) => match p.read(buf) {
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => Ok(0),
                Ok(0) => Err(hung_up()),
                other => other,
            },
            Source::File(f) => f.read(buf),
        }
    }

    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match self {
            Source::Port(p) => p.write_all(bytes).and_then(|()| p.flush()),
            Source::File(_) => Err(std::io::Error::other(
                "a file is read, not a port: nothing can be sent on it",
            )),
        }
    }
}

/// A port whose line hung up, or whose device is gone.
fn hung_up() -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::BrokenPipe,
        "the line hung up (the device is gone)",
    )
}

/// The error of a failed write to `p`.
fn write_err(p: &Path) -> impl Fn(std::io::Error) -> String + '_ {
    move |e| format!("{}: write failed: {e}", p.display())
}

/// A new output of the capture: refused if it exists.
fn new_output(path: &Path) -> Result<BufWriter<File>, String> {
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
        .map(|f| BufWriter::with_capacity(1 << 16, f))
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::AlreadyExists => format!(
                "{}: exists: a capture never replaces a previous record (name a new file)",
                path.display()
            ),
            _ => format!("{}: cannot create: {e}", path.display()),
        })
}

/// Runs the capture until it is idle for `job.idle` seconds (or interrupted).
pub fn capture(job: &CaptureJob) -> Result<CaptureSummary, String> {
    let mut outputs = vec![job.out, job.log];
    outputs.extend(job.raw);
    crate::output::check_distinct(&outputs, &[job.port])?;
    let mut source = Source::open(job.port, job.baud)?;
    let mut out = new_output(job.out)?;
    let mut log = new_output(job.log)?;
    let mut raw = match job.raw {
        Some(path) => Some((new_output(path)?, path)),
        None => None,
    };
    let mut rows = RowWriter::new(job.time_offset);
    rows.header(&mut out).map_err(write_err(job.out))?;
    out.flush().map_err(write_err(job.out))?;
    for frames in &job.send {
        source
            .send(frames)
            .map_err(|e| format!("{}: cannot send: {e}", job.port.display()))?;
    }
    (job.on_open)();
    let status = crate::progress::bar(job.progress, u64::MAX, "capture {spinner} {msg}");
    let mut decoder = StreamDecoder::default();
    let mut summary = CaptureSummary::default();
    let mut buf = vec![0u8; 1 << 14];
    let mut last_byte = Instant::now();
    let started = Instant::now();
    loop {
        // A device unplugged (a USB adapter, a terminal whose other side closed) may read
        // as silence: its node is gone.
        let read = match source.read(&mut buf) {
            Ok(0) if matches!(source, Source::Port(_)) && !job.port.exists() => Err(hung_up()),
            other => other,
        };
        let n = match read {
            Ok(n) => n,
            Err(e) => {
                // The port went away (unplugged, the unit powered off): what was read of a
                // frame is lost with it; wait for the port to come back.
                let mut stream = Stream::default();
                decoder.interrupted(&mut stream);
                writeln!(log, "PROBLEM the port was lost: {e}").map_err(write_err(job.log))?;
                write_packets(&stream, &mut rows, &mut out, &mut log, job, &mut summary)?;
                match reopen(job, &status, &mut summary) {
                    Some(s) => source = s,
                    None => {
                        writeln!(
                            log,
                            "PROBLEM the port was not back within {} s: the capture ends",
                            job.idle.unwrap_or_default()
                        )
                        .map_err(write_err(job.log))?;
                        break;
                    }
                }
                last_byte = Instant::now();
                continue;
            }
        };
        if n == 0 {
            if job
                .idle
                .is_some_and(|s| last_byte.elapsed().as_secs_f64() >= s)
            {
                break;
            }
            std::thread::sleep(Duration::from_millis(
                if matches!(source, Source::File(_)) {
                    100
                } else {
                    1
                },
            ));
            continue;
        }
        last_byte = Instant::now();
        summary.bytes += n as u64;
        if let Some((r, path)) = raw.as_mut() {
            r.write_all(&buf[..n])
                .and_then(|()| r.flush())
                .map_err(write_err(path))?;
        }
        let mut stream = Stream::default();
        decoder.push(&buf[..n], &mut stream);
        write_packets(&stream, &mut rows, &mut out, &mut log, job, &mut summary)?;
        status.set_message(format!(
            "{} packets, {} rows ({} flagged), {} problems, {} boots, {:.0} B/s",
            summary.packets,
            summary.rows,
            summary.flagged,
            summary.problems,
            summary.boots,
            summary.bytes as f64 / started.elapsed().as_secs_f64().max(1e-3)
        ));
        status.tick();
    }
    let mut stream = Stream::default();
    decoder.finish(&mut stream);
    write_packets(&stream, &mut rows, &mut out, &mut log, job, &mut summary)?;
    status.finish_and_clear();
    for (w, p) in [(&mut out, job.out), (&mut log, job.log)] {
        w.get_ref().sync_all().map_err(write_err(p))?;
    }
    Ok(summary)
}

/// The port opened again once it is back (tried every 0.5 s); `None` when it is not back
/// within `job.idle` s.
fn reopen(
    job: &CaptureJob,
    status: &indicatif::ProgressBar,
    summary: &mut CaptureSummary,
) -> Option<Source> {
    let lost = Instant::now();
    loop {
        status.set_message(format!("{}: lost, waiting for it", job.port.display()));
        status.tick();
        if let Ok(s) = Source::open(job.port, job.baud) {
            summary.reopened += 1;
            return Some(s);
        }
        if job.idle.is_some_and(|s| lost.elapsed().as_secs_f64() >= s) {
            return None;
        }
        std::thread::sleep(Duration::from_millis(500));
    }
}

/// Writes a chunk's packets (rows to the estimates, the rest to the log) and problems, then
/// flushes both: what was received is in the files.
fn write_packets(
    stream: &Stream,
    rows: &mut RowWriter,
    out: &mut BufWriter<File>,
    log: &mut BufWriter<File>,
    job: &CaptureJob,
    summary: &mut CaptureSummary,
) -> Result<(), String> {
    for p in &stream.packets {
        summary.packets += 1;
        if rows.packet(out, p).map_err(write_err(job.out))? {
            summary.rows += 1;
        }
        if let ballisto_link::decode::Report::Motion(m) = &p.report {
            summary.flagged += u64::from(m.estimate.flags.0 != 0);
        }
        summary.boots += u32::from(is_boot(p));
        if let Some(line) = log_line(p, job.time_offset) {
            writeln!(log, "{line}").map_err(write_err(job.log))?;
        }
    }
    for problem in &stream.problems {
        summary.problems += 1;
        writeln!(log, "PROBLEM {problem}").map_err(write_err(job.log))?;
    }
    out.flush().map_err(write_err(job.out))?;
    log.flush().map_err(write_err(job.log))?;
    Ok(())
}
