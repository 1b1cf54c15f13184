//! Temperature compensation on the ground (issue 50, `interfaces.md` "Temperature"): a samples
//! file with `temp_<channel>` columns and an arrangement with `t_ref`, `bias_tc`, `scale_tc`.
//! The record: `tetra-orbit` (four ADXL355 with their datasheet noise and clocks, no other
//! part error), its readings warmed as datasheet-typical coefficients say over a swing of
//! ±20 °C — in 30 s, not an orbit's 92 min, so that holding a temperature between reads costs
//! far more than it would in orbit — with each part's own lag and its temperature read every
//! tenth set; `ballisto estimate` with the coefficients must give the estimate of the unwarmed
//! record, and the record without them is worse (reported).

use std::path::{Path, PathBuf};

use ballisto::compare::compare;
use ballisto::estimate::{estimate_files, EstimateJob, Precision, Summary};
use ballisto::sim::{run_sim, SimJob};
use hal_sim::arrangement_file::ArrangementFile;
use hal_sim::scenario::Scenario;
use rand::{Rng, SeedableRng};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "ballisto-temperature-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn estimate(arrangement: &Path, samples: &Path, out: &Path) -> Result<Summary, String> {
    estimate_files(&EstimateJob {
        arrangement,
        samples,
        out,
        model: None,
        options: Default::default(),
        precision: Precision::F64,
    })
    .map_err(|e| e.to_string())
}

/// The part's temperature at `t`: 20 ± 20 °C over a 30 s "orbit", `lag` s behind.
fn temperature(t: f64, lag: f64) -> f64 {
    20.0 + 20.0 * (std::f64::consts::TAU * (t - lag) / 30.0).sin()
}

/// `tetra-orbit` simulated into `d` (30 s), and its arrangement with drawn datasheet-typical
/// coefficients (bias ±0.15 mg/°C, scale ±0.01 %/°C, `t_ref` 25 °C), written as
/// `warm.toml`; `warm.csv` the readings as the warming parts would give them
/// (`scale·(1 + scale_tc·ΔT)·(s·f) + bias + bias_tc·ΔT`), each part's temperature every tenth
/// set (empty between), `seed` drawing the coefficients and the lags.
fn warmed_record(d: &Path, seed: u64) {
    let mut sc = Scenario::load("tetra-orbit").unwrap();
    sc.duration = 30.0;
    run_sim(&SimJob {
        scenario: &sc,
        out: d,
        estimate: false,
        progress: false,
        firmware: None,
        identify: false,
        uplink: Vec::new(),
        calibration: None,
    })
    .unwrap();
    let mut file = ArrangementFile::read(&d.join("arrangement.toml")).unwrap();
    let names: Vec<String> = file
        .expanded_channels("arrangement.toml")
        .unwrap()
        .iter()
        .map(|c| c.name.clone())
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    // Channels of one part share its temperature (and its lag).
    let part = |n: &str| n.split('.').next().unwrap_or(n).to_string();
    let mut lags = std::collections::HashMap::new();
    let mut coefficients = Vec::new();
    for n in &names {
        let lag = *lags
            .entry(part(n))
            .or_insert_with(|| rng.gen_range(0.0..3.0));
        let bias_tc: f64 = rng.gen_range(-1.5e-3..1.5e-3);
        let scale_tc: f64 = rng.gen_range(-1e-4..1e-4);
        coefficients.push((lag, bias_tc, scale_tc));
    }
    // The file's channels with their coefficients (sensors expanded to channels).
    let mut channels = file.expanded_channels("arrangement.toml").unwrap();
    for (c, (_, b, k)) in channels.iter_mut().zip(&coefficients) {
        c.t_ref = Some(25.0);
        c.bias_tc = Some(*b);
        c.scale_tc = Some(*k);
    }
    file.sensors.clear();
    file.channels = channels.clone();
    std::fs::write(d.join("warm.toml"), file.to_toml()).unwrap();
    let text = std::fs::read_to_string(d.join("samples.csv")).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).unwrap())
        .collect();
    let mut out = header.join(",");
    for n in &names {
        out.push_str(&format!(",temp_{n}"));
    }
    out.push('\n');
    for (k, line) in lines.enumerate() {
        let mut f: Vec<String> = line.split(',').map(str::to_string).collect();
        let t: f64 = f[0].parse().unwrap();
        let mut temps = Vec::new();
        for (c, (lag, b, s)) in coefficients.iter().enumerate() {
            let temp = temperature(t, *lag);
            let dt = temp - 25.0;
            let bias = channels[c].bias.unwrap_or(0.0);
            if let Ok(p) = f[column[c]].parse::<f64>() {
                f[column[c]] = format!("{}", p + b * dt + s * dt * (p - bias));
            }
            temps.push(if k % 10 == 0 {
                format!("{temp:.3}")
            } else {
                String::new()
            });
        }
        out.push_str(&f.join(","));
        out.push(',');
        out.push_str(&temps.join(","));
        out.push('\n');
    }
    std::fs::write(d.join("warm.csv"), out).unwrap();
}

