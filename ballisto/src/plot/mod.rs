//! The plot of `ballisto sim --estimate`: Ω, Ω′ and σ0 against time, estimate (light) over
//! truth (dark), x red, y green, z blue — one PNG for a person to look at.

mod canvas;

use std::error::Error;
use std::path::Path;

pub use canvas::{Canvas, Rgb};

use crate::compare;

const WIDTH: i64 = 1200;
const PANEL: i64 = 290;
const LEFT: i64 = 110;
const RIGHT: i64 = 30;
const TOP: i64 = 40;
const GAP: i64 = 50;
const DARK: [Rgb; 3] = [[170, 0, 0], [0, 120, 0], [0, 0, 170]];
const LIGHT: [Rgb; 3] = [[250, 160, 160], [150, 220, 150], [160, 170, 250]];
const INK: Rgb = [30, 30, 30];
const GRID: Rgb = [225, 225, 225];

/// Plots the estimates file against the truth file into a PNG.
pub fn plot_files(truth: &Path, estimates: &Path, png: &Path) -> Result<(), Box<dyn Error>> {
    let (th, tr) = compare::read(truth)?;
    let (eh, er) = compare::read(estimates)?;
    let col = |h: &std::collections::HashMap<String, usize>, file: &Path, c: &str| {
        h.get(c)
            .copied()
            .ok_or_else(|| format!("{}: no column \"{c}\"", file.display()))
    };
    let height = TOP + 3 * (PANEL + GAP) + 20;
    let mut canvas = Canvas::new(WIDTH as usize, height as usize, [255, 255, 255]);
    canvas.text(
        LEFT,
        12,
        "ESTIMATE (LIGHT) OVER TRUTH (DARK)   X RED  Y GREEN  Z BLUE",
        2,
        INK,
    );
    let panels = [
        ("omega", "OMEGA (RAD/S)"),
        ("domega", "DOMEGA (RAD/S2)"),
        ("sigma0", "SIGMA0 (M/S2)"),
    ];
    let (tt, et) = (col(&th, truth, "t")?, col(&eh, estimates, "t")?);
    for (p, (key, title)) in panels.iter().enumerate() {
        let y0 = TOP + p as i64 * (PANEL + GAP);
        let mut truth_series = Vec::new();
        let mut est_series = Vec::new();
        for axis in ["x", "y", "z"] {
            let c = format!("{key}_{axis}");
            let (ct, ce) = (col(&th, truth, &c)?, col(&eh, estimates, &c)?);
            truth_series.push(tr.iter().map(|r| (r[tt], r[ct])).collect::<Vec<_>>());
            est_series.push(er.iter().map(|r| (r[et], r[ce])).collect::<Vec<_>>());
        }
        let frame = Frame::fit(&truth_series, &est_series, y0);
        frame.axes(&mut canvas, title, p == 2);
        for (s, c) in est_series.iter().zip(LIGHT) {
            frame.series(&mut canvas, s, c);
        }
        for (s, c) in truth_series.iter().zip(DARK) {
            frame.series(&mut canvas, s, c);
        }
    }
    canvas.save_png(png)?;
    Ok(())
}

/// One panel's data window and its place on the canvas.
struct Frame {
    t: (f64, f64),
    v: (f64, f64),
    top: i64,
}

