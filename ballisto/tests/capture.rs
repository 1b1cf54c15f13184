//! `ballisto capture` on a pseudo-terminal, the code path a serial port takes: the unit's
//! stream (the firmware's telemetry under the simulator) written into the terminal's master
//! side in pieces, with a reset of the unit between two boots, while the capture follows the
//! slave side and sends a telecommand on it. Nothing is lost or doubled: the live estimates
//! are the file decode's of the same bytes, row for row.

mod common;

use std::io::{Read, Write};
use std::os::fd::FromRawFd;
use std::process::Stdio;
use std::time::{Duration, Instant};

/// A pseudo-terminal pair in raw mode: the master side, and the slave's path.
fn pty() -> (std::fs::File, std::path::PathBuf, std::fs::File) {
    let (mut master, mut slave) = (0, 0);
    // SAFETY: openpty(3) writes two descriptors; the name, termios and size are optional.
    let r = unsafe {
        libc::openpty(
            &mut master,
            &mut slave,
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert_eq!(r, 0, "openpty");
    // Not inherited by the capture: the master's close must reach it as a hang-up.
    for fd in [master, slave] {
        // SAFETY: fcntl(2) on an open descriptor.
        assert_eq!(
            unsafe { libc::fcntl(fd, libc::F_SETFD, libc::FD_CLOEXEC) },
            0
        );
    }
    // SAFETY: `slave` is open; termios is plain data filled by tcgetattr.
    unsafe {
        let mut t: libc::termios = std::mem::zeroed();
        assert_eq!(libc::tcgetattr(slave, &mut t), 0);
        libc::cfmakeraw(&mut t);
        assert_eq!(libc::tcsetattr(slave, libc::TCSANOW, &t), 0);
    }
    // SAFETY: ttyname(3) returns a NUL-terminated string for an open terminal.
    let name = unsafe { std::ffi::CStr::from_ptr(libc::ttyname(slave)) }
        .to_string_lossy()
        .into_owned();
    // SAFETY: both descriptors are open and owned by nothing else.
    let (master, slave) = unsafe {
        (
            std::fs::File::from_raw_fd(master),
            std::fs::File::from_raw_fd(slave),
        )
    };
    (master, name.into(), slave)
}

#[test]
fn a_live_capture_across_a_reset_is_the_file_decode_row_for_row() {
    let d = common::firmware_record("capture", "pty");
    let boot = std::fs::read(d.join("telemetry.bin")).unwrap();
    let tc = d.join("ping.bin");
    common::run_ok(common::ballisto().args(["tc", "ping", "--out"]).arg(&tc));
    let ping = std::fs::read(&tc).unwrap();

    let (mut master, slave_path, _slave) = pty();
    let (out, log, raw) = (d.join("live.csv"), d.join("live.txt"), d.join("live.bin"));
    let mut capture = common::ballisto();
    capture
        .args(["capture", "--baud", "115200", "--idle", "5", "--port"])
        .arg(&slave_path)
        .arg("--out")
        .arg(&out)
        .arg("--log")
        .arg(&log)
        .arg("--raw")
        .arg(&raw)
        .arg("--send")
        .arg(&tc)
        .stderr(Stdio::piped());
    let child = capture.spawn().unwrap();
    // The telecommand arrives on the unit's side first.
    let mut got = vec![0u8; ping.len()];
    master.read_exact(&mut got).unwrap();
    assert_eq!(got, ping, "the frames sent");
    // Boot 1, a pause (the reset), boot 2 — in pieces, as a UART delivers them.
    let started = Instant::now();
    for stream in [&boot, &boot] {
        for piece in stream.chunks(997) {
            master.write_all(piece).unwrap();
        }
        std::thread::sleep(Duration::from_millis(300));
    }
    let done = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert_eq!(done.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("2 boots, 0 problems"),
        "{stderr} ({:?})",
        started.elapsed()
    );
    // Every byte kept, and the live rows are the file decode's of those bytes.
    let both = [boot.clone(), boot].concat();
    assert_eq!(std::fs::read(&raw).unwrap(), both, "the raw bytes");
    let whole = d.join("whole.bin");
    std::fs::write(&whole, &both).unwrap();
    let decoded = d.join("decoded.csv");
    common::run_ok(
        common::ballisto()
            .arg("decode")
            .arg(&whole)
            .arg("--out")
            .arg(&decoded)
            .arg("--log")
            .arg(d.join("decoded.txt")),
    );
    let (live, file) = (
        std::fs::read_to_string(&out).unwrap(),
        std::fs::read_to_string(&decoded).unwrap(),
    );
    assert_eq!(
        live.lines().count(),
        1 + 2 * 2001,
        "header and both boots' rows"
    );
    assert!(live == file, "the live rows differ from the file decode's");
    // The flagged rows counted live are the rows with a flag.
    let (header, rows) = common::read_table(&out);
    let flags = header.iter().position(|h| h == "flags").unwrap();
    let flagged = rows.iter().filter(|r| r[flags] != "0").count();
    assert!(
        stderr.contains(&format!("({flagged} flagged)")),
        "{stderr}: {flagged} rows flagged"
    );
    let live_log = std::fs::read_to_string(&log).unwrap();
    let file_log = std::fs::read_to_string(d.join("decoded.txt")).unwrap();
    assert_eq!(live_log, file_log, "the log");
}

#[test]
fn a_capture_never_replaces_a_previous_record() {
    let d = common::tmpdir("capture", "exists");
    let port = d.join("growing.bin");
    std::fs::write(&port, [0u8]).unwrap();
    let out = d.join("estimates.csv");
    std::fs::write(&out, "previous").unwrap();
    let run = common::ballisto()
        .args(["capture", "--idle", "0", "--port"])
        .arg(&port)
        .arg("--out")
        .arg(&out)
        .arg("--log")
        .arg(d.join("log.txt"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("never replaces a previous record"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "previous");
}

/// The port goes away (the terminal's other side closed: a cable pulled, the unit off): what
/// was received stays in the files, the loss is in the log, and the capture ends once the
/// port is not back within --idle.
#[test]
fn a_port_that_goes_away_keeps_what_was_received() {
    let d = common::firmware_record("capture", "lost");
    let boot = std::fs::read(d.join("telemetry.bin")).unwrap();
    let (mut master, slave_path, slave) = pty();
    drop(slave);
    let (out, log) = (d.join("live.csv"), d.join("live.txt"));
    let mut capture = common::ballisto();
    capture
        .args(["capture", "-q", "--baud", "115200", "--idle", "3", "--port"])
        .arg(&slave_path)
        .arg("--out")
        .arg(&out)
        .arg("--log")
        .arg(&log)
        .stderr(Stdio::piped());
    let child = capture.spawn().unwrap();
    let started = Instant::now();
    while !out.exists() {
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "the capture never opened"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    // Half the stream, ending on a frame's delimiter, then the port gone.
    let zeros: Vec<usize> = (0..boot.len()).filter(|i| boot[*i] == 0).collect();
    let cut = zeros[(zeros.len() / 2) | 1] + 1;
    master.write_all(&boot[..cut]).unwrap();
    std::thread::sleep(Duration::from_millis(500));
    drop(master);
    let done = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert_eq!(done.status.code(), Some(0), "{stderr}");
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.contains("PROBLEM the port was lost"), "{text}");
    assert!(text.contains("not back within 3 s"), "{text}");
    let rows = std::fs::read_to_string(&out).unwrap().lines().count() - 1;
    assert!(rows > 900, "{rows} rows of the half received");
}

/// The QEMU board's built-in scenario followed live over its UART0 on a pseudo-terminal
/// (`scripts/qemu-live.sh`, which the test command runs and names here with
/// `BOARD_QEMU_LIVE`): three boots and two resets of the board (its own, then the
/// watchdog's). The capture received every byte of the boots' files, in order, and its rows
/// and log are the file decode's of those files; each boot is its own segment.
#[test]
#[ignore = "needs the QEMU board's live run: scripts/qemu-live.sh, then BOARD_QEMU_LIVE=DIR"]
fn the_qemu_board_followed_live_over_its_uart_is_its_files_row_for_row() {
    let live = std::path::PathBuf::from(std::env::var("BOARD_QEMU_LIVE").expect("BOARD_QEMU_LIVE"));
    let files = [
        "telemetry-boot1.bin",
        "telemetry.bin",
        "telemetry-boot3.bin",
    ];
    let mut recorded = Vec::new();
    for f in files {
        let bytes = std::fs::read(live.join(f)).unwrap();
        assert!(!bytes.is_empty(), "{f} is empty");
        recorded.extend(bytes);
    }
    let received = std::fs::read(live.join("capture.bin")).unwrap();
    assert_eq!(
        received.len(),
        recorded.len(),
        "octets received over the UART against the boots' files"
    );
    assert!(
        received == recorded,
        "the octets received differ from the files'"
    );

    let d = common::tmpdir("capture", "qemu-live");
    let whole = d.join("whole.bin");
    std::fs::write(&whole, &recorded).unwrap();
    let (decoded, decoded_log) = (d.join("decoded.csv"), d.join("decoded.txt"));
    common::run_ok(
        common::ballisto()
            .arg("decode")
            .arg(&whole)
            .arg("--out")
            .arg(&decoded)
            .arg("--log")
            .arg(&decoded_log),
    );
    let captured = std::fs::read_to_string(live.join("estimates.csv")).unwrap();
    let file = std::fs::read_to_string(&decoded).unwrap();
    let rows = captured.lines().count() - 1;
    assert!(rows > 4000, "{rows} rows: the three boots run 4100 sets");
    assert!(
        captured == file,
        "the live rows differ from the file decode's"
    );
    // One segment per boot: the `boot` column (the last) counts 1, 2, 3.
    let boots: std::collections::BTreeSet<&str> = captured
        .lines()
        .skip(1)
        .filter_map(|l| l.rsplit(',').next())
        .collect();
    assert_eq!(boots.into_iter().collect::<Vec<_>>(), ["1", "2", "3"]);
    // The log: the file decode's, then the end of the board (QEMU gone, the port with it).
    let captured_log = std::fs::read_to_string(live.join("log.txt")).unwrap();
    let (head, tail) = captured_log
        .split_once("PROBLEM the port was lost")
        .expect("the capture saw the port go when QEMU ended");
    assert_eq!(
        head,
        std::fs::read_to_string(&decoded_log).unwrap(),
        "the log"
    );
    assert!(tail.contains("not back within 5 s"), "{tail}");
    assert!(!head.contains("PROBLEM"), "{head}");
}
