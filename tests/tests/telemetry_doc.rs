//! `docs/telemetry.md` agrees with the link crate's layouts, so the document a ground segment
//! decodes from cannot drift from the bytes: every row of the motion and housekeeping tables
//! (offset, type) is read back from a report encoded by `ballisto_link` with a distinct value
//! in every field, the rows tile the application data without gap or overlap up to its
//! length, and the lengths the document states are the crate's.

use std::path::Path;

use ballisto_link::event::EVENT_LEN;
use ballisto_link::housekeeping::HOUSEKEEPING_LEN;
use ballisto_link::motion::MOTION_LEN;
use ballisto_link::{
    BootInfo, CalibrationId, CalibrationSource, ChannelSet, ConsistencyTest, Housekeeping,
    LoopCounters, Mode, ModelCode, MotionReport, PartCounters, PartSet, PartState, RequestId,
    ResetCause, TimeCorrelation, Verification,
};
use estimator_core::linalg::Sym3;
use estimator_core::{Estimate, Flags};

fn doc() -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/telemetry.md");
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// One documented field: offset, element type, count.
#[derive(Debug)]
struct Row {
    offset: usize,
    ty: String,
    count: usize,
    field: String,
}

/// The `| offset | type | field |` table under the heading that starts with `heading`.
fn table(doc: &str, heading: &str) -> Vec<Row> {
    let start = doc
        .find(heading)
        .unwrap_or_else(|| panic!("no section {heading}"));
    let mut rows = Vec::new();
    let mut in_table = false;
    for line in doc[start..].lines().skip(1) {
        if line.starts_with("| offset | type | field |") {
            in_table = true;
            continue;
        }
        if !in_table {
            continue;
        }
        if !line.starts_with('|') {
            break;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells[1].starts_with("---") {
            continue;
        }
        let offset: usize = cells[1]
            .parse()
            .unwrap_or_else(|_| panic!("offset in {line}"));
        let (count, ty) = match cells[2].split_once('×') {
            Some((n, t)) => (n.trim().parse().expect("count"), t.trim().to_string()),
            None => (1, cells[2].to_string()),
        };
        rows.push(Row {
            offset,
            ty,
            count,
            field: cells[3].to_string(),
        });
    }
    assert!(!rows.is_empty(), "no table under {heading}");
    rows
}

fn size(ty: &str) -> usize {
    match ty {
        "u8" | "i8" => 1,
        "u16" => 2,
        "u32" | "f32" => 4,
        // A housekeeping part slot: state and six counters.
        "25" => 25,
        _ => panic!("unknown type {ty}"),
    }
}

/// Reads the row's values as f64 (the part-slot rows are read as their 25 octets' sum).
fn values(data: &[u8], row: &Row) -> Vec<f64> {
    let n = size(&row.ty);
    (0..row.count)
        .map(|i| {
            let b = &data[row.offset + i * n..row.offset + (i + 1) * n];
            match row.ty.as_str() {
                "u8" => f64::from(b[0]),
                "i8" => f64::from(b[0] as i8),
                "u16" => f64::from(u16::from_be_bytes([b[0], b[1]])),
                "u32" => f64::from(u32::from_be_bytes(b.try_into().unwrap())),
                "f32" => f64::from(f32::from_be_bytes(b.try_into().unwrap())),
                _ => b.iter().map(|v| f64::from(*v)).sum(),
            }
        })
        .collect()
}

/// Each row's field starts with its keyword and holds the expected values.
fn check_rows(data: &[u8], rows: &[Row], expected: &[(&str, Vec<f64>)], what: &str) {
    assert_eq!(rows.len(), expected.len(), "{what} rows");
    for (row, (name, want)) in rows.iter().zip(expected.iter()) {
        assert!(
            row.field.starts_with(name),
            "{what} offset {}: field \"{}\" is not {name}",
            row.offset,
            row.field
        );
        assert_eq!(
            &values(data, row),
            want,
            "{what} {name} at offset {}",
            row.offset
        );
    }
}

/// The rows tile `0..len`.
fn check_tiling(rows: &[Row], len: usize, what: &str) {
    let mut at = 0;
    for r in rows {
        assert_eq!(r.offset, at, "{what}: a gap or overlap before {r:?}");
        at += size(&r.ty) * r.count;
    }
    assert_eq!(
        at, len,
        "{what}: the table ends at {at}, the layout at {len}"
    );
}

#[test]
fn motion_report_table_matches_the_encoder() {
    let doc = doc();
    let rows = table(&doc, "### Motion report");
    check_tiling(&rows, MOTION_LEN, "motion");
    let f = |base: f32| [base + 0.25, base + 0.5, base + 0.75];
    let six = |base: f32| {
        Sym3([
            base,
            base + 1.0,
            base + 2.0,
            base + 3.0,
            base + 4.0,
            base + 5.0,
        ])
    };
    let estimate = Estimate::<f32> {
        sigma0: f(10.0),
        domega: f(20.0),
        omega: f(30.0),
        field: six(40.0),
        flags: Flags(0x51),
        chi2: 7.5,
        dof: 3,
        branches: 2,
        frame: 1,
        epsilon: -1,
        sd_sigma0: f(50.0),
        sd_domega: f(60.0),
        sd_omega: f(70.0),
        sd_field: six(80.0),
        branch_margin: 42.5,
        protection: Some(f(90.0)),
        ..Estimate::default()
    };
    let report = MotionReport {
        k: 123_456,
        estimate,
        missing_parts: PartSet(0x05),
        excluded_parts: PartSet(0x02),
        excluded_channels: ChannelSet(0x0F00),
        context: Some((Mode::Operate, ModelCode::FreeFloat)),
    };
    let mut data = [0u8; MOTION_LEN];
    assert_eq!(report.encode(&mut data), Some(MOTION_LEN));
    // In the document's row order.
    let v3 = |b: f32| f(b).map(f64::from).to_vec();
    let v6 = |b: f32| six(b).0.map(f64::from).to_vec();
    let expected = [
        ("SID", vec![1.0]),
        ("k", vec![123_456.0]),
        ("σ0", v3(10.0)),
        ("Ω′", v3(20.0)),
        ("Ω", v3(30.0)),
        ("A", v6(40.0)),
        ("flags", vec![f64::from(0x51)]),
        ("χ²", vec![7.5]),
        ("degrees of freedom", vec![3.0]),
        ("real branches", vec![2.0]),
        ("estimation frame", vec![1.0]),
        ("ε", vec![-1.0]),
        ("sd σ0", v3(50.0)),
        ("sd Ω′", v3(60.0)),
        ("sd Ω", v3(70.0)),
        ("sd A", v6(80.0)),
        ("parts without a value", vec![5.0]),
        ("parts excluded", vec![2.0]),
        ("channels not in the solve", vec![f64::from(0x0F00)]),
        ("branch margin", vec![42.5]),
        ("mode", vec![1.0]),
        ("model", vec![1.0]),
        ("protection levels", v3(90.0)),
    ];
    check_rows(&data, &rows, &expected, "motion");
    let packet = format!("(packet {} octets)", 21 + MOTION_LEN + 2);
    assert!(doc.contains(&format!("### Motion report — TM[3,25], SID 1 {packet}")));
}

#[test]
fn housekeeping_table_matches_the_encoder() {
    let doc = doc();
    let rows = table(&doc, "### Housekeeping report");
    check_tiling(&rows, HOUSEKEEPING_LEN, "housekeeping");
    let mut parts = [PartCounters::default(); 8];
    parts[1] = PartCounters {
        state: PartState::Down,
        reads: 1,
        bus_errors: 2,
        implausible: 3,
        missed: 4,
        failed_starts: 5,
        resyncs: 6,
    };
    let hk = Housekeeping {
        version: [1, 2, 3],
        mode: 1,
        model: 1,
        channels: 12,
        rate_hz: 100.0,
        motion_every: 2,
        housekeeping_every: 50,
        sampling: LoopCounters {
            sets: 1000,
            skipped: 4,
            dropped: 5,
            sync_errors: 6,
        },
        estimates: 999,
        excluded_parts: PartSet(0x08),
        commanded_out: ChannelSet(0x800),
        excluded_channels: ChannelSet(0xE00),
        tc_accepted: 7,
        tc_rejected: 8,
        frames_garbage: 9,
        tm_lost: 10,
        parts,
        calibration: Some(CalibrationId {
            source: CalibrationSource::Flash,
            id: 11,
            crc: 12,
        }),
        boot: Some((
            BootInfo {
                count: 13,
                cause: ResetCause::Watchdog,
            },
            TimeCorrelation {
                set: true,
                epoch: [1, 2, 3, 4, 5, 6, 7],
            },
        )),
        test: Some(ConsistencyTest::OwnResidual),
        temperatures: Some([21.5, -3.25, 40.0, 0.5, 1.5, 2.5, 3.5, 4.5]),
    };
    let mut data = [0u8; HOUSEKEEPING_LEN];
    assert_eq!(hk.encode(&mut data), Some(HOUSEKEEPING_LEN));
    let expected = [
        ("SID", vec![2.0]),
        ("firmware version", vec![1.0, 2.0, 3.0]),
        ("mode", vec![1.0]),
        ("model", vec![1.0]),
        ("channels in the arrangement", vec![12.0]),
        ("sample rate", vec![100.0]),
        ("motion_every", vec![2.0]),
        ("housekeeping_every", vec![50.0]),
        ("sample sets produced", vec![1000.0]),
        ("instants skipped", vec![4.0]),
        ("sets dropped", vec![5.0]),
        ("SYNC line failures", vec![6.0]),
        ("estimates computed", vec![999.0]),
        ("parts excluded automatically", vec![8.0]),
        ("channels excluded by command", vec![f64::from(0x800)]),
        ("channels not in the solve", vec![f64::from(0xE00)]),
        ("telecommands accepted", vec![7.0]),
        ("telecommands refused", vec![8.0]),
        ("command-link frames", vec![9.0]),
        ("telemetry packets the link failed", vec![10.0]),
        // Part slot 1: state 2, then counters 1..6 (their big-endian octets sum to 2 + 21).
        (
            "per part slot",
            vec![0.0, 23.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        ),
        ("calibration source", vec![1.0]),
        ("calibration id", vec![11.0]),
        ("CRC-32 (ISO-HDLC) of the calibration record", vec![12.0]),
        ("boot count", vec![13.0]),
        ("reset cause", vec![4.0]),
        ("time correlation", vec![1.0]),
        (
            "spacecraft time of the boot",
            (1..=7).map(f64::from).collect(),
        ),
        ("consistency test", vec![3.0]),
        (
            "per part slot 0–7, its last temperature",
            vec![21.5, -3.25, 40.0, 0.5, 1.5, 2.5, 3.5, 4.5],
        ),
    ];
    check_rows(&data, &rows, &expected, "housekeeping");
    // Slot 1 octet by octet: the state, then six u32 counters.
    let slot = &data[61 + 25..61 + 50];
    assert_eq!(slot[0], PartState::Down as u8);
    for (i, c) in slot[1..].chunks(4).enumerate() {
        assert_eq!(u32::from_be_bytes(c.try_into().unwrap()), i as u32 + 1);
    }
    let packet = format!("(packet {} octets)", 21 + HOUSEKEEPING_LEN + 2);
    assert!(doc.contains(&format!(
        "### Housekeeping report — TM[3,25], SID 2 {packet}"
    )));
}

/// The report overview's application data lengths are the crate's.
#[test]
fn stated_lengths_are_the_layouts() {
    let doc = doc();
    let mut buf = [0u8; 32];
    let request = RequestId::default();
    let ok = Verification {
        subtype: 1,
        request,
        failure: None,
    }
    .encode(&mut buf)
    .unwrap();
    let failed = Verification {
        subtype: 2,
        request,
        failure: Some((ballisto_link::FailureCode::Checksum, 0)),
    }
    .encode(&mut buf)
    .unwrap();
    for (report, len) in [
        ("| motion | TM[3,25] SID 1 |", MOTION_LEN.to_string()),
        (
            "| housekeeping | TM[3,25] SID 2 |",
            HOUSEKEEPING_LEN.to_string(),
        ),
        (
            "| event | TM[5,1..4] (subtype = severity) |",
            EVENT_LEN.to_string(),
        ),
        (
            "| verification | TM[1,1] / [1,2] / [1,7] / [1,8] |",
            format!("{ok} / {failed} / {ok} / {failed}"),
        ),
    ] {
        let line = doc
            .lines()
            .find(|l| l.starts_with(report))
            .unwrap_or_else(|| panic!("no row {report}"));
        let cell = line[report.len()..].split('|').next().unwrap().trim();
        assert_eq!(cell, len, "{report}");
    }
}

#[test]
fn identification_tables_match_the_encoders() {
    use ballisto_link::identification::{
        IdentificationSummary, IdentifiedChannel, CHANNEL_LEN, SUMMARY_LEN,
    };
    let doc = doc();
    let rows = table(&doc, "### Identification summary");
    check_tiling(&rows, SUMMARY_LEN, "identification summary");
    let s = IdentificationSummary {
        solution: 3,
        channels: 12,
        sets: 5800,
        not_covered: 4,
        incomplete: 5,
        points: 1161,
        restarts: 2,
        rho: [0.25, 0.5, 0.75],
        rho_sd: [1.25, 1.5, 1.75],
        frame: [2.25, 2.5, 2.75],
    };
    let mut data = [0u8; SUMMARY_LEN];
    assert_eq!(s.encode(&mut data), Some(SUMMARY_LEN));
    let expected = [
        ("solution number", vec![3.0]),
        ("channels", vec![12.0]),
        ("1: octet 24 is ρ", vec![1.0]),
        ("sample sets in the solution", vec![5800.0]),
        ("sets the reference did not cover", vec![4.0]),
        ("sets with a reading missing", vec![5.0]),
        ("reference points taken", vec![1161.0]),
        ("reference restarts", vec![2.0]),
        ("ρ of paper eq. 12", vec![0.25, 0.5, 0.75]),
        ("its standard deviation", vec![1.25, 1.5, 1.75]),
        ("the identified frame's uncertainty", vec![2.25, 2.5, 2.75]),
    ];
    check_rows(&data, &rows, &expected, "identification summary");
    assert!(doc.contains(&format!(
        "### Identification summary — TM[200,128] (packet {} octets)",
        21 + SUMMARY_LEN + 2
    )));

    let rows = table(&doc, "### Identified channel");
    check_tiling(&rows, CHANNEL_LEN, "identified channel");
    let c = IdentifiedChannel {
        solution: 3,
        channel: 7,
        held: 0b100001,
        position: [0.25, 0.5, 0.75],
        axis: [1.25, 1.5, 1.75],
        bias: 2.5,
        scale: 3.5,
        sd: [4.0, 4.25, 4.5, 4.75, 5.0, 5.25, 5.5],
        residual_rms: 6.5,
        noise: 7.5,
    };
    let mut data = [0u8; CHANNEL_LEN];
    assert_eq!(c.encode(&mut data), Some(CHANNEL_LEN));
    let expected = [
        ("solution number", vec![3.0]),
        ("channel", vec![7.0]),
        ("held", vec![33.0]),
        ("position", vec![0.25, 0.5, 0.75]),
        ("axis", vec![1.25, 1.5, 1.75]),
        ("bias", vec![2.5]),
        ("scale", vec![3.5]),
        (
            "standard deviations",
            vec![4.0, 4.25, 4.5, 4.75, 5.0, 5.25, 5.5],
        ),
        ("RMS of the channel's residual", vec![6.5]),
        ("the channel's declared noise", vec![7.5]),
    ];
    check_rows(&data, &rows, &expected, "identified channel");
    assert!(doc.contains(&format!(
        "### Identified channel — TM[200,129] (packet {} octets)",
        21 + CHANNEL_LEN + 2
    )));

    use ballisto_link::identification::{ThermalTrack, TRACK_LEN};
    let rows = table(&doc, "### Thermal track");
    check_tiling(&rows, TRACK_LEN, "thermal track");
    let k = ThermalTrack {
        solution: 4,
        channel: 9,
        state: 3,
        windows: 11,
        window_temperature: 12.5,
        span: 38.5,
        t_ref: 21.25,
        bias: 0.125,
        bias_sd: 0.25,
        bias_tc: 0.375,
        bias_tc_sd: 0.5,
        scatter: 1.75,
    };
    let mut data = [0u8; TRACK_LEN];
    assert_eq!(k.encode(&mut data), Some(TRACK_LEN));
    let expected = [
        ("solution number", vec![4.0]),
        ("channel", vec![9.0]),
        ("state", vec![3.0]),
        ("windows in the track", vec![11.0]),
        ("this window's mean temperature", vec![12.5]),
        ("span of the windows' mean temperatures", vec![38.5]),
        ("`t_ref`", vec![21.25]),
        ("bias at `t_ref`", vec![0.125]),
        ("its standard deviation", vec![0.25]),
        ("`bias_tc`", vec![0.375]),
        ("its standard deviation", vec![0.5]),
        ("the windows' scatter", vec![1.75]),
    ];
    check_rows(&data, &rows, &expected, "thermal track");
    assert!(doc.contains(&format!(
        "### Thermal track — TM[200,130] (packet {} octets)",
        21 + TRACK_LEN + 2
    )));
}

/// The numbers of `text` that follow `before` (digits with spaces between thousands, and a
/// decimal point), e.g. `379 404` → 379404.
fn number_after(text: &str, before: &str) -> f64 {
    let at = text
        .find(before)
        .unwrap_or_else(|| panic!("no \"{before}\" in the document"));
    let digits: String = text[at + before.len()..]
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == ' ' || *c == '.')
        .filter(|c| *c != ' ')
        .collect();
    digits
        .trim_end_matches('.')
        .parse()
        .unwrap_or_else(|_| panic!("no number after \"{before}\""))
}

/// The number of `text` just before `after`.
fn number_before(text: &str, after: &str) -> f64 {
    let at = text
        .find(after)
        .unwrap_or_else(|| panic!("no \"{after}\" in the document"));
    let head = text[..at].trim_end();
    let start = head
        .rfind(|c: char| !(c.is_ascii_digit() || c == '.'))
        .map_or(0, |i| i + 1);
    head[start..]
        .parse()
        .unwrap_or_else(|_| panic!("no number before \"{after}\""))
}

/// Each report's "(packet N octets)" heading is its headers, application data and CRC; the link
/// budget's motion report, framed, and the rates are what the framing and a run of
/// `tetra-orbit` through the firmware give.
#[test]
fn packet_lengths_and_the_link_budget_are_the_bytes() {
    use ballisto_link::framing;
    use ballisto_link::identification::{CHANNEL_LEN, SUMMARY_LEN, TRACK_LEN};
    use ballisto_link::tm::{CRC_LEN, HEADERS_LEN};
    let doc = doc();
    let packet = |data: usize| HEADERS_LEN + data + CRC_LEN;
    for (heading, data) in [
        ("### Motion report — TM[3,25], SID 1 (packet", MOTION_LEN),
        (
            "### Housekeeping report — TM[3,25], SID 2 (packet",
            HOUSEKEEPING_LEN,
        ),
        (
            "### Identification summary — TM[200,128] (packet",
            SUMMARY_LEN,
        ),
        ("### Identified channel — TM[200,129] (packet", CHANNEL_LEN),
        ("### Thermal track — TM[200,130] (packet", TRACK_LEN),
    ] {
        assert_eq!(
            number_after(&doc, heading),
            packet(data) as f64,
            "{heading}"
        );
    }
    for (row, data) in [
        ("| identification summary | TM[200,128] |", SUMMARY_LEN),
        ("| identified channel | TM[200,129] |", CHANNEL_LEN),
        ("| thermal track | TM[200,130] |", TRACK_LEN),
    ] {
        assert_eq!(number_after(&doc, row), data as f64, "{row}");
    }
    // A motion packet as the unit sends it, framed.
    let report = MotionReport {
        k: 1,
        estimate: Estimate::default(),
        missing_parts: PartSet(0),
        excluded_parts: PartSet(0),
        excluded_channels: ChannelSet(0),
        context: Some((Mode::Operate, ModelCode::General)),
    };
    let mut buf = [0u8; ballisto_link::ids::TM_MAX];
    let len = ballisto_link::tm::build(&mut buf, 7, 7, 3, 25, 1_000_000_000, |out| {
        report.encode(out)
    })
    .unwrap();
    let mut frame = [0u8; 600];
    let framed = framing::encode(&buf[..len], &mut frame).unwrap();
    let budget = &doc[doc.find("## Link budget").unwrap()..];
    assert_eq!(number_after(budget, "A motion report is"), len as f64);
    assert_eq!(number_after(budget, "octets,"), framed as f64);
    assert_eq!(
        number_before(budget, "kB/s at 100 Hz"),
        (framed * 100) as f64 / 1000.0,
        "kB/s at 100 Hz"
    );
    // The stream of a run.
    let dir = std::env::temp_dir().join(format!("telemetry-doc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sc = hal_sim::scenario::Scenario::load("tetra-orbit").unwrap();
    ballisto::sim::run_sim(&ballisto::sim::SimJob {
        scenario: &sc,
        out: &dir,
        estimate: false,
        progress: false,
        firmware: Some(ballisto_fw::config::Alignment::Interpolate),
        identify: false,
        uplink: Vec::new(),
        calibration: None,
    })
    .unwrap();
    let stream = std::fs::metadata(dir.join("telemetry.bin")).unwrap().len() as f64;
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(
        number_after(budget, "format 6):"),
        stream,
        "octets of the run"
    );
    assert_eq!(
        number_after(budget, "in 20 s with housekeeping and events,"),
        (stream / sc.duration / 100.0).round() / 10.0,
        "kB/s of the run"
    );
    assert_eq!(sc.duration, 20.0);
}
