//! `ballisto completions` and `ballisto man`: the shell completions and the manual pages,
//! generated from the command line's own definition (so they never disagree with `--help`).

use std::error::Error;
use std::path::Path;
use std::process::ExitCode;

use super::args::Say;

/// `ballisto completions SHELL`: the completion script on stdout.
pub fn completions(
    shell: clap_complete::Shell,
    mut cmd: clap::Command,
) -> Result<ExitCode, Box<dyn Error>> {
    let mut script = Vec::new();
    clap_complete::generate(shell, &mut cmd, "ballisto", &mut script);
    ballisto::output::signals::print(&String::from_utf8_lossy(&script))?;
    Ok(ExitCode::SUCCESS)
}

/// `ballisto man --out DIR`: `ballisto.1` and one page per subcommand, each written as every
/// output is (`ballisto::output`).
pub fn man(dir: &Path, cmd: clap::Command, say: Say) -> Result<ExitCode, Box<dyn Error>> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot make: {e}", dir.display()))?;
    let mut written = 0;
    page(dir, cmd.name("ballisto"), &mut written)?;
    say.info(format!(
        "ballisto man: {written} pages in {}",
        dir.display()
    ));
    Ok(ExitCode::SUCCESS)
}

/// Writes `cmd`'s page (named after it, `ballisto-tc-ping.1`), then its subcommands'.
fn page(dir: &Path, cmd: clap::Command, written: &mut usize) -> Result<(), Box<dyn Error>> {
    let name = cmd.get_name().to_string();
    let mut roff = Vec::new();
    clap_mangen::Man::new(cmd.clone()).render(&mut roff)?;
    ballisto::output::write(&dir.join(format!("{name}.1")), &roff)?;
    *written += 1;
    for sub in cmd.get_subcommands().filter(|s| s.get_name() != "help") {
        let full = format!("{name}-{}", sub.get_name());
        page(dir, sub.clone().name(full), written)?;
    }
    Ok(())
}
