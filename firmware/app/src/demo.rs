//! The built-in scenario: what a board without accelerometers runs (QEMU in CI), and what
//! the host recomputes to check it. The `tetra` board on the synthetic motion of
//! [`crate::sampler::synthetic`] for [`SETS`] sets, one part silent for half a second, one
//! stuck for 0.4 s ([`STUCK`]), and a
//! script of telecommands on the uplink ([`SCRIPT`]) that exercises every path: mode changes,
//! a housekeeping request, line noise, a damaged command, a model change, an exclusion.

use ballisto_link::framing;
use ballisto_link::telecommand::{self, ACK_ACCEPTANCE, ACK_COMPLETION};
use ballisto_link::{service, sid, subtype};
use embedded_io_async::{ErrorType, Read};

use core::ops::Range;

use ballisto_link::{BootInfo, CalibrationId, ResetCause};
use embedded_storage_async::nor_flash::NorFlash;

use crate::calstore::{select_at_boot, CalibrationRecord, CalibrationStore};
use crate::config::{tetra, AppConfig};
use crate::sampler::synthetic::Outage;
use crate::time::{Nanos, TimeBase};

/// Sample sets of the run (10 s at 100 Hz).
pub const SETS: u32 = 1000;

/// Part u3 silent from 4.0 s to 4.5 s.
pub const OUTAGE: Outage = Outage {
    part: 3,
    from: 4.0,
    to: 4.5,
};

/// Part u1's output stuck from 8.3 s to 8.7 s: the fault monitor isolates it (its own signal
/// frozen), the estimate goes on without it, and it is re-admitted once it moves again.
pub const STUCK: Outage = Outage {
    part: 1,
    from: 8.3,
    to: 8.7,
};

/// The configuration: the built-in `tetra` board.
pub fn config() -> AppConfig {
    tetra()
}

/// What the calibration boots of the scenario found ([`calibration_boots`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CalibrationBoots {
    /// The first boot, on an erased store: the built-in arrangement.
    pub first: CalibrationId,
    /// The second, after the commit and a reset: the stored record.
    pub second: CalibrationId,
    /// The second boot's count and cause: the second since power-on, by a software reset (the
    /// QEMU board's SYSRESETREQ), as [`crate::boot::count_boot`] counts them.
    pub boot: BootInfo,
}

/// The scenario's first boot on `flash` (erased; `range` of it, whole sectors): the empty
/// store gives the built-in arrangement; the built-in arrangement is then committed as
/// calibration 1 (what a ground calibration uploaded by command would be). Returns what the
/// boot chose and the flash; a reset follows.
pub async fn first_boot<F: NorFlash>(
    flash: F,
    range: Range<u32>,
) -> Result<(CalibrationId, F), &'static str> {
    let builtin = config().arrangement;
    let mut store = CalibrationStore::new(flash, range).map_err(|_| "store range")?;
    let (_, first, _) = select_at_boot(&mut store, &builtin).await;
    let record = CalibrationRecord {
        id: 1,
        arrangement: builtin,
    };
    store.commit(&record).await.map_err(|_| "commit")?;
    Ok((first, store.into_flash()))
}

/// A boot after it: the configuration with the arrangement the store gives, and its identity.
pub async fn boot<F: NorFlash>(
    flash: F,
    range: Range<u32>,
) -> Result<(AppConfig, CalibrationId, F), &'static str> {
    let mut config = config();
    let mut store = CalibrationStore::new(flash, range).map_err(|_| "store range")?;
    let (arrangement, id, _) = select_at_boot(&mut store, &config.arrangement).await;
    config.arrangement = arrangement;
    Ok((config, id, store.into_flash()))
}

/// [`first_boot`], a reset (here: the flash given back, everything else dropped) and [`boot`]:
/// what the host runs; the QEMU board runs the two with a reset of the machine between them.
pub async fn calibration_boots<F: NorFlash>(
    flash: F,
    range: Range<u32>,
) -> Result<(AppConfig, CalibrationBoots, F), &'static str> {
    let mut retained = [0u32; 2];
    crate::boot::count_boot(&mut retained, ResetCause::PowerOn);
    let (first, flash) = first_boot(flash, range.clone()).await?;
    let boot_info = crate::boot::count_boot(&mut retained, ResetCause::Software);
    let (config, second, flash) = boot(flash, range).await?;
    let boots = CalibrationBoots {
        first,
        second,
        boot: boot_info,
    };
    Ok((config, boots, flash))
}