/// Compensated, the warmed record gives the unwarmed record's errors (the temperature held
/// between reads: within 2 % in σ0, Ω′ and Ω); uncompensated it does not (reported); the
/// coefficients without the temperature columns are warned about, not applied silently.
#[test]
fn a_warming_record_is_compensated_to_the_unwarmed_ones_errors() {
    let d = dir("compensated");
    warmed_record(&d, 5001);
    let truth = d.join("truth.csv");
    estimate(
        &d.join("arrangement.toml"),
        &d.join("samples.csv"),
        &d.join("cold.csv"),
    )
    .unwrap();
    let cold = compare(&truth, &d.join("cold.csv")).unwrap();
    let summary = estimate(
        &d.join("warm.toml"),
        &d.join("warm.csv"),
        &d.join("compensated.csv"),
    )
    .unwrap();
    let compensated = compare(&truth, &d.join("compensated.csv")).unwrap();
    estimate(
        &d.join("arrangement.toml"),
        &d.join("warm.csv"),
        &d.join("warm-plain.csv"),
    )
    .unwrap();
    let plain = compare(&truth, &d.join("warm-plain.csv")).unwrap();
    let pairs = [
        ("σ0", cold.sigma0, compensated.sigma0, plain.sigma0),
        ("Ω′", cold.domega, compensated.domega, plain.domega),
        ("Ω", cold.omega, compensated.omega, plain.omega),
    ];
    for (name, c, w, p) in pairs {
        println!(
            "{name} RMS: unwarmed {c:.3e}, warmed and compensated {w:.3e} ({:.3} ×), warmed \
             uncompensated {p:.3e} ({:.2} ×)",
            w / c,
            p / c
        );
        assert!(w <= 1.02 * c && w >= 0.98 * c, "{name}: {w:.3e} vs {c:.3e}");
    }
    assert!(
        plain.sigma0 > 1.5 * cold.sigma0,
        "uncompensated σ0 {:.3e} vs {:.3e}",
        plain.sigma0,
        cold.sigma0
    );
    // Nothing left uncompensated but the rows before a part's first temperature (none: the
    // first row has them all).
    assert!(
        !summary
            .warnings
            .iter()
            .any(|w| w.contains("not compensated")),
        "{:?}",
        summary.warnings
    );
    // The coefficients without the columns: estimated uncorrected, and said.
    let stripped = d.join("no-temps.csv");
    let text = std::fs::read_to_string(d.join("warm.csv")).unwrap();
    let keep = text
        .lines()
        .next()
        .unwrap()
        .split(',')
        .take_while(|h| !h.starts_with("temp_"))
        .count();
    let body: String = text
        .lines()
        .map(|l| l.split(',').take(keep).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    std::fs::write(&stripped, body).unwrap();
    let summary = estimate(&d.join("warm.toml"), &stripped, &d.join("x.csv")).unwrap();
    let warned = summary
        .warnings
        .iter()
        .filter(|w| w.contains("no temp_") && w.contains("not compensated"))
        .count();
    assert_eq!(warned, summary_channels(&d), "{:?}", summary.warnings);
}

fn summary_channels(d: &Path) -> usize {
    ArrangementFile::read(&d.join("warm.toml"))
        .unwrap()
        .channels
        .len()
}

/// Bad temperature input is refused by name: a temperature column for no channel, a reading
/// no part gives, coefficients without `t_ref`.
#[test]
fn bad_temperature_input_is_refused_by_name() {
    let d = dir("refused");
    let arrangement = d.join("a.toml");
    // Twelve channels: four tri-axial parts at a tetrahedron's corners.
    let corners = [
        [0.1, 0.1, 0.1],
        [0.1, -0.1, -0.1],
        [-0.1, 0.1, -0.1],
        [-0.1, -0.1, 0.1],
    ];
    let channel = |extra: &str, name: &str, c: usize| {
        let (r, mut axis) = (corners[c / 3], [0.0; 3]);
        axis[c % 3] = 1.0;
        format!("[[channel]]\nname = \"{name}\"\nposition = {r:?}\naxis = {axis:?}\n{extra}\n")
    };
    let mut toml = String::new();
    for c in 0..12 {
        toml.push_str(&channel("", &format!("c{c}"), c));
    }
    std::fs::write(&arrangement, &toml).unwrap();
    let names: Vec<String> = (0..12).map(|i| format!("c{i}")).collect();
    let samples = |extra_header: &str, extra: &str| {
        let p = d.join("s.csv");
        let row = ["0.1"; 12].join(",");
        std::fs::write(
            &p,
            format!(
                "t,{}{extra_header}\n0,{row}{extra}\n0.01,{row}{extra}\n",
                names.join(",")
            ),
        )
        .unwrap();
        p
    };
    let e = estimate(
        &arrangement,
        &samples(",temp_nothing", ",20"),
        &d.join("o.csv"),
    )
    .unwrap_err();
    assert!(
        e.contains("temp_nothing") && e.contains("not a channel"),
        "{e}"
    );
    let e = estimate(&arrangement, &samples(",temp_c0", ",900"), &d.join("o.csv")).unwrap_err();
    assert!(
        e.contains("line 2") && e.contains("not a temperature"),
        "{e}"
    );
    let e = estimate(
        &arrangement,
        &samples(",temp_c0,temp_c0", ",20,20"),
        &d.join("o.csv"),
    )
    .unwrap_err();
    assert!(e.contains("appears twice"), "{e}");
    let toml = toml.replacen("name = \"c5\"", "name = \"c5\"\nbias_tc = 0.001", 1);
    std::fs::write(&arrangement, &toml).unwrap();
    let e = estimate(&arrangement, &samples("", ""), &d.join("o.csv")).unwrap_err();
    assert!(e.contains("c5") && e.contains("t_ref"), "{e}");
}
