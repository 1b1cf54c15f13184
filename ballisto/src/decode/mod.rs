//! The ground side of the telemetry link (`ballisto decode`): a byte stream → packets, each
//! checked (COBS frame, length, CRC, APID, layout) and its sequence count followed, → the
//! estimates file and a readable log of housekeeping, events and verification reports.

use std::fmt::Write as _;
use std::io::Write;

mod file;
mod identified;

pub use file::{decode_file, DecodeJob, Decoding, LogTo};
pub use identified::identified_arrangement;

use ballisto_link::decode::{decode, Decoded, Report};
use ballisto_link::framing::{max_encoded_len, Deframed, Deframer};
use ballisto_link::ids::TC_MAX;
use ballisto_link::{
    subtype, BootEvent, CalibrationSource, EventId, Housekeeping, Mode, ModelCode, PartState,
};

/// Extra columns of the decoded estimates file, after the estimates-file columns.
pub const LINK_COLUMNS: [&str; 5] = [
    "k",
    "missing_parts",
    "excluded_parts",
    "excluded_channels",
    "boot",
];

/// A decoded stream.
#[derive(Debug, Default)]
pub struct Stream {
    /// The packets that passed every check, in order.
    pub packets: Vec<Decoded>,
    /// What was wrong, one sentence each (byte offset of the frame's end).
    pub problems: Vec<String>,
}

/// Splits `bytes` into frames and decodes them; damaged frames, gaps in the sequence count and
/// gaps in each report kind's message type counter (telemetry format 2: which kinds were lost)
/// are listed in [`Stream::problems`], never silently skipped.
pub fn decode_stream(bytes: &[u8]) -> Stream {
    let mut decoder = StreamDecoder::default();
    let mut out = Stream::default();
    decoder.push(bytes, &mut out);
    decoder.finish(&mut out);
    out
}

/// Whether `p` is the unit's boot event: the start of a boot's stream (its counts start
/// again, its `t` is the time since that boot).
pub fn is_boot(p: &Decoded) -> bool {
    matches!(&p.report, Report::Event(e) if e.id == EventId::Boot)
}

/// The decoder of a stream that arrives in pieces (a file, or a live link): the frames and
/// the checks of [`decode_stream`], byte offsets counted from the stream's start.
pub struct StreamDecoder {
    deframer: Deframer<{ max_encoded_len(TC_MAX) }>,
    next: Option<u16>,
    types: TypeCounters,
    /// Where the frame being read began.
    pending_start: u64,
    /// Bytes pushed so far.
    offset: u64,
}

impl Default for StreamDecoder {
    fn default() -> Self {
        StreamDecoder {
            deframer: Deframer::new(),
            next: None,
            types: TypeCounters::default(),
            pending_start: 0,
            offset: 0,
        }
    }
}

impl StreamDecoder {
    /// Decodes `bytes`, the stream's next ones: its packets and problems appended to `out`.
    pub fn push(&mut self, bytes: &[u8], out: &mut Stream) {
        for &b in bytes {
            let offset = self.offset;
            self.offset += 1;
            let frame = match self.deframer.push(b) {
                Deframed::Pending => continue,
                Deframed::Garbage => {
                    Err("not a COBS frame (or longer than any packet)".to_string())
                }
                Deframed::Packet(n) => decode(self.deframer.packet(n)).map_err(|e| e.to_string()),
            };
            let at = self.pending_start;
            self.pending_start = offset + 1;
            match frame {
                Ok(p) => self.follow(p, at, out),
                Err(e) => out.problems.push(format!("byte {at}: {e}")),
            }
        }
    }

    /// Checks packet `p` (ended at byte `at`) against the sequence and type counts.
    fn follow(&mut self, p: Decoded, at: u64, out: &mut Stream) {
        // A boot starts the count again: the stream of a new boot, not lost packets.
        let booted = is_boot(&p) && p.sequence == 0;
        if let Some(expected) = self.next.filter(|_| !booted) {
            if p.sequence != expected {
                let lost = p.sequence.wrapping_sub(expected) & 0x3FFF;
                out.problems.push(format!(
                    "byte {at}: sequence count {} where {expected} was due ({lost} packets lost)",
                    p.sequence
                ));
            }
        }
        self.next = Some((p.sequence + 1) & 0x3FFF);
        if let Some(problem) = self.types.follow(&p) {
            out.problems.push(format!("byte {at}: {problem}"));
        }
        out.packets.push(p);
    }