/// What arrives on the uplink.
#[derive(Clone, Copy, Debug)]
pub enum Step {
    /// A telecommand TC[service, subtype] with application data, all acknowledgements asked.
    Command(u8, u8, &'static [u8]),
    /// The same, its CRC damaged on the line.
    Damaged(u8, u8, &'static [u8]),
    /// Line noise.
    Noise(&'static [u8]),
}

/// The uplink script: (seconds after the first instant, what arrives). Times sit between
/// two sample instants, so a command is handled between the same two sets on every machine.
pub const SCRIPT: [(f64, Step); 9] = [
    (
        2.005,
        Step::Command(service::BALLISTOMETER, subtype::SET_MODE, &[0]),
    ),
    (
        2.505,
        Step::Command(service::BALLISTOMETER, subtype::SET_MODE, &[1]),
    ),
    (
        3.005,
        Step::Command(
            service::HOUSEKEEPING,
            subtype::HK_ONE_SHOT,
            &[1, 0, sid::HOUSEKEEPING as u8],
        ),
    ),
    (3.505, Step::Noise(&[0x55, 0xAA, 0x00, 0x13])),
    (
        3.605,
        Step::Damaged(service::BALLISTOMETER, subtype::SET_MODEL, &[1]),
    ),
    (
        6.005,
        Step::Command(service::BALLISTOMETER, subtype::SET_MODEL, &[1]),
    ),
    (
        7.005,
        Step::Command(service::BALLISTOMETER, subtype::EXCLUDE, &[11]),
    ),
    (
        8.005,
        Step::Command(service::BALLISTOMETER, subtype::INCLUDE, &[11]),
    ),
    (
        9.005,
        Step::Command(service::TEST, subtype::ARE_YOU_ALIVE, &[]),
    ),
];

/// The frame of a script step with sequence count `seq`; its length.
pub fn frame(step: Step, seq: u16, out: &mut [u8]) -> usize {
    let (s, st, data, damaged) = match step {
        Step::Noise(bytes) => {
            let n = bytes.len().min(out.len());
            out[..n].copy_from_slice(&bytes[..n]);
            return n;
        }
        Step::Command(s, st, d) => (s, st, d, false),
        Step::Damaged(s, st, d) => (s, st, d, true),
    };
    let mut raw = [0u8; 64];
    // Every acknowledgement asked (start and progress too: accepted, not reported).
    let ack = ACK_ACCEPTANCE | 0x4 | 0x2 | ACK_COMPLETION;
    let Some(n) = telecommand::build(&mut raw, seq, ack, s, st, data) else {
        return 0;
    };
    if damaged {
        raw[n - 1] ^= 0x5A;
    }
    framing::encode(&raw[..n], out).unwrap_or(0)
}

/// The uplink of the built-in scenario: each step of [`SCRIPT`] once the time base reaches
/// it, then nothing.
pub struct ScriptedUplink<'a, T> {
    time: &'a T,
    t0: Nanos,
    next: usize,
}

impl<'a, T: TimeBase> ScriptedUplink<'a, T> {
    /// The script, its times counted from the first sample instant `t0`.
    pub fn new(time: &'a T, t0: Nanos) -> Self {
        ScriptedUplink { time, t0, next: 0 }
    }
}

impl<T> ErrorType for ScriptedUplink<'_, T> {
    type Error = core::convert::Infallible;
}

impl<T: TimeBase> Read for ScriptedUplink<'_, T> {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let Some(&(at, step)) = SCRIPT.get(self.next) else {
            return core::future::pending().await;
        };
        let at = self.t0 + (at * 1e9) as Nanos;
        while self.time.now() < at {
            embassy_futures::yield_now().await;
        }
        self.next += 1;
        Ok(frame(step, self.next as u16, buf))
    }
}
