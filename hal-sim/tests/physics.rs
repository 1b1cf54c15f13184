//! Samples vs physics: what the parts return through their buses against paper eq. (4)
//! evaluated on the truth. Without noise and errors every channel equals eq. (4) to
//! quantisation; with them, the residuals have the configured scale, bias, cross-axis terms and
//! noise; each scheduled fault of a named scenario shows in the record at its time.

use hal_sim::motion::Truth;
use hal_sim::recorder::Recorder;
use hal_sim::scenario::{PartSpec, Scenario};

use hal_sim::sensors::errors::G0;

/// eq. (4) for the three axes of a part.
fn ideal(tr: &Truth, p: &PartSpec) -> [f64; 3] {
    [0, 1, 2].map(|k| tr.channel(&p.position, &p.axis(k)))
}

/// `samples` sample sets: (truth, readings per part).
fn record(sc: &Scenario, samples: usize) -> Vec<(Truth, Vec<[f64; 3]>)> {
    let mut rec = Recorder::new(sc).expect("the scenario starts");
    (0..samples)
        .map(|k| {
            let (t, set) = rec.sample_set(k);
            let readings = set
                .into_iter()
                .map(|r| r.expect("no bus errors without faults"))
                .collect();
            (rec.truth(t), readings)
        })
        .collect()
}

const TUMBLE: &str = r#"
rate = 200.0
duration = 5.0
seed = 5
[body]
inertia = [1.0, 1.8, 2.5]
omega0 = [0.8, 1.9, -1.1]
origin_offset = [0.02, -0.01, 0.03]
[environment]
kind = "orbit"
altitude = 400e3
[[bus]]
name = "spi"
kind = "spi"
clock_hz = 8e6
"#;

fn adxl_part(name: &str, cs: usize, position: [f64; 3], extra: &str) -> String {
    format!(
        r#"
[[part]]
name = "{name}"
type = "adxl355"
bus = "spi"
cs = {cs}
position = {position:?}
orientation = [[0.726315789474, 0.442105263158, 0.526315789474], [-0.315789473684, 0.894736842105, -0.315789473684], [-0.610526315789, 0.063157894737, 0.789473684211]]
{extra}
"#
    )
}

#[test]
fn without_noise_and_errors_every_channel_is_eq_4_to_quantisation() {
    let mut text = TUMBLE.to_string();
    for (i, p) in [[0.1, 0.05, -0.08], [-0.12, 0.0, 0.1], [0.0, -0.15, 0.02]]
        .iter()
        .enumerate()
    {
        text += &adxl_part(&format!("u{i}"), i, *p, "");
    }
    let sc = Scenario::parse(&text, "test").unwrap();
    let lsb = G0 / 256_000.0;
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for (tr, readings) in record(&sc, sc.samples()) {
        for (p, r) in sc.parts.iter().zip(readings.iter()) {
            let f = ideal(&tr, p);
            for k in 0..3 {
                // Less the driver's f32 rounding: its scale and the product, each to 2⁻²⁴ of
                // the value (the firmware reads the same f32).
                let rounding = f[k].abs() * f64::from(f32::EPSILON);
                worst = worst.max((r[k] - f[k]).abs() - rounding);
                largest = largest.max(f[k].abs());
            }
        }
    }
    eprintln!(
        "ADXL355, sync: max |reading − eq. 4| less the driver's f32 rounding = {:.3} LSB over signals up to {:.0} LSB",
        worst / lsb,
        largest / lsb
    );
    assert!(largest > 1e4 * lsb, "the motion must exercise the channels");
    assert!(worst <= 0.5 * lsb * (1.0 + 1e-9), "{} LSB", worst / lsb);
}