    /// A frame cut off (the link lost, or reopened): what was read of it is a problem, and
    /// the next frame starts afresh.
    pub fn interrupted(&mut self, out: &mut Stream) {
        self.finish(out);
        self.deframer = Deframer::new();
        self.pending_start = self.offset;
    }

    /// The stream's end: a frame left open is a problem.
    pub fn finish(&mut self, out: &mut Stream) {
        if self.pending_start < self.offset {
            out.problems.push(format!(
                "byte {}: the stream ends inside a frame ({} bytes without a delimiter)",
                self.pending_start,
                self.offset - self.pending_start
            ));
        }
    }
}

/// The message type counter of each kind of report (PUS-C TM secondary header), followed
/// across a stream.
#[derive(Default)]
struct TypeCounters {
    /// The last counter seen of each (service, subtype) since the last boot event.
    last: std::collections::HashMap<(u8, u8), u16>,
}

impl TypeCounters {
    /// Follows packet `p`; says how many reports of its kind were lost before it, if any.
    /// A boot event starts the count again. Streams of format 1 carry 0 in every packet,
    /// which reads as "no counter" (a count that stays 0 is never a gap).
    fn follow(&mut self, p: &Decoded) -> Option<String> {
        if is_boot(p) {
            self.last.clear();
        }
        let c = p.type_counter;
        let last = self.last.insert(p.service, c)?;
        let expected = last.wrapping_add(1);
        if c == expected || (c == 0 && last == 0) {
            return None;
        }
        let (s, st) = p.service;
        Some(format!(
            "TM[{s},{st}] message type counter {c} where {expected} was due ({} of that kind lost)",
            c.wrapping_sub(expected)
        ))
    }
}

/// The rows of an estimates file (docs/formats.md columns, then [`LINK_COLUMNS`]), packet by
/// packet, with what earlier packets said: the model in force (model G's rows carry the
/// gravity gradient) and the boot. `t` is the packet time (s since boot) plus the time offset,
/// rounded to 0.1 µs (the CUC fine time has 2⁻²⁴ s ≈ 60 ns steps, so a time on a 0.1 µs grid
/// on board comes back exactly).
pub struct RowWriter {
    time_offset: f64,
    /// From the housekeeping (one is sent at boot, before any estimate) and the reconfigured
    /// and model-switched events, unless the report carries it.
    model: Option<ModelCode>,
    /// The boot the rows are of (`t` starts again at each): from the boot event and the
    /// housekeeping (format 2).
    boot: Option<u32>,
    line: Vec<u8>,
}

impl RowWriter {
    /// Rows with `time_offset` added to each packet's time.
    pub fn new(time_offset: f64) -> Self {
        RowWriter {
            time_offset,
            model: None,
            boot: None,
            line: Vec::with_capacity(512),
        }
    }

    /// The header line.
    pub fn header<W: Write>(&self, w: &mut W) -> std::io::Result<()> {
        crate::estimates_csv::write_header(&mut RowWithout(w, &LINK_COLUMNS))
    }

    /// Follows packet `p`: its row if it is a motion report (true), else what it says of the
    /// model or the boot.
    pub fn packet<W: Write>(&mut self, w: &mut W, p: &Decoded) -> std::io::Result<bool> {
        let code = |b: u32| {
            u8::try_from(b)
                .ok()
                .and_then(|b| ModelCode::try_from(b).ok())
        };
        let m = match &p.report {
            Report::Motion(m) => m,
            Report::Housekeeping(h) => {
                self.model = ModelCode::try_from(h.model).ok();
                if let Some((info, _)) = &h.boot {
                    self.boot = Some(info.count);
                }
                return Ok(false);
            }
            Report::Event(e) if e.id == EventId::Boot => {
                let b = BootEvent::from_words(e.a, e.b);
                self.boot = (b.format >= 2).then_some(u32::from(b.count));
                return Ok(false);
            }
            Report::Event(e) if e.id == EventId::ModelSwitched || e.id == EventId::Reconfigured => {
                self.model = code(e.b);
                return Ok(false);
            }
            _ => return Ok(false),
        };
        self.line.clear();
        let t = ((p.t + self.time_offset) * 1e7).round() / 1e7;
        // The report's own model where it carries one (format 2).
        let gamma = m.context.map_or(self.model, |(_, c)| Some(c)) == Some(ModelCode::General);
        let excluded = u64::from(m.excluded_channels.0);
        crate::estimates_csv::write_row(&mut self.line, t, &m.estimate, gamma, excluded)?;
        self.line.pop();
        w.write_all(&self.line)?;
        write!(
            w,
            ",{},{},{},{},",
            m.k, m.missing_parts.0, m.excluded_parts.0, m.excluded_channels.0
        )?;
        match self.boot {
            Some(b) => writeln!(w, "{b}")?,
            None => writeln!(w)?,
        }
        Ok(true)
    }
}

