//! Identification in flight on the firmware host (paper §6): the ground's side — the
//! scenario's reference gyro sent up in TC[200,9] batches, the window started, reported and
//! committed by telecommand — and two boots of the firmware with the calibration store's flash
//! handed from the first to the second (a reset: everything else is dropped).

use ballisto_fw::boot::count_boot;
use ballisto_fw::calstore::ram_flash::{Programming, RamFlash};
use ballisto_fw::calstore::store::{select_at_boot, CalibrationStore};
use ballisto_fw::config::AppConfig;
use ballisto_link::identification::{points_data, ReferencePoint, MAX_POINTS, POINT_LEN};
use ballisto_link::ids::TC_MAX;
use ballisto_link::telecommand::{build_command, Command, ACK_ACCEPTANCE, ACK_COMPLETION};
use ballisto_link::{framing, CalibrationId, ResetCause};

use crate::firmware_host::{
    run_firmware_boot, Boot, Emit, FirmwareReport, HostStore, SimTime, HOST_SECTOR,
};
use crate::motion::Propagator;
use crate::reference::ReferenceSensor;
use crate::rig::TRUTH_STEP;
use crate::scenario::Scenario;

/// When the ground identifies: the window (scenario seconds), the reference points per
/// telecommand and how late each batch arrives after its last point.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// The window starts (TC[200,8] arrives just before).
    pub start: f64,
    /// The window ends; TC[200,10] arrives after the last batch, TC[200,11] after it.
    pub end: f64,
    /// Reference points per TC[200,9].
    pub batch: usize,
    /// Delay of a batch after its last point, s (the bus and the OBC).
    pub latency: f64,
}

impl Plan {
    /// The windows the ground identifies in for `sc`: from 1 s to 1 s before its end; or, where
    /// the scenario's surroundings change temperature, windows of at most 60 s spread evenly
    /// over the run (one per 15 minutes, 3 to 24 of them), so that the unit's thermal track
    /// sees the parts at their temperatures across it. 4 points per telecommand, 50 ms late.
    pub fn for_scenario(sc: &Scenario) -> Vec<Self> {
        let one = |start: f64, end: f64| Plan {
            start,
            end,
            batch: 4,
            latency: 0.05,
        };
        let varies = sc
            .temperature
            .as_ref()
            .is_some_and(|s| !matches!(s, crate::sensors::thermal::Surroundings::Constant { .. }));
        if !varies {
            return vec![one(1.0, (sc.duration - 1.0).max(1.5))];
        }
        let n = (sc.duration / 900.0).floor().clamp(3.0, 24.0) as usize;
        let spacing = sc.duration / n as f64;
        let len = (spacing / 2.0).min(60.0);
        (0..n)
            .map(|k| {
                let mid = (k as f64 + 0.5) * spacing;
                one(mid - len / 2.0, mid + len / 2.0)
            })
            .collect()
    }
}

/// Telecommand frames of an uplink, numbered in order: COBS, as on the line, each with the
/// scenario time it arrives at.
#[derive(Default)]
struct Frames {
    out: Vec<(f64, Vec<u8>)>,
    seq: u16,
}

impl Frames {
    fn push(&mut self, at: f64, ack: u8, command: Command) -> Result<(), String> {
        let mut raw = vec![0u8; TC_MAX];
        let n = build_command(&mut raw, self.seq, ack, &command).ok_or("telecommand too long")?;
        let mut framed = vec![0u8; framing::max_encoded_len(n)];
        let m = framing::encode(&raw[..n], &mut framed).ok_or("framing")?;
        framed.truncate(m);
        self.out.push((at, framed));
        self.seq = self.seq.wrapping_add(1);
        Ok(())
    }

    /// TC[200,8] just before `plan`'s window: `period_ms` and, without a reference, the body's
    /// `inertia`.
    fn start(
        &mut self,
        plan: &Plan,
        period_ms: u16,
        inertia: Option<[f32; 6]>,
    ) -> Result<(), String> {
        let window_ms = ((plan.end - plan.start) * 1000.0).round() as u32;
        self.push(
            plan.start - 0.002,
            ACK_ACCEPTANCE | ACK_COMPLETION,
            Command::StartIdentification {
                period_ms,
                window_ms,
                inertia,
            },
        )
    }

    /// TC[200,10] at `at`.
    fn report(&mut self, at: f64) -> Result<(), String> {
        self.push(
            at,
            ACK_ACCEPTANCE | ACK_COMPLETION,
            Command::ReportIdentification,
        )
    }

    /// TC[200,11] at `at` committing solution `solution` (a boot numbers its solutions from
    /// 1); the frames, in time order.
    fn commit(mut self, at: f64, solution: u16) -> Result<Vec<(f64, Vec<u8>)>, String> {
        self.push(
            at,
            ACK_ACCEPTANCE | ACK_COMPLETION,
            Command::CommitCalibration { solution },
        )?;
        self.out.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(self.out)
    }
}

