//! Exit status of `ballisto` (documented in `ballisto --help`, the README and `docs/ballisto.md`): one code per
//! kind of outcome, so that a script can tell a typo from damaged data.

use std::fmt;

/// Everything was done.
pub const SUCCESS: u8 = 0;
/// An input is wrong: a file cannot be read, is empty or malformed, names what does not
/// exist, or an output would overwrite an input. Nothing was written.
pub const BAD_INPUT: u8 = 1;
/// The command line is wrong (unknown option, missing argument, bad value).
pub const USAGE: u8 = 2;
/// `decode`: the telemetry was damaged or packets were lost; the good packets were written.
pub const DAMAGED_TELEMETRY: u8 = 3;
/// The inputs were read but do not support the result asked for (a calibration record that
/// does not determine the parameters, an identification that does not converge, a
/// calibration that does not improve the part of the record held out of its fit): nothing
/// written.
pub const REFUSED: u8 = 4;

/// A result refused for what the data say (exit [`REFUSED`]), as opposed to an input that
/// could not be read ([`BAD_INPUT`]).
#[derive(Debug)]
pub struct Refused(pub String);

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Refused {}

/// A command line that parses but does not make sense (exit [`USAGE`]), e.g. arguments that
/// do not go together.
#[derive(Debug)]
pub struct Usage(pub String);

impl fmt::Display for Usage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// The exit code of an error: [`REFUSED`] for a [`Refused`], [`USAGE`] for a [`Usage`], else
/// [`BAD_INPUT`].
pub fn code_of(e: &(dyn std::error::Error + 'static)) -> u8 {
    if e.downcast_ref::<Refused>().is_some() {
        REFUSED
    } else if e.downcast_ref::<Usage>().is_some() {
        USAGE
    } else {
        BAD_INPUT
    }
}

/// The exit codes as `--help` lists them.
pub const HELP: &str =
    "Exit status: 0 done (or stdout's reader went away); 1 an input is wrong (unreadable,
empty, malformed, or an output that would overwrite an input, is a directory or is not
writable: nothing written); 2 the command line is wrong; 3 (decode)
telemetry damaged or packets lost (the good ones were written); 4 the data do not support the
result asked for (e.g. a calibration record that does not determine the parameters: nothing
written). Results go to stdout or the named file, diagnostics to stderr; `-` names stdin or
stdout where a file is read or written.";
