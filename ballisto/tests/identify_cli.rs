//! `ballisto sim --firmware --identify` and `ballisto decode --calibration`: identification in
//! flight from the command line, and the ground's arrangement file of the solution.

mod common;

use std::process::Command;

use ballisto_config::arrangement_file::load_arrangement;

fn ballisto(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_ballisto"))
        .args(args)
        .output()
        .unwrap()
}

/// `ballisto sim [--firmware] --identify --scenario SCENARIO --out D`.
fn sim_identify(firmware: bool, scenario: &str, d: &std::path::Path) -> std::process::Output {
    let mut args = vec!["sim"];
    if firmware {
        args.push("--firmware");
    }
    args.extend([
        "--identify",
        "--scenario",
        scenario,
        "--out",
        d.to_str().unwrap(),
    ]);
    ballisto(&args)
}

/// `ballisto decode STREAM --calibration CAL --arrangement arrangement.toml` in `d`, the
/// estimates and log beside.
fn decode_with_calibration(
    d: &std::path::Path,
    stream: &str,
    cal: &std::path::Path,
) -> std::process::Output {
    let path = |f: &str| d.join(f).to_str().unwrap().to_string();
    ballisto(&[
        "decode",
        &path(stream),
        "--out",
        &path(&format!("{stream}.csv")),
        "--log",
        &path(&format!("{stream}.txt")),
        "--calibration",
        cal.to_str().unwrap(),
        "--arrangement",
        &path("arrangement.toml"),
    ])
}

/// ρ and its deviation from the calibrated file's header (`# rho = [x, y, z] m, sd [..] m: ..`).
fn header_rho(text: &str) -> ([f64; 3], [f64; 3]) {
    let line = text
        .lines()
        .find(|l| l.starts_with("# rho = ["))
        .expect("a rho line in the header");
    let vectors: Vec<[f64; 3]> = line
        .split('[')
        .skip(1)
        .take(2)
        .map(|v| {
            let parts: Vec<f64> = v[..v.find(']').unwrap()]
                .split(',')
                .map(|x| x.trim().parse().unwrap())
                .collect();
            [parts[0], parts[1], parts[2]]
        })
        .collect();
    (vectors[0], vectors[1])
}

#[test]
fn identify_in_flight_then_decode_the_solution_as_an_arrangement_file() {
    let d = common::tmpdir("identify", "orbit");
    let r = sim_identify(true, "orbit-identify", &d);
    let stdout = common::summary(&r);
    assert!(
        stdout.contains("IDENTIFICATION solution=1 channels=12"),
        "{stdout}"
    );
    assert!(stdout.contains("calibration-stored"), "{stdout}");
    assert!(
        stdout.contains("second boot: calibration Flash id=1"),
        "{stdout}"
    );
    assert!(d.join("telemetry-identify.bin").exists());

    let cal = d.join("identified.toml");
    let r = decode_with_calibration(&d, "telemetry-identify.bin", &cal);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let text = std::fs::read_to_string(&cal).unwrap();
    assert!(text.starts_with("# Identified in flight (paper §6): solution 1"));
    let loaded = load_arrangement(&cal).unwrap();
    let nominal = load_arrangement(&d.join("arrangement.toml")).unwrap();
    assert_eq!(loaded.names, nominal.names);
    // Every bias identified (0.2 m/s² datasheet offsets), every scale held.
    assert_eq!(text.matches("bias_sd").count(), 12);
    assert_eq!(text.matches("scale_sd").count(), 0);
    let truth = load_arrangement(&d.join("truth_geometry.toml")).unwrap();
    for (c, t) in loaded
        .arrangement
        .channels()
        .iter()
        .zip(truth.arrangement.channels())
    {
        assert!((c.bias - t.bias).abs() < 2e-3, "{} vs {}", c.bias, t.bias);
    }

    // One ρ (paper eq. 12: the origin from the centre of mass) in the identification's
    // report, in `ballisto com` on the identified geometry, and in the scenario: its
    // origin_offset. The identification's deviation holds the frame's translation (the parts'
    // mean mounting error); `com` on the identified geometry shares that frame, so the two
    // agree to `com`'s own deviation.
    let origin_offset = [0.02, -0.01, 0.03]; // orbit-identify.toml
    let (rho, rho_sd) = header_rho(&text);
    for k in 0..3 {
        assert!(
            (rho[k] - origin_offset[k]).abs() < 4.0 * rho_sd[k],
            "identified rho_{k} {} ± {} vs origin_offset {}",
            rho[k],
            rho_sd[k],
            origin_offset[k]
        );
    }
    let com = d.join("com.csv");
    let r = ballisto(&[
        "com",
        "--arrangement",
        cal.to_str().unwrap(),
        "--samples",
        d.join("samples.csv").to_str().unwrap(),
        "--out",
        com.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let (_, rows) = common::read_table(&com);
    assert_eq!(rows.len(), 11, "60 s in windows of 10 s every 5 s");
    for row in &rows {
        for k in 0..3 {
            let (c, sd): (f64, f64) = (row[1 + k].parse().unwrap(), row[7 + k].parse().unwrap());
            assert!(
                (c - rho[k]).abs() < 4.0 * sd,
                "com rho_{k} {c} ± {sd} at t {} vs identified {}",
                row[0],
                rho[k]
            );
        }
    }

    // A stream without a solution: said so, nothing written.
    let none = d.join("none.toml");
    let r = decode_with_calibration(&d, "telemetry.bin", &none);
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("no identification solution"), "{err}");
    assert!(!none.exists());
}

#[test]
fn identifying_needs_a_reference_sensor_or_a_torque_free_tumble() {
    let d = common::tmpdir("identify", "no-reference");
    // orbit-identify without its reference gyro: the attitude-control torque leaves no
    // source of the field.
    let text: String = common::scenario_text("orbit-identify").replace(
        "[reference]\nnoise_density = 1e-4\nbias = [0.0, 0.0, 0.0]\nrate = 20.0\n",
        "",
    );
    assert!(!text.contains("[reference]"));
    let file = d.join("no-reference.toml");
    std::fs::write(&file, text).unwrap();
    let r = sim_identify(true, file.to_str().unwrap(), &d);
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("not a torque-free tumble")
            && err.contains("no [reference] sensor to identify with"),
        "{err}"
    );
    // tetra-orbit, a torque-free tumble without a reference: identified from its motion.
    let r = sim_identify(true, "tetra-orbit", &d);
    let stdout = common::summary(&r);
    assert!(
        stdout.contains("IDENTIFICATION solution=1 channels=12")
            && stdout.contains("reference_points=0"),
        "{stdout}"
    );
    // --identify without --firmware is a usage error.
    let r = sim_identify(false, "tetra-orbit", &d);
    assert!(!r.status.success());
}

