//! `ballisto tc`: telecommands for the unit.

use std::error::Error;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use super::args::*;

/// The arguments of `ballisto tc`.
#[derive(Args)]
pub struct TcArgs {
    /// Where to write the frames (default: stdout, `-`).
    #[arg(long, value_name = "TC.bin", global = true, default_value = "-")]
    pub out: PathBuf,
    /// Sequence count of the (first) packet, 0–16383: the verification reports carry it.
    #[arg(long, value_name = "N", global = true, default_value = "0",
          value_parser = clap::value_parser!(u16).range(0..=0x3FFF))]
    pub sequence: u16,
    /// Verification reports asked for: acceptance, completion (comma-separated), or none.
    #[arg(
        long,
        value_name = "LIST",
        global = true,
        default_value = "acceptance,completion"
    )]
    pub ack: String,
    /// Write the frames as hexadecimal text, one per line, instead of binary.
    #[arg(long, global = true)]
    pub hex: bool,
    #[command(subcommand)]
    pub command: TcCommand,
}

/// `ballisto tc`.
pub fn tc(args: TcArgs, say: Say) -> Result<ExitCode, Box<dyn Error>> {
    let TcArgs {
        out,
        sequence,
        ack,
        hex,
        command,
    } = args;
    let ack = ballisto::tc::ack_flags(&ack)?;
    ballisto::output::check_distinct(&[&out], &inputs(&command))?;
    let frames = telecommands(command, sequence, ack, say)?;
    let bytes = if hex {
        ballisto::tc::hex(&frames).into_bytes()
    } else {
        frames
            .iter()
            .flat_map(|f| f.frame.iter().copied())
            .collect()
    };
    if ballisto::output::is_std(&out) && !hex {
        use std::io::IsTerminal;
        if std::io::stdout().is_terminal() {
            return Err("refusing to write binary telecommand frames to a terminal: name --out FILE, redirect stdout, or add --hex".into());
        }
    }
    ballisto::output::write(&out, &bytes)?;
    for f in &frames {
        say.info(format!("ballisto tc: {} -> {}", f.text, out.display()));
    }
    Ok(ExitCode::SUCCESS)
}

/// The files a `tc` command reads (the output may be none of them).
fn inputs(command: &TcCommand) -> Vec<&std::path::Path> {
    match command {
        TcCommand::Exclude { arrangement, .. } | TcCommand::Include { arrangement, .. } => {
            arrangement.iter().map(PathBuf::as_path).collect()
        }
        TcCommand::LoadArrangement { arrangement } => vec![arrangement.as_path()],
        TcCommand::Reference { file, .. } => vec![file.as_path()],
        _ => Vec::new(),
    }
}

/// The frames of a `tc` command: consecutive sequence counts from `sequence`.
fn telecommands(
    command: TcCommand,
    sequence: u16,
    ack: u8,
    say: Say,
) -> Result<Vec<ballisto::tc::Framed>, Box<dyn std::error::Error>> {
    use ballisto::tc;
    use ballisto_link::telecommand::Command as Tc;
    let one = |c: Tc, channels: Option<usize>| tc::frame(&c, sequence, ack, channels);
    let frames = match command {
        TcCommand::Mode { mode } => vec![one(
            Tc::SetMode(match mode {
                ModeArg::Standby => ballisto_link::Mode::Standby,
                ModeArg::Operate => ballisto_link::Mode::Operate,
            }),
            None,
        )?],
        TcCommand::Model { model } => vec![one(Tc::SetModel(model.into()), None)?],
        TcCommand::Hint { omega } => {
            let w = parse_vec3(&omega).map_err(|e| e.replace("--initial-omega", "hint"))?;
            vec![one(Tc::SetHint(w.map(|v| v as f32)), None)?]
        }
        TcCommand::Exclude {
            channel,
            arrangement,
        } => {
            let (c, channels) = tc::channel_index(&channel, arrangement.as_deref())?;
            vec![one(Tc::Exclude(c), channels)?]
        }
        TcCommand::Include {
            channel,
            arrangement,
        } => {
            let (c, channels) = tc::channel_index(&channel, arrangement.as_deref())?;
            vec![one(Tc::Include(c), channels)?]
        }
        TcCommand::LoadArrangement { arrangement } => {
            let (data, warnings) = tc::arrangement_data(&arrangement)?;
            for w in warnings {
                eprintln!("ballisto tc: WARNING: {w}");
            }
            vec![one(Tc::LoadArrangement(&data), None)?]
        }
        TcCommand::Rates {
            motion_every,
            housekeeping_every,
        } => vec![one(
            Tc::SetRates {
                motion_every,
                housekeeping_every,
            },
            None,
        )?],
        TcCommand::Identify {
            period_ms,
            window,
            inertia,
        } => {
            let ms = (window * 1000.0).round();
            if !(ms >= 1.0 && ms <= f64::from(u32::MAX)) {
                return Err(Box::new(ballisto::exit::Usage(format!(
                    "--window {window}: not a window length in seconds (1 ms to 49 days)"
                ))));
            }
            vec![one(
                Tc::StartIdentification {
                    period_ms,
                    window_ms: ms as u32,
                    inertia: inertia.map(|j| j.map(|v| v as f32)),
                },
                None,
            )?]
        }
        TcCommand::Reference { file, from, to } => {
            let batches = tc::reference_batches(&file, from, to)?;
            say.detail(format!(
                "ballisto tc: {}: {} packets of reference points",
                file.display(),
                batches.len()
            ));
            batches
                .iter()
                .enumerate()
                .map(|(i, data)| {
                    tc::frame(
                        &Tc::ReferenceRate(data),
                        sequence.wrapping_add(i as u16) & 0x3FFF,
                        ack,
                        None,
                    )
                })
                .collect::<Result<_, _>>()?
        }
        TcCommand::ReportIdentification => vec![one(Tc::ReportIdentification, None)?],
        TcCommand::Commit { solution } => {
            vec![one(Tc::CommitCalibration { solution }, None)?]
        }
        TcCommand::Housekeeping => vec![one(Tc::ReportHousekeeping, None)?],
        TcCommand::SetTime { seconds } => {
            vec![one(Tc::SetTime(tc::time_ticks(seconds)?), None)?]
        }
        TcCommand::Ping => vec![one(Tc::AreYouAlive, None)?],
    };
    Ok(frames)
}
