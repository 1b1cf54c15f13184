//! The built-in tumble: identification without a reference (TC[200,8] source 2), what
//! the QEMU board runs when its semihosting command line says `tumble`, and what the host
//! recomputes to check it. The `tetra` board with its parts as mounted ([`demo::truth`]: u2 3 mm
//! off) tumbles torque-free in free flight ([`Synthetic::tumbling`]), in two boots:
//!
//! 1. Power-on, the store erased: the nominal arrangement, for [`BOOT1_SETS`] sets. The ground
//!    starts a window with the body's inertia and no reference ([`START`]: the unit keeps means
//!    of 40 ms with its own rate), asks for the solution after it (TC[200,10]) and commits it
//!    once reported (TC[200,11]). The search runs in the identification task, below the
//!    estimate and below the builder of configurations: u3 falls silent while it runs
//!    ([`OUTAGE`]) and is excluded and re-admitted meanwhile. Then a reset.
//! 2. The calibration read back from the store, the same tumble from its start, for [`SETS`]
//!    sets, nothing on the uplink (`demo::quiet`).
//!
//! The search is f64: on a core with double-precision hardware (the STM32H743's Cortex-M7,
//! QEMU's mps2-an500) about 24 G instructions, a minute at 400 MHz; in the soft f64 of
//! mps2-an386's Cortex-M4F QEMU did not finish it in 20 minutes. `scripts/qemu-board-m7.sh`
//! runs this scenario on mps2-an500.

use ballisto_link::telecommand::Command;

use crate::demo::{self, Step};
use crate::synthetic::{Outage, Synthetic};

/// The body's principal moments of inertia (kg·m²).
pub const INERTIA: [f64; 3] = [1.0, 1.8, 2.5];

/// Ω at the first instant (rad/s): near the intermediate axis, so that the body turns over
/// again and again (the field's terms all vary).
pub const OMEGA0: [f64; 3] = [0.3, 1.7, -0.6];

/// The window: from set 50 for 40 s, kept as means of 40 ms (1 000 means).
const WINDOW_FIRST: u32 = 50;
const WINDOW_SETS: u32 = 4000;
const MEAN_MS: u16 = 40;

/// When the ground commits, after the window's last set (s): once the solution is reported.
/// On QEMU's Cortex-M7 at 250 MIPS (`scripts/qemu-board-m7.sh`) the search takes 96 s (about
/// 24 G instructions; the host's is instant). The QEMU board's scripted uplink runs in thread
/// mode beside the search, so the commit never arrives before the solution; the boot lasts a
/// second beyond this time, so a slower search would end the boot before the commit, and the
/// test that reads the telemetry would fail.
const COMMIT_AFTER_S: f64 = 120.0;

/// Sets of the first boot: the window, the search and the commit, and a second more.
pub const BOOT1_SETS: u32 = WINDOW_FIRST + WINDOW_SETS + (COMMIT_AFTER_S as u32 + 1) * 100;

/// Sets of the second boot (10 s at 100 Hz).
pub const SETS: u32 = 1000;

/// TC[200,8] source 2: the means' period, the window (ending half a period after a set, as
/// [`demo`]'s) and the inertia (principal, no products).
pub const START: Command<'static> = Command::StartIdentification {
    period_ms: MEAN_MS,
    window_ms: WINDOW_SETS * 10 + 5,
    inertia: Some([
        INERTIA[0] as f32,
        INERTIA[1] as f32,
        INERTIA[2] as f32,
        0.0,
        0.0,
        0.0,
    ]),
};

/// Part u3 silent from 45 s to 46 s of the first boot: after the window, while the board
/// searches. Its exclusion is built below the estimate and above the search, so it does not
/// wait for the search to end.
pub const OUTAGE: Outage = Outage {
    part: 3,
    from: 45.0,
    to: 46.0,
};

/// The parts as mounted, tumbling; u3 silent over `outage`.
pub fn source(outage: Option<Outage>) -> Synthetic {
    Synthetic::new(&demo::truth(), outage, None).tumbling(INERTIA, OMEGA0)
}

/// The first boot's uplink: TC[200,8] just before the window, TC[200,10] after it,
/// TC[200,11] committing solution 1 once it is reported.
pub fn identification(i: usize) -> Option<(f64, Step)> {
    let at = |set: u32| f64::from(set) * 0.01;
    let last = WINDOW_FIRST + WINDOW_SETS;
    match i {
        0 => Some((at(WINDOW_FIRST) - 0.005, Step::Command(START))),
        1 => Some((
            at(last) + 0.105,
            Step::Command(Command::ReportIdentification),
        )),
        2 => Some((
            at(last) + COMMIT_AFTER_S,
            Step::Command(Command::CommitCalibration { solution: 1 }),
        )),
        _ => None,
    }
}