impl Frame {
    /// Time span of all series; values: the truth's range and the central 98 % of the
    /// estimates, with a margin (outliers beyond are clipped so that they do not flatten the
    /// plot).
    fn fit(truth: &[Vec<(f64, f64)>], est: &[Vec<(f64, f64)>], top: i64) -> Frame {
        let mut t = (f64::INFINITY, f64::NEG_INFINITY);
        let mut v = (f64::INFINITY, f64::NEG_INFINITY);
        for s in truth.iter().chain(est.iter()) {
            for &(ti, _) in s {
                t = (t.0.min(ti), t.1.max(ti));
            }
        }
        for s in truth {
            for &(_, vi) in s.iter().filter(|p| p.1.is_finite()) {
                v = (v.0.min(vi), v.1.max(vi));
            }
        }
        let mut e: Vec<f64> = est
            .iter()
            .flat_map(|s| s.iter().map(|p| p.1))
            .filter(|x| x.is_finite())
            .collect();
        if !e.is_empty() {
            e.sort_by(f64::total_cmp);
            let at = |q: f64| e[((e.len() - 1) as f64 * q).round() as usize];
            v = (v.0.min(at(0.01)), v.1.max(at(0.99)));
        }
        if !(t.0.is_finite() && t.1 > t.0) {
            t = (0.0, 1.0);
        }
        if !v.0.is_finite() {
            v = (-1.0, 1.0);
        }
        let span = (v.1 - v.0).max(1e-3 * v.0.abs().max(v.1.abs())).max(1e-9);
        Frame {
            t,
            v: (v.0 - 0.25 * span, v.1 + 0.25 * span),
            top,
        }
    }

    fn x(&self, t: f64) -> i64 {
        LEFT + ((t - self.t.0) / (self.t.1 - self.t.0) * (WIDTH - LEFT - RIGHT) as f64) as i64
    }

    fn y(&self, v: f64) -> i64 {
        let f = ((v - self.v.0) / (self.v.1 - self.v.0)).clamp(0.0, 1.0);
        self.top + PANEL - (f * PANEL as f64) as i64
    }

    fn axes(&self, c: &mut Canvas, title: &str, time_label: bool) {
        let (l, r) = (LEFT, WIDTH - RIGHT);
        for v in ticks(self.v.0, self.v.1) {
            let y = self.y(v);
            c.line((l, y), (r, y), GRID);
            let s = label(v);
            c.text(l - 8 - Canvas::text_width(&s, 2), y - 7, &s, 2, INK);
        }
        for t in ticks(self.t.0, self.t.1) {
            let x = self.x(t);
            c.line((x, self.top), (x, self.top + PANEL), GRID);
            let s = label(t);
            c.text(
                x - Canvas::text_width(&s, 2) / 2,
                self.top + PANEL + 6,
                &s,
                2,
                INK,
            );
        }
        c.line((l, self.top), (l, self.top + PANEL), INK);
        c.line((l, self.top + PANEL), (r, self.top + PANEL), INK);
        c.text(l + 8, self.top + 6, title, 2, INK);
        if time_label {
            c.text(
                r - Canvas::text_width("T (S)", 2),
                self.top + PANEL + 26,
                "T (S)",
                2,
                INK,
            );
        }
    }

    fn series(&self, c: &mut Canvas, s: &[(f64, f64)], colour: Rgb) {
        let mut last: Option<(i64, i64)> = None;
        for &(t, v) in s {
            if !v.is_finite() {
                last = None;
                continue;
            }
            let p = (self.x(t), self.y(v));
            if let Some(q) = last {
                if q != p {
                    c.line(q, p, colour);
                }
            } else {
                c.set(p.0, p.1, colour);
            }
            last = Some(p);
        }
    }
}

/// About five round tick values in [lo, hi].
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let raw = (hi - lo) / 5.0;
    if !(raw.is_finite() && raw > 0.0) {
        return Vec::new();
    }
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let mut v = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while v <= hi && out.len() < 20 {
        out.push(if v.abs() < 1e-9 * step { 0.0 } else { v });
        v += step;
    }
    out
}

/// A short label for a tick value.
fn label(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside_the_range() {
        assert_eq!(ticks(0.0, 10.0), vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        let t = ticks(-0.013, 0.027);
        assert_eq!(t.first(), Some(&-0.01));
        assert!(t.iter().all(|v| (-0.013..=0.027).contains(v)));
        assert_eq!(label(0.25), "0.25");
        assert_eq!(label(2e-5), "2.0e-5");
        assert!(ticks(1.0, 1.0).is_empty());
    }
}
