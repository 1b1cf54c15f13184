//! What may not happen to a file a command writes or reads, one test per way it once did:
//! a special file replaced, `tc` overwriting its input, a failed run destroying the previous
//! output, a mode or a read-only file ignored, stdin overwritten, an interruption leaving
//! temporaries, a closed pipe ending in a panic. Special files are made in temporary
//! directories only.

use crate::common;

use std::ffi::CString;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn c_path(p: &Path) -> CString {
    CString::new(p.as_os_str().as_bytes()).unwrap()
}

/// `ballisto tc ping --out OUT`: a few bytes of frame.
fn ping(out: &Path) -> Command {
    let mut c = common::ballisto();
    c.args(["tc", "ping", "--out"]).arg(out);
    c
}

/// The files of `dir` whose name says they are temporaries.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp"))
        .collect()
}

/// A small record: arrangement.toml and samples.csv of tetra-orbit (20 s, 2 001 rows).
fn record(name: &str) -> PathBuf {
    let d = common::tmpdir("output-safety", name);
    let mut c = common::ballisto();
    c.args(["sim", "-q", "--scenario", "tetra-orbit", "--out"])
        .arg(&d);
    common::run_ok(&mut c);
    d
}

#[test]
fn special_files_are_written_in_place_and_links_through() {
    let d = common::tmpdir("output-safety", "special");
    // A FIFO: read as the frames arrive, and a FIFO still afterwards.
    let fifo = d.join("frames.fifo");
    // SAFETY: a valid path; mkfifo(3) only reads it.
    assert_eq!(unsafe { libc::mkfifo(c_path(&fifo).as_ptr(), 0o600) }, 0);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    common::run_ok(&mut ping(&fifo));
    let got = reader.join().unwrap();
    assert!(!got.is_empty(), "the FIFO's reader got the frame");
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(kind.is_fifo(), "the FIFO was replaced: {kind:?}");
    // A character device (the null device's numbers), made here where root may.
    // SAFETY: geteuid(2) has no preconditions.
    if unsafe { libc::geteuid() } == 0 {
        let null = d.join("null");
        let dev = libc::makedev(1, 3);
        // SAFETY: a valid path; mknod(2) only reads it.
        let made = unsafe { libc::mknod(c_path(&null).as_ptr(), libc::S_IFCHR | 0o666, dev) };
        if made == 0 {
            common::run_ok(&mut ping(&null));
            let kind = std::fs::symlink_metadata(&null).unwrap().file_type();
            assert!(kind.is_char_device(), "the device was replaced: {kind:?}");
        }
    }
    // A symbolic link: the file it points to is written, the link stays a link.
    let real = d.join("real.bin");
    std::fs::write(&real, b"old").unwrap();
    let link = d.join("link.bin");
    std::os::unix::fs::symlink("real.bin", &link).unwrap();
    common::run_ok(&mut ping(&link));
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(
        std::fs::read(&real).unwrap(),
        got,
        "written through the link"
    );
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
}

#[test]
fn tc_refuses_to_overwrite_its_inputs() {
    let d = record("tc");
    let arr = d.join("arrangement.toml");
    let before = std::fs::read(&arr).unwrap();
    let reference = d.join("reference.csv");
    std::fs::write(
        &reference,
        "t,omega_x,omega_y,omega_z\n0,0,0,0.1\n1,0,0,0.1\n",
    )
    .unwrap();
    let runs: [(Vec<&str>, &Path); 3] = [
        (vec!["exclude", "u1.x", "--arrangement"], &arr),
        (vec!["load-arrangement"], &arr),
        (vec!["reference"], &reference),
    ];
    for (args, input) in runs {
        let kept = std::fs::read(input).unwrap();
        let mut c = common::ballisto();
        c.arg("tc").args(&args).arg(input).arg("--out").arg(input);
        let out = c.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(
            stderr.contains("refusing to overwrite an input"),
            "{stderr}"
        );
        assert_eq!(
            std::fs::read(input).unwrap(),
            kept,
            "{args:?}: input changed"
        );
    }
    assert_eq!(std::fs::read(&arr).unwrap(), before);
}

#[test]
fn a_failed_run_leaves_the_previous_output_as_it_was() {
    let d = record("failed");
    let (arr, samples) = (d.join("arrangement.toml"), d.join("samples.csv"));
    let good = d.join("good.csv");
    common::run_ok(&mut common::estimate(&arr, &samples, &good));
    let kept = std::fs::read(&good).unwrap();
    // The same record with a bad field on line 501.
    let mut lines: Vec<String> = std::fs::read_to_string(&samples)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    lines[500] = lines[500].replacen(',', ",zero", 1);
    let bad = d.join("bad.csv");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    let out = common::estimate(&arr, &bad, &good).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("line 501"), "{stderr}");
    assert_eq!(
        std::fs::read(&good).unwrap(),
        kept,
        "the previous output changed"
    );
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
}