#[test]
fn unsynchronised_i2c_part_reads_eq_4_at_its_own_earlier_sample_instant() {
    // Ground turntable: the LIS3DH samples at 400 Hz on its own clock, read at 100 Hz; each
    // reading is eq. 4 at the part's latest sample instant, a constant lag behind the read.
    let sc = Scenario::parse(
        r#"
rate = 100.0
duration = 4.0
[body]
turntable = { axis = [0.2, -0.3, 0.93], rate = 3.0 }
attitude0 = [0.96, 0.2, -0.1, 0.15]
[environment]
kind = "ground"
[[bus]]
name = "i2c"
kind = "i2c"
clock_hz = 400e3
[[part]]
name = "l0"
type = "lis3dh"
bus = "i2c"
address = 0x18
position = [0.04, -0.13, 0.1]
odr = 400.0
"#,
        "test",
    )
    .unwrap();
    let lsb = G0 * 1e-3;
    let rec = record(&sc, sc.samples());
    let p = &sc.parts[0];
    // Rate of change of eq. 4 at each read instant (central difference of the truth).
    let m = Recorder::new(&sc).unwrap();
    let mut sum_rd = 0.0;
    let mut sum_dd = 0.0;
    let mut rows = Vec::new();
    for (tr, r) in &rec {
        let (a, b) = (m.truth(tr.t + 1e-5), m.truth(tr.t - 1e-5));
        let (fa, fb) = (ideal(&a, p), ideal(&b, p));
        let f = ideal(tr, p);
        for k in 0..3 {
            let d = (fa[k] - fb[k]) / 2e-5;
            let res = r[0][k] - f[k];
            sum_rd += res * d;
            sum_dd += d * d;
            rows.push((res, d));
        }
    }
    let lag = -sum_rd / sum_dd;
    let worst = rows
        .iter()
        .map(|(res, d)| (res + lag * d).abs())
        .fold(0.0, f64::max);
    let uncorrected = rows.iter().map(|(res, _)| res.abs()).fold(0.0, f64::max);
    eprintln!(
        "LIS3DH at 400 Hz read at 100 Hz: lag {:.3} ms; max residual {:.2} LSB, {:.2} LSB after the lag",
        lag * 1e3,
        uncorrected / lsb,
        worst / lsb
    );
    assert!(
        lag > 0.0 && lag < 1.0 / 400.0,
        "lag {lag} s within one period"
    );
    assert!(uncorrected > 2.0 * lsb, "the lag must show as error");
    // Quantisation plus the second-order term of the lag (g ω² lag² / 2 < 0.03 LSB).
    assert!(worst <= 0.5 * lsb + 0.05 * lsb, "{} LSB", worst / lsb);
}

/// Least squares `y ≈ X c` for 4 columns (normal equations, Gauss–Jordan): coefficients,
/// their standard errors for unit noise (√ of the diagonal of (XᵀX)⁻¹), residual RMS.
fn fit4(rows: &[([f64; 4], f64)]) -> ([f64; 4], [f64; 4], f64) {
    // [XᵀX | I | Xᵀy]
    let mut a = [[0.0; 9]; 4];
    for (x, y) in rows {
        for i in 0..4 {
            for j in 0..4 {
                a[i][j] += x[i] * x[j];
            }
            a[i][8] += x[i] * y;
        }
    }
    for (i, row) in a.iter_mut().enumerate() {
        row[4 + i] = 1.0;
    }
    for c in 0..4 {
        let p = a[c][c];
        for v in a[c].iter_mut() {
            *v /= p;
        }
        for r in 0..4 {
            if r != c {
                let f = a[r][c];
                let pivot = a[c];
                for (v, pv) in a[r].iter_mut().zip(pivot.iter()) {
                    *v -= f * pv;
                }
            }
        }
    }
    let c = [a[0][8], a[1][8], a[2][8], a[3][8]];
    let se = [0, 1, 2, 3].map(|i| a[i][4 + i].sqrt());
    let ss: f64 = rows
        .iter()
        .map(|(x, y)| (y - (0..4).map(|i| c[i] * x[i]).sum::<f64>()).powi(2))
        .sum();
    (c, se, (ss / (rows.len() - 4) as f64).sqrt())
}