/// RMS errors of σ0, Ω′, Ω of `estimates` against `truth` (the simulator's files), over the
/// rows after 2 s; σ0 compared at the point `origin` of the true geometry (`σ0 + (A + {Ω′})
/// origin`, paper eq. 4: the origin an identified geometry calls its own).
fn rms_errors(truth: &std::path::Path, estimates: &std::path::Path, origin: [f64; 3]) -> [f64; 3] {
    let (th, tr) = common::read_table(truth);
    let (eh, er) = common::read_table(estimates);
    let col = |h: &[String], n: &str| h.iter().position(|c| c == n).unwrap();
    let get = |h: &[String], r: &[String], n: &str| -> f64 { r[col(h, n)].parse().unwrap() };
    let mut sum = [0.0; 3];
    let mut n = 0usize;
    for (t, e) in tr.iter().zip(&er) {
        if get(&th, t, "t") < 2.0 {
            continue;
        }
        assert!((get(&th, t, "t") - get(&eh, e, "t")).abs() < 1e-9);
        let a = |n: &str| get(&th, t, n);
        let (xx, yy, zz, xy, xz, yz) = (
            a("A_xx"),
            a("A_yy"),
            a("A_zz"),
            a("A_xy"),
            a("A_xz"),
            a("A_yz"),
        );
        let dw = [a("domega_x"), a("domega_y"), a("domega_z")];
        let o = origin;
        let at = [
            xx * o[0] + xy * o[1] + xz * o[2] + dw[1] * o[2] - dw[2] * o[1],
            xy * o[0] + yy * o[1] + yz * o[2] + dw[2] * o[0] - dw[0] * o[2],
            xz * o[0] + yz * o[1] + zz * o[2] + dw[0] * o[1] - dw[1] * o[0],
        ];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            let s = |what: &str| format!("{what}_{axis}");
            sum[0] += (get(&eh, e, &s("sigma0")) - a(&s("sigma0")) - at[k]).powi(2);
            sum[1] += (get(&eh, e, &s("domega")) - a(&s("domega"))).powi(2);
            sum[2] += (get(&eh, e, &s("omega")) - a(&s("omega"))).powi(2);
        }
        n += 3;
    }
    assert!(n > 300);
    sum.map(|s| (s / n as f64).sqrt())
}