/// The uplink of identifications in `plans`' windows: for each, TC[200,8] at its start, the
/// reference (the scenario's `[reference]` sensor, on the unit's time) in batches and TC[200,10]
/// after the last batch; then TC[200,11] committing the last window's solution. Frames are
/// COBS, as on the line; times are scenario seconds.
pub fn uplink(sc: &Scenario, plans: &[Plan]) -> Result<Vec<(f64, Vec<u8>)>, String> {
    let mut sensor = ReferenceSensor::of(sc).ok_or_else(|| {
        format!(
            "scenario {}: no [reference] sensor to identify with",
            sc.description
        )
    })?;
    let reference_rate = sc
        .reference
        .as_ref()
        .and_then(|r| r.rate)
        .unwrap_or(sc.rate);
    let period_ms = (1000.0 / reference_rate).round().clamp(1.0, 1000.0) as u16;
    let mut truth = Propagator::new(sc.motion(), TRUTH_STEP);
    let mut frames = Frames::default();
    // The reference's points in each window, with their scenario times (the sensor sampled
    // once, in order, over the whole run).
    let mut points: Vec<Vec<(f64, ReferencePoint)>> = vec![Vec::new(); plans.len()];
    let last_end = plans.iter().map(|p| p.end).fold(0.0, f64::max);
    for k in 0..sc.samples() {
        let t = k as f64 / sc.rate;
        if t > last_end {
            break;
        }
        let tr = truth.truth_at(t);
        let Some(w) = sensor.sample(k, &tr) else {
            continue;
        };
        if let Some(i) = plans.iter().position(|p| t >= p.start && t <= p.end) {
            let point = ReferencePoint {
                t: SimTime::nanos(t),
                omega: w.map(|v| v as f32),
            };
            points[i].push((t, point));
        }
    }
    let mut at = 0.0;
    for (plan, points) in plans.iter().zip(&points) {
        frames.start(plan, period_ms, None)?;
        for chunk in points.chunks(plan.batch.clamp(1, MAX_POINTS)) {
            let batch: Vec<ReferencePoint> = chunk.iter().map(|(_, p)| *p).collect();
            let mut data = vec![0u8; 1 + POINT_LEN * batch.len()];
            let n = points_data(&batch, &mut data).ok_or("reference batch")?;
            let at = chunk.last().map_or(plan.start, |p| p.0) + plan.latency;
            frames.push(at, 0, Command::ReferenceRate(&data[..n]))?;
        }
        let last = points.last().map_or(plan.start, |p| p.0);
        at = last + plan.latency + 0.1;
        frames.report(at)?;
    }
    frames.commit(at + 0.1, plans.len() as u16)
}

/// The uplink of identifications without a reference (TC[200,8] source 2) in `plans`'
/// windows, with the body's inertia (the scenario's principal moments), the unit keeping
/// means of `mean_ms` of sets; TC[200,10] 0.1 s after each window, then TC[200,11] committing
/// the last window's solution. Errors: a scenario whose body has no inertia or a torque (not
/// a torque-free tumble).
pub fn uplink_tumble(
    sc: &Scenario,
    plans: &[Plan],
    mean_ms: u16,
) -> Result<Vec<(f64, Vec<u8>)>, String> {
    let j = match (sc.body.inertia, &sc.body.torque) {
        (Some(j), None) => j,
        _ => {
            return Err(format!(
                "scenario {}: not a torque-free tumble with its inertia given",
                sc.description
            ))
        }
    };
    let mut frames = Frames::default();
    let mut at = 0.0;
    for plan in plans {
        let inertia = [j[0] as f32, j[1] as f32, j[2] as f32, 0.0, 0.0, 0.0];
        frames.start(plan, mean_ms, Some(inertia))?;
        at = plan.end + 0.1;
        frames.report(at)?;
    }
    frames.commit(at + 0.1, plans.len() as u16)
}

/// Flash of the host's calibration store: four sectors.
pub const STORE_LEN: usize = 4 * HOST_SECTOR;