#[test]
fn an_output_keeps_its_mode_and_one_the_user_may_not_write_is_refused() {
    let d = common::tmpdir("output-safety", "mode");
    let out = d.join("frames.bin");
    std::fs::write(&out, b"old").unwrap();
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o640)).unwrap();
    common::run_ok(&mut ping(&out));
    let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o7777;
    assert_eq!(mode, 0o640, "mode {mode:o}");
    assert_ne!(std::fs::read(&out).unwrap(), b"old");
    // Read-only for a user who does not own it: refused, as `cp` refuses it. As root, the
    // command runs as `nobody` (from a copy of the binary it may run, in a directory it may
    // write); otherwise as the user, on a file of mode 0444.
    let locked = d.join("locked.bin");
    std::fs::write(&locked, b"keep").unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o444)).unwrap();
    std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o777)).unwrap();
    let mut c = ping(&locked);
    // SAFETY: geteuid(2) has no preconditions.
    if unsafe { libc::geteuid() } == 0 {
        let bin = d.join("ballisto");
        std::fs::copy(env!("CARGO_BIN_EXE_ballisto"), &bin).unwrap();
        std::fs::set_permissions(&bin, std::fs::Permissions::from_mode(0o755)).unwrap();
        c = Command::new(&bin);
        c.args(["tc", "ping", "--out"])
            .arg(&locked)
            .uid(65534)
            .gid(65534);
    }
    let run = c.output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("not writable"), "{stderr}");
    assert_eq!(std::fs::read(&locked).unwrap(), b"keep");
    let mode = std::fs::metadata(&locked).unwrap().permissions().mode() & 0o7777;
    assert_eq!(mode, 0o444);
}

#[test]
fn stdin_that_is_the_output_is_refused() {
    let d = record("stdin");
    let (arr, samples) = (d.join("arrangement.toml"), d.join("samples.csv"));
    let kept = std::fs::read(&samples).unwrap();
    let out = common::estimate(&arr, Path::new("-"), &samples)
        .stdin(std::fs::File::open(&samples).unwrap())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("read on stdin: refusing to overwrite an input"),
        "{stderr}"
    );
    assert_eq!(std::fs::read(&samples).unwrap(), kept);
    // The same for `decode -`.
    let tm = d.join("telemetry.bin");
    std::fs::write(&tm, [0u8, 1, 2, 3]).unwrap();
    let mut c = common::ballisto();
    c.args(["decode", "-", "--out"]).arg(&tm);
    let out = c.stdin(std::fs::File::open(&tm).unwrap()).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(std::fs::read(&tm).unwrap(), [0u8, 1, 2, 3]);
}

#[test]
fn an_interrupted_run_leaves_no_temporary_file() {
    let d = common::tmpdir("output-safety", "interrupted");
    // A three-hour orbit: its outputs are long in the writing.
    let mut c = common::ballisto();
    c.args(["sim", "-q", "--scenario", "tetra-orbit-thermal", "--out"])
        .arg(&d)
        .stderr(Stdio::piped());
    interrupt_once(&mut c, || !temporaries(&d).is_empty());
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
}

/// Starts `c`, sends it SIGINT once `begun` (within 2 minutes, before it ends), and checks
/// that it ended as SIGINT ends a process.
fn interrupt_once(c: &mut Command, begun: impl Fn() -> bool) {
    let mut child = c.spawn().unwrap();
    let started = std::time::Instant::now();
    while !begun() {
        assert!(
            started.elapsed().as_secs() < 120,
            "no output begun in 2 minutes"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "ended before the signal"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // SAFETY: kill(2) on our own child.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let status = child.wait().unwrap();
    assert_eq!(status.signal(), Some(libc::SIGINT), "{status:?}");
}

#[test]
fn a_reader_that_goes_away_ends_the_command_quietly() {
    let d = common::firmware_record("output-safety", "pipe");
    let mut c = common::ballisto();
    c.arg("decode")
        .arg(d.join("telemetry.bin"))
        .args(["--out", "-", "--log"])
        .arg(d.join("log.txt"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = c.spawn().unwrap();
    // `| head -1`: one line read, then the pipe closed.
    let mut stdout = child.stdout.take().unwrap();
    let mut first = [0u8; 64];
    std::io::Read::read_exact(&mut stdout, &mut first).unwrap();
    drop(stdout);
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(first.starts_with(b"t,"), "the estimates' header first");
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
}

/// `--plot-only` interrupted: its scratch directory of records goes with it.
#[test]
fn an_interrupted_plot_only_run_leaves_no_scratch() {
    let d = common::tmpdir("output-safety", "scratch");
    let mut c = common::ballisto();
    c.args([
        "sim",
        "-q",
        "--scenario",
        "tetra-orbit-thermal",
        "--estimate",
        "--plot-only",
        "--out",
    ])
    .arg(&d)
    .stderr(Stdio::piped());
    let scratch = |d: &Path| -> Vec<String> {
        std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(".ballisto-scratch"))
            .collect()
    };
    // Once the records are being written in it.
    interrupt_once(&mut c, || {
        scratch(&d)
            .first()
            .is_some_and(|s| !temporaries(&d.join(s)).is_empty())
    });
    assert!(scratch(&d).is_empty(), "{:?}", scratch(&d));
}
