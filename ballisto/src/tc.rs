//! `ballisto tc`: telecommands as the unit reads them — each built by the link crate
//! ([`ballisto_link::telecommand::build_command`]), checked by the unit's own acceptance
//! ([`ballisto_link::telecommand::parse`]) before it leaves the ground, and COBS-framed as on
//! the line. The other way, [`sent`] reads such a stream back so that `ballisto decode` can
//! name the command each verification report answers.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use ballisto_link::framing::{self, max_encoded_len, Deframed, Deframer};
use ballisto_link::identification::{points_data, ReferencePoint, MAX_POINTS, POINT_LEN};
use ballisto_link::ids::{subtype, MAX_CHANNELS, TC_MAX};
use ballisto_link::telecommand::{build_command, parse, Command, Context, ACK_ACCEPTANCE};
use ballisto_link::{Mode, RequestId};
use estimator_core::Model;

/// Octets of a telecommand's headers before its application data (primary + PUS-C secondary).
const HEADERS: usize = 11;

/// One telecommand packet, COBS-framed, and what it says.
#[derive(Clone, Debug)]
pub struct Framed {
    /// The frame as sent on the line (COBS, with its zero delimiter).
    pub frame: Vec<u8>,
    /// Readable: `TC[200,4] exclude channel 3 (seq 5)`.
    pub text: String,
}

/// Builds `command` with sequence count `sequence` and acknowledgement flags `ack`, checks it
/// with the unit's acceptance (`channels`: the unit's channel count where the command's range
/// depends on it, else the most the link carries), and frames it. A command the unit would
/// refuse is an error naming why: nothing is sent that the unit is known to refuse.
pub fn frame(
    command: &Command,
    sequence: u16,
    ack: u8,
    channels: Option<usize>,
) -> Result<Framed, String> {
    let mut raw = vec![0u8; TC_MAX];
    let n = build_command(&mut raw, sequence, ack, command).ok_or_else(|| {
        format!(
            "{} is longer than a telecommand ({TC_MAX} octets)",
            describe(command)
        )
    })?;
    let raw = &raw[..n];
    let channels = channels.unwrap_or(match command {
        Command::LoadArrangement(data) => data.first().map_or(0, |n| usize::from(*n)),
        _ => MAX_CHANNELS,
    });
    if let Err(r) = parse(raw, Context { channels }) {
        return Err(format!(
            "{}: the unit would refuse it: {} (code {}, data {})",
            describe(command),
            r.code.describe(),
            r.code as u16,
            r.data
        ));
    }
    let mut out = vec![0u8; max_encoded_len(n)];
    let m = framing::encode(raw, &mut out).ok_or("COBS framing failed")?;
    out.truncate(m);
    Ok(Framed {
        frame: out,
        text: format!("{} (seq {})", describe(command), sequence & 0x3FFF),
    })
}

/// What a command asks, in words (its service and subtype first).
pub fn describe(command: &Command) -> String {
    let (s, st) = command.kind();
    let what = match command {
        Command::SetMode(m) => format!(
            "set mode {}",
            match m {
                Mode::Standby => "standby",
                Mode::Operate => "operate",
            }
        ),
        Command::SetModel(m) => format!("set model {}", model_name(*m)),
        Command::SetHint(w) => format!("set rate hint [{}, {}, {}] rad/s", w[0], w[1], w[2]),
        Command::Exclude(c) => format!("exclude channel {c}"),
        Command::Include(c) => format!("include channel {c}"),
        Command::LoadArrangement(data) => format!(
            "load arrangement of {} channels",
            data.first().copied().unwrap_or(0)
        ),
        Command::SetRates {
            motion_every,
            housekeeping_every,
        } => format!(
            "set rates: a motion report every {motion_every} sets, housekeeping every {housekeeping_every}"
        ),
        Command::StartIdentification {
            period_ms,
            window_ms,
            inertia: None,
        } => format!(
            "start identification: reference every {period_ms} ms, window {:.3} s",
            f64::from(*window_ms) / 1000.0
        ),
        Command::StartIdentification {
            period_ms,
            window_ms,
            inertia: Some(j),
        } => format!(
            "start identification in a torque-free tumble: means of {period_ms} ms kept, window {:.3} s, inertia {j:?}",
            f64::from(*window_ms) / 1000.0
        ),
        Command::ReferenceRate(data) => {
            let points: Vec<ReferencePoint> = ballisto_link::identification::points(data).collect();
            match (points.first(), points.last()) {
                (Some(a), Some(b)) => format!(
                    "reference rate: {} points {:.6}–{:.6} s",
                    points.len(),
                    a.t as f64 * 1e-9,
                    b.t as f64 * 1e-9
                ),
                _ => "reference rate: no points".to_string(),
            }
        }
        Command::ReportIdentification => "solve and report the identification".to_string(),
        Command::CommitCalibration { solution } => format!("commit solution {solution}"),
        Command::ReportHousekeeping => "report housekeeping".to_string(),
        Command::SetTime(ticks) => format!(
            "set time: spacecraft time {:.6} s at reception",
            *ticks as f64 / f64::from(1u32 << 24)
        ),
        Command::AreYouAlive => "are you alive".to_string(),
    };
    format!("TC[{s},{st}] {what}")
}

