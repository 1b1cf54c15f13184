//! `ballisto`: the host binary (docs/formats.md).

mod cli;

use std::process::ExitCode;

use clap::{CommandFactory, Parser};
use cli::args::{Command, Say};

#[derive(Parser)]
#[command(
    name = "ballisto",
    version,
    about = "Ballistometer host tools: σ0, Ω′ and Ω from accelerometers alone",
    after_help = ballisto::exit::HELP
)]
struct Cli {
    /// Say nothing but warnings and errors (no summaries, no notices).
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    quiet: bool,
    /// Say more: timings, every problem listed, the calibration's alternations.
    #[arg(short, long, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

fn run(cli: Cli) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let say = Say {
        quiet: cli.quiet,
        verbose: cli.verbose,
    };
    let started = std::time::Instant::now();
    match cli.command {
        Command::Estimate(args) => cli::estimate::estimate(args, say, started),
        Command::Sim(args) => cli::sim::sim(args, say, started),
        Command::Decode(args) => cli::telemetry::decode(args, say),
        Command::Capture(args) => cli::telemetry::capture(args, say),
        Command::Calibrate(args) => cli::estimate::calibrate(args, say, started),
        Command::Com(args) => cli::estimate::com(args, say),
        Command::Compare(args) => cli::telemetry::compare(args, say),
        Command::Tc(args) => cli::tc::tc(args, say),
        Command::Completions { shell } => cli::manual::completions(shell, Cli::command()),
        Command::Man { out } => cli::manual::man(&out, Cli::command(), say),
    }
}

/// `-v`'s log: the library's `log::debug!` lines on stderr (the calibration's alternations).
struct StderrLog;

impl log::Log for StderrLog {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.target().starts_with("ballisto")
    }

    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            eprintln!("  [{}] {}", record.target(), record.args());
        }
    }

    fn flush(&self) {}
}

static STDERR_LOG: StderrLog = StderrLog;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            // Bare `ballisto` (or `ballisto tc`): the help as clap lays it out, on stderr.
            eprint!("{}", e.render());
            return ExitCode::from(ballisto::exit::USAGE);
        }
        Err(e) => {
            // docs/formats.md: an error is one sentence on stderr (clap's own spans lines).
            eprintln!("ballisto: {}", one_line(&e.to_string()));
            return ExitCode::from(ballisto::exit::USAGE);
        }
    };
    if cli.verbose && log::set_logger(&STDERR_LOG).is_ok() {
        log::set_max_level(log::LevelFilter::Debug);
    }
    if let Err(e) = ballisto::output::signals::remove_temporaries_on_signals() {
        eprintln!("ballisto: cannot watch for signals: {e}");
        return ExitCode::from(ballisto::exit::BAD_INPUT);
    }
    let result = run(cli);
    // A reader of stdout that went away (`| head`) took what it wanted: no failure.
    if ballisto::output::signals::stdout_closed() {
        return ExitCode::SUCCESS;
    }
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("ballisto: {e}");
            ExitCode::from(ballisto::exit::code_of(e.as_ref()))
        }
    }
}

/// A command-line error of clap's as one line: its lines joined, without the pointer to
/// `--help` (e.g. "invalid value 'x' for '--model <MODEL>' [possible values: general,
/// free-float]").
fn one_line(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("For more information"))
        .map(|l| l.strip_prefix("error: ").unwrap_or(l))
        .collect::<Vec<_>>()
        .join(" ")
}