/// Two boots: the first runs `config` (the nominal arrangement) on an erased store, or on
/// `calibration` committed to it on the ground ([`boot_on_stored`]), with `uplink`
/// (identifications ending in a commit) and its telemetry into `downlink1`; the second, after
/// the reset, boots with what the store gives (`select_at_boot`) and runs the scenario again,
/// telemetry into `downlink2`, every estimate through `emit`. Returns both reports and the
/// calibration the second boot used.
pub fn identify_and_reboot(
    sc: &Scenario,
    config: &AppConfig,
    calibration: Option<&estimator_core::Arrangement<{ ballisto_fw::config::MAX_CHANNELS }>>,
    uplink: &[(f64, Vec<u8>)],
    downlink1: &mut dyn std::io::Write,
    downlink2: &mut dyn std::io::Write,
    emit: Emit,
) -> Result<(FirmwareReport, FirmwareReport, CalibrationId), String> {
    let mut mem = vec![0xFFu8; STORE_LEN];
    let mut erases = [0u32; STORE_LEN / HOST_SECTOR];
    let flash = RamFlash::new(&mut mem, &mut erases, Programming::WordOnce);
    let range = 0..STORE_LEN as u32;
    let mut store = CalibrationStore::new(flash, range.clone()).map_err(|e| format!("{e}"))?;
    let (first_config, first_id) = match calibration {
        Some(c) => commit_on_ground(&mut store, config, c)?,
        None => (config.clone(), CalibrationId::default()),
    };
    let instants = sc.samples() as u32;
    // The boot count in RAM that survives the reset (not a power loss), as on the boards.
    let mut retained = [0u32; 2];
    let info = count_boot(&mut retained, ResetCause::PowerOn);
    let first = run_firmware_boot(
        sc,
        &first_config,
        instants,
        uplink,
        downlink1,
        &mut |_, _, _| {},
        Boot {
            store: Some(&mut store),
            calibration: first_id,
            info,
        },
    )?;
    // The reset: only the flash survives.
    let flash = store.into_flash();
    let mut store = CalibrationStore::new(flash, range).map_err(|e| format!("{e}"))?;
    let (second_config, id) =
        stored_config(&mut store, config).map_err(|e| format!("second boot: {e}"))?;
    let second = run_firmware_boot(
        sc,
        &second_config,
        instants,
        &[],
        downlink2,
        emit,
        Boot {
            store: Some(&mut store),
            calibration: id,
            info: count_boot(&mut retained, ResetCause::Software),
        },
    )?;
    Ok((first, second, id))
}

/// The configuration a boot runs with what `store` holds (`select_at_boot`, as the boards
/// do); an error if the stored calibration is not used.
fn stored_config(
    store: &mut HostStore<'_>,
    config: &AppConfig,
) -> Result<(AppConfig, CalibrationId), String> {
    let (arrangement, id, not_used) =
        embassy_futures::block_on(select_at_boot(store, &config.arrangement));
    if let Some(why) = not_used {
        return Err(format!("the stored calibration was not used ({why:?})"));
    }
    let mut stored = config.clone();
    stored.arrangement = arrangement;
    Ok((stored, id))
}

/// `calibration` committed to `store` on the ground (id 1, as the unit leaves calibration) and
/// selected at boot: the configuration a boot runs with it.
fn commit_on_ground(
    store: &mut HostStore<'_>,
    config: &AppConfig,
    calibration: &estimator_core::Arrangement<{ ballisto_fw::config::MAX_CHANNELS }>,
) -> Result<(AppConfig, CalibrationId), String> {
    let record = ballisto_fw::calstore::record::CalibrationRecord {
        id: 1,
        arrangement: calibration.clone(),
    };
    embassy_futures::block_on(store.commit(&record))
        .map_err(|e| format!("the calibration cannot be stored: {e:?}"))?;
    stored_config(store, config)
}

/// One boot with `calibration` in the store (committed on the ground, id 1, as the unit leaves
/// calibration): the firmware selects it at boot (`select_at_boot`: the record is encoded,
/// stored, read back and checked as on the board) and runs the scenario on it, telemetry into
/// `downlink`, every estimate through `emit`. Returns the report and the calibration used.
pub fn boot_on_stored(
    sc: &Scenario,
    config: &AppConfig,
    calibration: &estimator_core::Arrangement<{ ballisto_fw::config::MAX_CHANNELS }>,
    uplink: &[(f64, Vec<u8>)],
    downlink: &mut dyn std::io::Write,
    emit: Emit,
) -> Result<(FirmwareReport, CalibrationId), String> {
    let mut mem = vec![0xFFu8; STORE_LEN];
    let mut erases = [0u32; STORE_LEN / HOST_SECTOR];
    let flash = RamFlash::new(&mut mem, &mut erases, Programming::WordOnce);
    let mut store =
        CalibrationStore::new(flash, 0..STORE_LEN as u32).map_err(|e| format!("{e}"))?;
    let (stored_config, id) = commit_on_ground(&mut store, config, calibration)?;
    let mut retained = [0u32; 2];
    let report = run_firmware_boot(
        sc,
        &stored_config,
        sc.samples() as u32,
        uplink,
        downlink,
        emit,
        Boot {
            store: Some(&mut store),
            calibration: id,
            info: count_boot(&mut retained, ResetCause::PowerOn),
        },
    )?;
    Ok((report, id))
}