/// `ballisto calibrate --inertia`: without a reference, from a torque-free tumble (the
/// `orbit-identify` parts with their datasheet errors, the torque removed), the start rate and
/// the geometry are found; `ballisto estimate` on the calibrated file is then within 1.5 × the
/// ideal parts' errors (σ0 at the identified origin, Ω′, Ω). A tumble that stays near a spin
/// about one principal axis is refused (exit 4, nothing written), naming the channel and the
/// parameter the motion does not determine.
#[test]
fn a_torque_free_tumble_is_calibrated_without_a_reference() {
    let d = common::tmpdir("identify", "tumble");
    let text: String = common::scenario_text("orbit-identify")
        .lines()
        .filter(|l| !l.starts_with("torque"))
        .map(|l| format!("{l}\n"))
        .collect();
    let errors = [
        "bias ",
        "scale ",
        "cross ",
        "position_error ",
        "orientation_error ",
    ];
    let ideal: String = text
        .lines()
        .filter(|l| !errors.iter().any(|e| l.starts_with(e)))
        .map(|l| format!("{l}\n"))
        .collect();
    let spin = text.replace("omega0 = [0.3, 1.7, -0.6]", "omega0 = [0.0, 0.02, 1.5]");
    assert_ne!(spin, text);
    let mut runs = Vec::new();
    for (name, scenario) in [("tumble", &text), ("ideal", &ideal), ("spin", &spin)] {
        let file = d.join(format!("{name}.toml"));
        std::fs::write(&file, scenario).unwrap();
        let out = d.join(name);
        let r = ballisto(&[
            "sim",
            "--scenario",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "-q",
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        runs.push(out);
    }
    let path = |dir: &std::path::Path, f: &str| dir.join(f).to_str().unwrap().to_string();
    let calibrate = |dir: &std::path::Path| {
        ballisto(&[
            "calibrate",
            "--arrangement",
            &path(dir, "arrangement.toml"),
            "--samples",
            &path(dir, "samples.csv"),
            "--out",
            &path(dir, "calibrated.toml"),
            "--inertia",
            "1.0,1.8,2.5",
        ])
    };
    let estimate = |dir: &std::path::Path, arrangement: &str, out: &str| {
        let r = ballisto(&[
            "estimate",
            "--arrangement",
            &path(dir, arrangement),
            "--samples",
            &path(dir, "samples.csv"),
            "--out",
            &path(dir, out),
            "-q",
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    let (tumble, ideal, spin) = (&runs[0], &runs[1], &runs[2]);
    let r = calibrate(tumble);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let text = std::fs::read_to_string(tumble.join("calibrated.toml")).unwrap();
    assert!(text.starts_with("# Identified without a reference"));
    // The header's ρ line (no deviation here): the vector alone.
    let line = text.lines().find(|l| l.starts_with("# rho = [")).unwrap();
    let rho: Vec<f64> = line[9..line.find(']').unwrap()]
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect();
    let drawn = [0.02, -0.01, 0.03]; // origin_offset of orbit-identify.toml
    let origin: [f64; 3] = core::array::from_fn(|k| rho[k] - drawn[k]);
    estimate(tumble, "calibrated.toml", "calibrated.csv");
    estimate(tumble, "arrangement.toml", "nominal.csv");
    estimate(ideal, "arrangement.toml", "ideal.csv");
    let after = rms_errors(
        &tumble.join("truth.csv"),
        &tumble.join("calibrated.csv"),
        origin,
    );
    let before = rms_errors(
        &tumble.join("truth.csv"),
        &tumble.join("nominal.csv"),
        [0.0; 3],
    );
    let reference = rms_errors(&ideal.join("truth.csv"), &ideal.join("ideal.csv"), [0.0; 3]);
    for (k, name) in ["σ0", "Ω′", "Ω"].iter().enumerate() {
        println!(
            "without a reference, {name}: nominal geometry {:.3e}, identified {:.3e}, ideal parts {:.3e} ({:.2}×)",
            before[k],
            after[k],
            reference[k],
            after[k] / reference[k]
        );
        assert!(
            after[k] <= 1.5 * reference[k],
            "{name}: {after:?} vs {reference:?}"
        );
    }
    // Near a spin about z: refused by name, nothing written.
    let r = calibrate(spin);
    assert_eq!(r.status.code(), Some(4));
    let err = String::from_utf8_lossy(&r.stderr);
    println!("spin: {err}");
    // The channel and parameter named: the one the start rate's uncertainty moves, or the
    // first held where most of the geometry is.
    assert!(err.contains("does not determine"), "{err}");
    assert!(
        err.contains("'s tilt") || err.contains("'s position"),
        "{err}"
    );
    assert!(!spin.join("calibrated.toml").exists());
}