fn model_name(m: Model) -> &'static str {
    match m {
        Model::General => "general",
        Model::FreeFloat => "free-float",
    }
}

/// TC\[9,128\]'s field: the spacecraft time `seconds` as 2⁻²⁴ s ticks (CUC 4+3), or an error
/// if it is negative, not finite or beyond the 4 coarse octets.
pub fn time_ticks(seconds: f64) -> Result<u64, String> {
    let ticks = (seconds * f64::from(1u32 << 24)).round();
    if !(0.0..(1u64 << 56) as f64).contains(&ticks) {
        return Err(format!(
            "set-time {seconds}: not a CUC 4+3 time (0 to {} s)",
            u32::MAX
        ));
    }
    Ok(ticks as u64)
}

/// TC\[200,6\] application data from an arrangement file (its channels in file order: position,
/// axis, noise), and the warnings: what the command does not carry (bias, scale), and an
/// implausible extent ([`crate::plausibility::arrangement`]).
pub fn arrangement_data(path: &Path) -> Result<(Vec<u8>, Vec<String>), String> {
    let loaded =
        ballisto_config::arrangement_file::load_arrangement(path).map_err(|e| e.to_string())?;
    let channels = loaded.arrangement.channels();
    let mut data = vec![0u8; 1 + ballisto_link::telecommand::CHANNEL_LEN * channels.len()];
    let n = ballisto_link::telecommand::arrangement_data(
        channels.iter().map(|c| (c.position, c.axis, c.noise)),
        &mut data,
    )
    .ok_or_else(|| {
        format!(
            "{}: {} channels, a telecommand carries at most {MAX_CHANNELS}",
            path.display(),
            channels.len()
        )
    })?;
    data.truncate(n);
    let mut warnings: Vec<String> =
        crate::plausibility::arrangement(&loaded, &path.display().to_string())
            .into_iter()
            .collect();
    let corrected: Vec<&str> = channels
        .iter()
        .zip(&loaded.names)
        .filter(|(c, _)| c.bias != 0.0 || c.scale != 1.0)
        .map(|(_, name)| name.as_str())
        .collect();
    if !corrected.is_empty() {
        warnings.push(format!(
            "{}: TC[200,6] carries positions, axes and noise only: the bias and scale of {} stay as the unit has them",
            path.display(),
            corrected.join(", ")
        ));
    }
    Ok((data, warnings))
}

/// A channel given as its index or, with the unit's arrangement file, its name; and the
/// unit's channel count where the file gives it (the range the unit accepts).
pub fn channel_index(
    channel: &str,
    arrangement: Option<&Path>,
) -> Result<(u8, Option<usize>), String> {
    let loaded = arrangement
        .map(|p| ballisto_config::arrangement_file::load_arrangement(p).map_err(|e| e.to_string()))
        .transpose()?;
    let count = loaded.as_ref().map(|l| l.names.len());
    if let Ok(i) = channel.parse::<u8>() {
        return Ok((i, count));
    }
    let (Some(loaded), Some(path)) = (loaded, arrangement) else {
        return Err(format!(
            "channel \"{channel}\" is not an index (0–{}); a name needs --arrangement",
            MAX_CHANNELS - 1
        ));
    };
    loaded
        .names
        .iter()
        .position(|n| n == channel)
        .and_then(|i| u8::try_from(i).ok())
        .map(|i| (i, count))
        .ok_or_else(|| {
            format!(
                "{}: no channel \"{channel}\" (channels: {})",
                path.display(),
                loaded.names.join(", ")
            )
        })
}

/// TC\[200,9\] packets' application data for the rows of a reference rate file (times on the
/// unit's clock, s since boot) between `from` and `to`: [`MAX_POINTS`] points each.
pub fn reference_batches(path: &Path, from: f64, to: f64) -> Result<Vec<Vec<u8>>, String> {
    // The reference's own flag columns (`valid`, `*_saturated`) leave rows out here too.
    let (r, _) = crate::calibrate::reference_rate::read(path, &Default::default())
        .map_err(|e| e.to_string())?;
    let mut points = Vec::new();
    for (t, w) in r.t.iter().zip(&r.omega) {
        if *t < from || *t > to {
            continue;
        }
        if *t < 0.0 {
            return Err(format!(
                "{}: t = {t} is before the unit's boot (times are on the unit's clock)",
                path.display()
            ));
        }
        points.push(ReferencePoint {
            t: (t * 1e9).round() as u64,
            omega: [w.x as f32, w.y as f32, w.z as f32],
        });
    }
    if points.is_empty() {
        return Err(format!(
            "{}: no rows between {from} and {to} s",
            path.display()
        ));
    }
    points
        .chunks(MAX_POINTS)
        .map(|chunk| {
            let mut data = vec![0u8; 1 + POINT_LEN * chunk.len()];
            let n = points_data(chunk, &mut data).ok_or("reference batch")?;
            data.truncate(n);
            Ok(data)
        })
        .collect()
}

