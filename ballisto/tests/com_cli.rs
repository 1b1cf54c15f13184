//! `ballisto com`: ρ of `tetra-orbit` (origin_offset in the scenario) recovered within its
//! reported deviations; a window without rotation cannot separate ρ from f and says so.

mod common;

use common::ballisto;

use std::path::{Path, PathBuf};

fn tmpdir(name: &str) -> PathBuf {
    common::tmpdir("com", name)
}

fn sim(scenario: &str, dir: &Path) {
    common::run_ok(
        ballisto()
            .args(["sim", "--scenario", scenario, "--out"])
            .arg(dir),
    );
}

fn com(dir: &Path, samples: &str) -> Vec<Vec<Option<f64>>> {
    common::run_ok(
        ballisto()
            .arg("com")
            .arg("--arrangement")
            .arg(dir.join("arrangement.toml"))
            .arg("--samples")
            .arg(dir.join(samples))
            .arg("--out")
            .arg(dir.join("com.csv")),
    );
    let text = std::fs::read_to_string(dir.join("com.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,rho_x,rho_y,rho_z,f_x,f_y,f_z,sd_rho_x,sd_rho_y,sd_rho_z"
    );
    lines
        .map(|l| l.split(',').map(|v| v.parse().ok()).collect())
        .collect()
}

#[test]
fn rho_of_tetra_orbit_is_recovered_within_its_deviations() {
    let dir = tmpdir("tetra");
    sim("tetra-orbit", &dir);
    let rows = com(&dir, "samples.csv");
    assert_eq!(rows.len(), 3, "20 s in windows of 10 s every 5 s");
    let truth = [0.02, -0.01, 0.03]; // origin_offset of tetra-orbit.toml
    for r in &rows {
        for k in 0..3 {
            let (rho, sd) = (r[1 + k].unwrap(), r[7 + k].unwrap());
            println!(
                "t {} rho_{k} {rho:.6} ± {sd:.1e} (truth {})",
                r[0].unwrap(),
                truth[k]
            );
            assert!(sd > 0.0 && sd < 1e-3, "sd {sd}");
            assert!(
                (rho - truth[k]).abs() < 4.0 * sd,
                "rho_{k} {rho} ± {sd} vs {}",
                truth[k]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_record_at_rest_leaves_rho_empty() {
    let dir = tmpdir("rest");
    // tetra-orbit's parts on the ground, at rest for 20 s: A + {Ω′} is only noise.
    let text = common::scenario_text("tetra-orbit");
    let parts = &text[text.find("[[bus]]").unwrap()..];
    let scenario = format!(
        "rate = 100.0\nduration = 20.0\n[body]\nschedule = [{{ kind = \"rest\", duration = 20.0 }}]\n[environment]\nkind = \"ground\"\n{parts}"
    );
    std::fs::write(dir.join("rest.toml"), scenario).unwrap();
    sim(dir.join("rest.toml").to_str().unwrap(), &dir);
    let rows = com(&dir, "samples.csv");
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert!(r[1..].iter().all(|v| v.is_none()), "{r:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
