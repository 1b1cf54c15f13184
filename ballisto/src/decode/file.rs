//! `ballisto decode` of a recorded stream, in bounded memory: the input read in pieces through
//! the [`StreamDecoder`] (the same checks as a live capture), each motion report written to
//! the estimates as it is decoded, the log spooled to an unnamed temporary file and written
//! (or printed) at the end in its documented order — the reports, the telecommands never
//! answered, then the problems. What stays in memory is the identification reports (for
//! `--calibration`) and the first problems, for the summary.

use std::collections::{HashMap, HashSet};
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, Write};
use std::path::Path;

use ballisto_link::decode::{Decoded, Report};
use ballisto_link::RequestId;

use super::{log_line, RowWriter, Stream, StreamDecoder};

/// Where the log goes.
#[derive(Clone, Copy, Debug)]
pub enum LogTo<'a> {
    /// A file (written beside, then put in place, as every output).
    File(&'a Path),
    /// Stdout (the estimates went to a file).
    Stdout,
    /// Stderr (the estimates own stdout).
    Stderr,
    /// Nowhere (`--quiet` with the estimates on stdout).
    Nowhere,
}

/// What `ballisto decode` is asked to do.
pub struct DecodeJob<'a> {
    /// The recorded stream (`-`: stdin; gzip-compressed read as such).
    pub input: &'a Path,
    /// The estimates file (`-`: stdout).
    pub out: &'a Path,
    /// The log.
    pub log: LogTo<'a>,
    /// Seconds added to each packet's on-board time.
    pub time_offset: f64,
    /// The telecommands sent (`--commands`), named in the log beside their answers.
    pub sent: &'a HashMap<RequestId, String>,
    /// How many problems to keep for the caller's listing (the log has them all).
    pub keep_problems: usize,
    /// A progress bar on stderr (drawn only on a terminal).
    pub progress: bool,
}

/// What a decode found.
#[derive(Debug, Default)]
pub struct Decoding {
    /// Packets that passed every check.
    pub packets: u64,
    /// Motion reports written.
    pub rows: u64,
    /// Problems found (all in the log).
    pub problems: u64,
    /// The first [`DecodeJob::keep_problems`] of them.
    pub listed: Vec<String>,
    /// The identification reports (TM\[200,128\], TM\[200,129\]), for
    /// [`super::identified_arrangement`].
    pub identification: Stream,
}

/// Bytes read at a time.
const PIECE: usize = 1 << 16;

/// `ballisto decode`: reads `job.input` in pieces, writes the estimates and the log. Nothing is
/// written when the input holds no packet at all (the wrong file, not damaged telemetry). The
/// caller has checked every output against every input first (`crate::output::check_distinct`:
/// the command line also names `--calibration`, `--arrangement` and `--commands`).
pub fn decode_file(job: &DecodeJob) -> Result<Decoding, String> {
    let name = job.input.display().to_string();
    let mut input =
        crate::output::open_input(job.input).map_err(|e| format!("{name}: cannot open: {e}"))?;
    let spool = |what: &str| {
        tempfile::tempfile()
            .map(BufWriter::new)
            .map_err(|e| format!("cannot create a temporary file for the {what}: {e}"))
    };
    let mut d = Decoder {
        job,
        rows: RowWriter::new(job.time_offset),
        header: false,
        log: spool("log")?,
        problems: spool("problems")?,
        answered: HashSet::new(),
        found: Decoding::default(),
    };
    let (pending, mut out) = crate::output::create(job.out)?;
    let bar = crate::progress::reading(job.progress, job.input, "decode");
    let mut decoder = StreamDecoder::default();
    let mut buf = vec![0u8; PIECE];
    let mut read = 0u64;
    loop {
        let n = match input.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(format!("{name}: cannot read: {e}")),
        };
        read += n as u64;
        bar.set_position(read);
        let mut piece = Stream::default();
        decoder.push(&buf[..n], &mut piece);
        d.take(piece, &mut out)?;
    }
    let mut end = Stream::default();
    decoder.finish(&mut end);
    d.take(end, &mut out)?;
    bar.finish_and_clear();
    if read == 0 {
        return Err(format!("{name}: empty: no telemetry"));
    }
    if d.found.packets == 0 {
        return Err(format!(
            "{name}: not telemetry: no packet in {read} bytes ({}; nothing written)",
            d.found
                .listed
                .first()
                .map_or_else(|| "no frame".to_string(), |p| format!("first: {p}"))
        ));
    }
    crate::output::finish(pending, out)?;
    d.unanswered()?;
    let Decoder {
        log,
        problems,
        found,
        ..
    } = d;
    write_log(job.log, [rewound(log)?, rewound(problems)?])?;
    Ok(found)
}