/// Appends extra columns to the header line written through it.
struct RowWithout<'a, W>(&'a mut W, &'a [&'a str]);

impl<W: Write> Write for RowWithout<'_, W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if buf.last() == Some(&b'\n') {
            self.0.write_all(&buf[..buf.len() - 1])?;
            write!(self.0, ",{}", self.1.join(","))?;
            self.0.write_all(b"\n")?;
        } else {
            self.0.write_all(buf)?;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

/// One line of text per packet other than motion: housekeeping, events, verification.
pub fn log_line(p: &Decoded, time_offset: f64) -> Option<String> {
    let head = format!("t={:.6} seq={:5}", p.t + time_offset, p.sequence);
    let body = match &p.report {
        Report::Motion(_) => return None,
        Report::Housekeeping(h) => housekeeping_text(h),
        Report::Event(e) => {
            let severity = ["", "info", "low", "medium", "high"][usize::from(e.id.severity())];
            let detail = match e.id {
                EventId::PartsExcluded | EventId::PartsIncluded => {
                    format!("parts={:#04x} channels_out={:#08x}", e.a, e.b)
                }
                EventId::Boot => {
                    let boot = BootEvent::from_words(e.a, e.b);
                    let [major, minor, patch] = boot.version;
                    let version = format!("version={major}.{minor}.{patch}");
                    if boot.format >= 2 {
                        format!(
                            "{version} channels={} format={} boot={} reset={}",
                            boot.channels,
                            boot.format,
                            boot.count,
                            boot.cause.name()
                        )
                    } else {
                        format!("{version} channels={}", e.b)
                    }
                }
                EventId::ChannelsCommanded => {
                    format!("commanded_out={:#08x} -> {:#08x}", e.a, e.b)
                }
                EventId::PartIsolated => format!("part={} channels={:#08x}", e.a, e.b),
                EventId::ModelSwitched => {
                    let name = |m: u32| match m {
                        0 => "general".to_string(),
                        1 => "free-float".to_string(),
                        other => format!("unknown({other})"),
                    };
                    format!("model={} -> {}", name(e.a), name(e.b))
                }
                EventId::FaultSuspected => format!(
                    "{} level={:.3}",
                    if e.a == 1 { "start" } else { "end" },
                    f64::from(e.b) / 1000.0
                ),
                _ => format!("a={} b={}", e.a, e.b),
            };
            format!("EVENT {} ({severity}) {detail}", e.id.name())
        }
        Report::Verification(v) => {
            let what = match v.subtype {
                subtype::ACCEPTED => "accepted",
                subtype::NOT_ACCEPTED => "NOT ACCEPTED",
                subtype::COMPLETED => "completed",
                _ => "NOT COMPLETED",
            };
            let mut s = format!(
                "TC {:#06x}/{:#06x} {what}",
                v.request.packet_id, v.request.sequence
            );
            if let Some((code, data)) = v.failure {
                let _ = write!(
                    s,
                    ": {} (code {}, data {data:#x})",
                    code.describe(),
                    code as u16
                );
            }
            s
        }
        Report::Alive => "ALIVE".to_string(),
        Report::IdentificationSummary(s) => format!(
            "IDENTIFICATION solution={} channels={} sets={} not_covered={} incomplete={} reference_points={} restarts={} rho=[{:.6},{:.6},{:.6}] m sd=[{:.2e},{:.2e},{:.2e}] frame rotation_sd={:.2e} translation_sd={:.2e} size_sd={:.2e}",
            s.solution, s.channels, s.sets, s.not_covered, s.incomplete, s.points, s.restarts,
            s.rho[0], s.rho[1], s.rho[2],
            s.rho_sd[0], s.rho_sd[1], s.rho_sd[2],
            s.frame[0], s.frame[1], s.frame[2]
        ),
        Report::IdentifiedChannel(c) => {
            let held: Vec<&str> = estimator_core::identify::Param::ALL
                .iter()
                .filter(|p| c.held & p.bit() != 0)
                .map(|p| p.name())
                .collect();
            format!(
                "IDENTIFIED solution={} channel={} position=[{:.6},{:.6},{:.6}] axis=[{:.6},{:.6},{:.6}] bias={:.5} scale={:.5} sd=[{}] residual_rms={:.3e} noise={:.3e} held=[{}]",
                c.solution, c.channel, c.position[0], c.position[1], c.position[2],
                c.axis[0], c.axis[1], c.axis[2], c.bias, c.scale,
                c.sd.iter().map(|v| format!("{v:.2e}")).collect::<Vec<_>>().join(","),
                c.residual_rms, c.noise, held.join(",")
            )
        }
        Report::ThermalTrack(k) => {
            use ballisto_link::identification::{TRACK_ADDED, TRACK_DETERMINED, TRACK_SCALE_DRIFT};
            format!(
                "THERMAL_TRACK solution={} channel={} window_temperature_c={:.2} added={} windows={} span_c={:.1} determined={} t_ref={:.2} bias={:.6} bias_sd={:.2e} bias_tc={:.4e} bias_tc_sd={:.2e} scatter={:.2}{}",
                k.solution, k.channel, k.window_temperature,
                u8::from(k.state & TRACK_ADDED != 0), k.windows, k.span,
                u8::from(k.state & TRACK_DETERMINED != 0), k.t_ref,
                k.bias, k.bias_sd, k.bias_tc, k.bias_tc_sd, k.scatter,
                if k.state & TRACK_SCALE_DRIFT != 0 {
                    " SCALE_DRIFT (a position held, no scale coefficient in use: the slope may carry the scale's drift)"
                } else {
                    ""
                }
            )
        }
    };
    Some(format!("{head} {body}"))
}

fn housekeeping_text(h: &Housekeeping) -> String {
    let mut s = format!(
        "HK v{}.{}.{} mode={} model={} channels={} rate={}Hz motion_every={} hk_every={} sets={} skipped={} dropped={} sync_errors={} estimates={} excluded_parts={:#04x} commanded_out={:#08x} channels_out={:#08x} tc_accepted={} tc_rejected={} frames_garbage={} tm_lost={}",
        h.version[0], h.version[1], h.version[2],
        if Mode::try_from(h.mode) == Ok(Mode::Operate) { "operate" } else { "standby" },
        if ModelCode::try_from(h.model) == Ok(ModelCode::FreeFloat) { "F" } else { "G" },
        h.channels, h.rate_hz, h.motion_every, h.housekeeping_every, h.sampling.sets,
        h.sampling.skipped, h.sampling.dropped, h.sampling.sync_errors, h.estimates, h.excluded_parts.0, h.commanded_out.0,
        h.excluded_channels.0, h.tc_accepted, h.tc_rejected, h.frames_garbage, h.tm_lost
    );
    for (i, c) in h.parts.iter().enumerate() {
        let state = match c.state {
            PartState::Absent => continue,
            PartState::Running => "running",
            PartState::Down => "DOWN",
        };
        let _ = write!(
            s,
            " | part{i} {state} reads={} bus_errors={} implausible={} missed={} failed_starts={} resyncs={}",
            c.reads, c.bus_errors, c.implausible, c.missed, c.failed_starts, c.resyncs
        );
    }
    match h.calibration {
        Some(c) => {
            let source = match c.source {
                CalibrationSource::Builtin => "builtin",
                CalibrationSource::Flash => "flash",
                CalibrationSource::Commanded => "commanded",
            };
            let _ = write!(s, " | calibration {source} id={} crc={:#010x}", c.id, c.crc);
        }
        None => s.push_str(" | calibration unknown (layout before issue 16)"),
    }
    if let Some((boot, time)) = h.boot {
        let _ = write!(s, " | boot {} reset={}", boot.count, boot.cause.name());
        if time.set {
            let _ = write!(s, " | time boot_at={:.6}", time.epoch_seconds());
        } else {
            s.push_str(" | time not correlated");
        }
    }
    if let Some(test) = h.test {
        let _ = write!(s, " | consistency_test={}", test.name());
    }
    if let Some(temps) = h.temperatures {
        // Slots with a part: those that report one, or whose counters show a part.
        let shown: Vec<String> = temps
            .iter()
            .zip(h.parts.iter())
            .enumerate()
            .filter(|(_, (t, p))| !t.is_nan() || p.state != ballisto_link::PartState::Absent)
            .map(|(i, (t, _))| {
                if t.is_nan() {
                    format!("{i}:unread")
                } else {
                    format!("{i}:{t:.2}")
                }
            })
            .collect();
        if !shown.is_empty() {
            let _ = write!(s, " | temperature_c {}", shown.join(" "));
        }
    }
    s
}