#[test]
fn with_errors_the_residuals_have_the_configured_scale_bias_cross_axis_and_noise() {
    let scale = [1.01, 0.995, 1.002];
    let bias = [0.02, -0.01, 0.03];
    let cross = [
        [0.0, 0.004, -0.002],
        [0.003, 0.0, 0.001],
        [-0.003, 0.002, 0.0],
    ];
    let nd = 2.2e-4;
    let extra = format!(
        "scale = {scale:?}\nbias = {bias:?}\ncross = {cross:?}\nnoise_density = {nd}\nclock_ppm = 40.0"
    );
    let mut text = TUMBLE.replace("duration = 5.0", "duration = 10.0");
    text += &adxl_part("u0", 0, [0.1, 0.12, -0.08], &extra);
    let sc = Scenario::parse(&text, "test").unwrap();
    let rec = record(&sc, sc.samples());
    let p = &sc.parts[0];
    // ODR 250 Hz (the lowest at or above 200 Hz): noise over ODR/4, plus quantisation.
    let lsb = G0 / 256_000.0;
    let sd = (nd * nd * 250.0 / 4.0 + lsb * lsb / 12.0).sqrt();
    for k in 0..3 {
        let rows: Vec<([f64; 4], f64)> = rec
            .iter()
            .map(|(tr, r)| {
                let f = ideal(tr, p);
                ([f[0], f[1], f[2], 1.0], r[0][k])
            })
            .collect();
        let (c, se, resid) = fit4(&rows);
        for j in 0..3 {
            // Five standard errors.
            let tol = 5.0 * sd * se[j];
            let want = if j == k {
                scale[k]
            } else {
                scale[k] * cross[k][j]
            };
            assert!(
                (c[j] - want).abs() < tol,
                "axis {k} coefficient {j}: {} vs {want} (tol {tol:.1e})",
                c[j]
            );
        }
        assert!(
            (c[3] - bias[k]).abs() < 5.0 * sd * se[3],
            "axis {k} bias {}",
            c[3]
        );
        eprintln!(
            "axis {k}: scale {:.5} ± {:.5} (set {}), bias {:.5} ± {:.5} (set {}), residual {:.3e} (model {:.3e})",
            c[k], sd * se[k], scale[k], c[3], sd * se[3], bias[k], resid, sd
        );
        assert!(
            (resid / sd - 1.0).abs() < 0.08,
            "axis {k}: residual {resid:e} vs {sd:e}"
        );
    }
}

#[test]
fn faults_of_the_named_scenario_show_in_the_record_at_their_times() {
    let sc = Scenario::load("tetra-orbit-faults").unwrap();
    let mut rec = Recorder::new(&sc).unwrap();
    let idx = |name: &str| sc.parts.iter().position(|p| p.name == name).unwrap();
    let (u0, u1, u2, u3) = (idx("u0"), idx("u1"), idx("u2"), idx("u3"));
    let lsb = G0 / 256_000.0;
    let mut stuck_value = None;
    let (mut bias_before, mut bias_after, mut nb, mut na) = ([0.0; 3], [0.0; 3], 0.0, 0.0);
    let (mut outliers_in, mut outliers_out) = (0, 0);
    for k in 0..sc.samples() {
        let (t, set) = rec.sample_set(k);
        let tr = rec.truth(t);
        let get = |i: usize| set[i].clone().expect("SPI reads do not fail");
        // u3 dead in [14, 15): MISO high reads all ones, bits the part always reads as zero
        // (the low nibble of XDATA1): the driver refuses the transfer.
        let dead = set[u3].is_err();
        assert!(set[u3].as_ref().is_ok_and(|v| *v != [-lsb; 3]) || dead);
        assert_eq!(dead, (14.0..15.0).contains(&t), "u3 at t = {t}");
        // u1 stuck in [5, 6): one repeated value.
        if (5.0..6.0).contains(&t) {
            let v = get(u1);
            assert_eq!(*stuck_value.get_or_insert(v), v, "u1 at t = {t}");
        } else {
            let f = ideal(&tr, &sc.parts[u1]);
            let v = get(u1);
            assert!((0..3).all(|j| (v[j] - f[j]).abs() < 0.02), "u1 live at {t}");
        }
        // u2 bias jump from 10 s.
        let f = ideal(&tr, &sc.parts[u2]);
        let v = get(u2);
        if t < 10.0 {
            nb += 1.0;
            (0..3).for_each(|j| bias_before[j] += v[j] - f[j]);
        } else {
            na += 1.0;
            (0..3).for_each(|j| bias_after[j] += v[j] - f[j]);
        }
        // u0 corrupted bytes in [17, 17.5): single-bit flips, mostly far above the noise.
        // A flip in a bit the part always reads as zero is refused by the driver; the others
        // read as values.
        let f = ideal(&tr, &sc.parts[u0]);
        let wild = match &set[u0] {
            Ok(v) => (0..3).any(|j| (v[j] - f[j]).abs() > 0.02),
            Err(_) => true,
        };
        if (17.0..17.5).contains(&t) {
            outliers_in += usize::from(wild);
        } else {
            outliers_out += usize::from(wild);
        }
    }
    let step: Vec<f64> = (0..3)
        .map(|j| bias_after[j] / na - bias_before[j] / nb)
        .collect();
    eprintln!("u2 bias step {step:.4?} (set [0.05, 0, -0.03]); u0 outliers {outliers_in} in the window, {outliers_out} outside");
    for (s, want) in step.iter().zip([0.05, 0.0, -0.03]) {
        assert!((s - want).abs() < 5e-4, "{s} vs {want}");
    }
    assert!(outliers_in >= 5, "corruption visible: {outliers_in}");
    assert_eq!(outliers_out, 0);
}