/// The telecommands in a stream of frames as `ballisto tc` writes them: each one's request
/// identifier (what its verification reports carry) with its description. A frame that is not
/// a telecommand is an error naming its byte offset.
pub fn sent(bytes: &[u8], file: &str) -> Result<HashMap<RequestId, String>, String> {
    let mut deframer = Deframer::<{ max_encoded_len(TC_MAX) }>::new();
    let mut out = HashMap::new();
    let mut start = 0;
    for (offset, &b) in bytes.iter().enumerate() {
        let n = match deframer.push(b) {
            Deframed::Pending => continue,
            Deframed::Garbage => {
                return Err(format!("{file}: byte {start}: not a telecommand frame"))
            }
            Deframed::Packet(n) => n,
        };
        let raw = deframer.packet(n);
        let channels = if raw.len() > HEADERS
            && raw[7] == ballisto_link::service::BALLISTOMETER
            && raw[8] == subtype::LOAD_ARRANGEMENT
        {
            usize::from(raw[HEADERS])
        } else {
            MAX_CHANNELS
        };
        let text = match parse(raw, Context { channels }) {
            Ok(a) => describe(&a.command),
            Err(r) => format!("a telecommand the unit refuses ({})", r.code.describe()),
        };
        let id = RequestId::of(raw)
            .ok_or_else(|| format!("{file}: byte {start}: shorter than a packet header"))?;
        out.insert(id, text);
        start = offset + 1;
    }
    if start < bytes.len() {
        return Err(format!(
            "{file}: byte {start}: the stream ends inside a frame"
        ));
    }
    Ok(out)
}

/// The frames' bytes as hexadecimal, one frame per line.
pub fn hex(frames: &[Framed]) -> String {
    let mut s = String::new();
    for f in frames {
        for b in &f.frame {
            let _ = write!(s, "{b:02x}");
        }
        s.push('\n');
    }
    s
}

/// Acknowledgement flags from a list: `acceptance`, `completion` (comma-separated), or `none`.
pub fn ack_flags(list: &str) -> Result<u8, String> {
    let mut ack = 0;
    for item in list.split(',').map(str::trim) {
        ack |= match item {
            "acceptance" => ACK_ACCEPTANCE,
            "completion" => ballisto_link::telecommand::ACK_COMPLETION,
            "none" => 0,
            other => {
                return Err(format!(
                    "--ack \"{list}\": \"{other}\" is not one of acceptance, completion, none"
                ))
            }
        };
    }
    Ok(ack)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_command_the_unit_refuses_is_not_built() {
        let e = frame(&Command::Exclude(12), 0, ACK_ACCEPTANCE, Some(12)).unwrap_err();
        assert!(
            e.contains("TC[200,4] exclude channel 12") && e.contains("refuse"),
            "{e}"
        );
        let e = frame(&Command::SetHint([0.0, 99.0, 0.0]), 0, 0, None).unwrap_err();
        assert!(e.contains("refuse"), "{e}");
        assert!(time_ticks(-1.0).is_err());
        assert!(time_ticks(f64::NAN).is_err());
        assert_eq!(time_ticks(2.5), Ok(5 << 23));
    }

    #[test]
    fn frames_read_back_as_the_commands_sent() {
        let mut bytes = Vec::new();
        let commands = [
            Command::Exclude(3),
            Command::AreYouAlive,
            Command::ReportHousekeeping,
        ];
        for (i, c) in commands.iter().enumerate() {
            bytes.extend(frame(c, 40 + i as u16, ACK_ACCEPTANCE, None).unwrap().frame);
        }
        let got = sent(&bytes, "tc.bin").unwrap();
        assert_eq!(got.len(), 3);
        let mut texts: Vec<&String> = got.values().collect();
        texts.sort();
        assert_eq!(
            texts,
            [
                "TC[17,1] are you alive",
                "TC[200,4] exclude channel 3",
                "TC[3,27] report housekeeping"
            ]
        );
        assert!(sent(&bytes[..bytes.len() - 1], "tc.bin").is_err());
        assert_eq!(ack_flags("acceptance,completion"), Ok(9));
        assert!(ack_flags("accept").is_err());
    }
}
