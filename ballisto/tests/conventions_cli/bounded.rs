//! Memory that does not grow with the input: `decode` streams its input (a recorded stream 50 ×
//! the size of its peak memory), and a text input's line is bounded (a 100 MB "line" is the
//! wrong file, refused by its number without reading it into memory).

use std::io::Write;
use std::path::Path;
use std::process::Command;

use super::common::{ballisto, firmware_record, run_ok, tmpdir};

/// Runs `cmd`; its exit code, its stderr and its peak resident memory (bytes), from wait4(2).
#[expect(
    clippy::zombie_processes,
    reason = "waited for by wait4(2), for its resource usage"
)]
fn peak(cmd: &mut Command) -> (Option<i32>, String, u64) {
    let child = cmd
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.unwrap(), &mut stderr).unwrap();
    let (mut status, mut usage) = (0, unsafe { std::mem::zeroed::<libc::rusage>() });
    // SAFETY: wait4(2) on our own child; `status` and `usage` outlive the call.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(r, pid, "wait4");
    let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
    // ru_maxrss is in kilobytes on Linux.
    (code, stderr, usage.ru_maxrss as u64 * 1024)
}

fn size(p: &Path) -> u64 {
    std::fs::metadata(p).unwrap().len()
}

#[test]
fn decode_holds_a_piece_of_the_stream_not_the_stream() {
    let d = firmware_record("bounded", "decode");
    let boot = std::fs::read(d.join("telemetry.bin")).unwrap();
    // Boots one after another (each its own segment): ≥ 48 MB.
    let times = (48 << 20) / boot.len() + 1;
    let big = d.join("long.bin");
    let mut f = std::fs::File::create(&big).unwrap();
    for _ in 0..times {
        f.write_all(&boot).unwrap();
    }
    drop(f);
    let one = d.join("one.csv");
    run_ok(
        ballisto()
            .arg("decode")
            .arg(d.join("telemetry.bin"))
            .args(["-q", "--out"])
            .arg(&one)
            .arg("--log")
            .arg(d.join("one.txt")),
    );
    let out = d.join("long.csv");
    let (code, stderr, rss) = peak(
        ballisto()
            .arg("decode")
            .arg(&big)
            .arg("--out")
            .arg(&out)
            .arg("--log")
            .arg(d.join("long.txt")),
    );
    assert_eq!(code, Some(0), "{stderr}");
    println!(
        "decode of {} MB: peak memory {:.1} MB",
        size(&big) >> 20,
        rss as f64 / 1e6
    );
    // Every row written: the boot's rows `times` over (and one header).
    let rows = |p: &Path| std::fs::read_to_string(p).unwrap().lines().count() - 1;
    assert_eq!(rows(&out), times * rows(&one));
    assert!(
        rss < size(&big) / 2,
        "decode of {} bytes peaked at {rss} bytes of memory",
        size(&big)
    );
}

#[test]
fn a_line_of_a_hundred_megabytes_is_refused_by_its_number() {
    let d = tmpdir("bounded", "line");
    run_ok(
        ballisto()
            .args(["sim", "--scenario", "tetra-orbit", "-q", "--out"])
            .arg(&d),
    );
    let wrong = d.join("wrong.csv");
    // Written in pieces: the peak of a spawned command counts this process's own peak too.
    let text = std::fs::read_to_string(d.join("samples.csv")).unwrap();
    let mut f = std::io::BufWriter::new(std::fs::File::create(&wrong).unwrap());
    for line in text.lines().take(3) {
        writeln!(f, "{line}").unwrap();
    }
    for _ in 0..100 {
        f.write_all(&[b'7'; 1 << 20]).unwrap();
    }
    for line in text.lines().skip(3) {
        writeln!(f, "{line}").unwrap();
    }
    f.flush().unwrap();
    drop(f);
    let (code, stderr, rss) = peak(
        ballisto()
            .arg("estimate")
            .arg("--arrangement")
            .arg(d.join("arrangement.toml"))
            .arg("--samples")
            .arg(&wrong)
            .arg("--out")
            .arg(d.join("estimates.csv")),
    );
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("line 4: over 1 MiB without a line end"),
        "{stderr}"
    );
    assert!(!d.join("estimates.csv").exists(), "nothing written");
    println!(
        "estimate refusing a 100 MB line: peak memory {:.1} MB",
        rss as f64 / 1e6
    );
    assert!(rss < 50 << 20, "peak memory {rss} bytes");
}