/// The decoder's state between pieces.
struct Decoder<'a> {
    job: &'a DecodeJob<'a>,
    rows: RowWriter,
    /// Whether the estimates' header is written (at the first packet: an input without one
    /// writes nothing, not even to stdout).
    header: bool,
    log: BufWriter<File>,
    problems: BufWriter<File>,
    answered: HashSet<RequestId>,
    found: Decoding,
}

impl Decoder<'_> {
    /// A piece's packets and problems: rows to `out`, lines to the spools.
    fn take(&mut self, piece: Stream, out: &mut impl Write) -> Result<(), String> {
        let failed = |e: std::io::Error| format!("{}: write failed: {e}", self.job.out.display());
        for p in piece.packets {
            self.found.packets += 1;
            if !self.header {
                self.rows.header(out).map_err(failed)?;
                self.header = true;
            }
            self.found.rows += u64::from(self.rows.packet(out, &p).map_err(failed)?);
            self.log_packet(&p)?;
            if matches!(
                p.report,
                Report::IdentificationSummary(_) | Report::IdentifiedChannel(_)
            ) {
                self.found.identification.packets.push(p);
            }
        }
        for problem in piece.problems {
            self.found.problems += 1;
            writeln!(self.problems, "PROBLEM {problem}").map_err(spool_err)?;
            if self.found.listed.len() < self.job.keep_problems {
                self.found.listed.push(problem);
            }
        }
        Ok(())
    }

    /// The log line of `p`, naming the telecommand it answers.
    fn log_packet(&mut self, p: &Decoded) -> Result<(), String> {
        let Some(mut line) = log_line(p, self.job.time_offset) else {
            return Ok(());
        };
        if let Report::Verification(v) = &p.report {
            if let Some(what) = self.job.sent.get(&v.request) {
                line += " -- ";
                line += what;
                self.answered.insert(v.request);
            }
        }
        writeln!(self.log, "{line}").map_err(spool_err)
    }

    /// The telecommands sent that no report answered.
    fn unanswered(&mut self) -> Result<(), String> {
        let mut unanswered: Vec<(&RequestId, &String)> = self
            .job
            .sent
            .iter()
            .filter(|(id, _)| !self.answered.contains(*id))
            .collect();
        unanswered.sort_by_key(|(id, _)| id.sequence);
        for (id, what) in unanswered {
            writeln!(
                self.log,
                "NO VERIFICATION TC {:#06x}/{:#06x} -- {what} (not received, refused before its header, or sent without acknowledgement flags)",
                id.packet_id, id.sequence
            )
            .map_err(spool_err)?;
        }
        Ok(())
    }
}

fn spool_err(e: std::io::Error) -> String {
    format!("the log's temporary file: {e}")
}

/// A spool flushed and read again from its start.
fn rewound(w: BufWriter<File>) -> Result<BufReader<File>, String> {
    let mut f = w.into_inner().map_err(|e| spool_err(e.into_error()))?;
    f.rewind().map_err(spool_err)?;
    Ok(BufReader::new(f))
}

/// The spooled log (its reports and unanswered telecommands, then its problems) to where it
/// goes.
fn write_log(to: LogTo, parts: [BufReader<File>; 2]) -> Result<(), String> {
    let copy = |w: &mut dyn Write| -> std::io::Result<()> {
        for mut part in parts {
            std::io::copy(&mut part, w)?;
        }
        w.flush()
    };
    match to {
        LogTo::File(path) => {
            let (pending, mut w) = crate::output::create(path)?;
            copy(&mut w).map_err(|e| format!("{}: write failed: {e}", path.display()))?;
            crate::output::finish(pending, w)
        }
        LogTo::Stdout => copy(&mut BufWriter::new(crate::output::signals::Stdout))
            .map_err(|e| format!("stdout: write failed: {e}")),
        // Diagnostics: a stderr that cannot be written to is no failure of the decode's.
        LogTo::Stderr => {
            let _ = copy(&mut std::io::stderr().lock());
            Ok(())
        }
        LogTo::Nowhere => Ok(()),
    }
}
