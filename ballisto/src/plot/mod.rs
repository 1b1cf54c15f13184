//! The plot of `ballisto sim --estimate` / `--firmware`: what a person checking an estimate
//! needs to see — the motion (Ω of the truth), then the **error** of Ω, Ω′ and σ0 against the
//! truth over time with the band of ±3 reported standard deviations (grey) and the rows the
//! estimator flagged (orange strip): an error outside the band without a flag is a silently
//! wrong estimate. x red, y green, z blue. One PNG.
//!
//! The files are streamed (two passes; per pixel column the range of every series), so memory
//! does not grow with the record.

mod canvas;

use std::error::Error;
use std::path::Path;

pub use canvas::{Canvas, Rgb};

use crate::columns::{Columns, Matched};

const WIDTH: i64 = 1200;
const PANEL: i64 = 220;
const LEFT: i64 = 110;
const RIGHT: i64 = 30;
const TOP: i64 = 40;
const GAP: i64 = 50;
const PLOT_W: usize = (WIDTH - LEFT - RIGHT) as usize;
const AXIS: [Rgb; 3] = [[200, 0, 0], [0, 140, 0], [0, 0, 200]];
const BAND: Rgb = [215, 215, 215];
const FLAGGED: Rgb = [255, 150, 0];
const INK: Rgb = [30, 30, 30];
const GRID: Rgb = [235, 235, 235];

/// Columns read from both files (`t` first), then the estimates' own.
const SHARED: [&str; 10] = [
    "t", "omega_x", "omega_y", "omega_z", "domega_x", "domega_y", "domega_z", "sigma0_x",
    "sigma0_y", "sigma0_z",
];
const EXTRA: [&str; 10] = [
    "sd_omega_x",
    "sd_omega_y",
    "sd_omega_z",
    "sd_domega_x",
    "sd_domega_y",
    "sd_domega_z",
    "sd_sigma0_x",
    "sd_sigma0_y",
    "sd_sigma0_z",
    "flags",
];

/// The range of one series within one pixel column, and its first and last value there.
#[derive(Clone, Copy)]
struct Cell {
    lo: f64,
    hi: f64,
    first: f64,
    last: f64,
}

/// Per pixel column: every series' cell (`None`: no finite value there).
type Track = Vec<Option<Cell>>;

fn add(track: &mut Track, x: usize, v: f64) {
    if !v.is_finite() {
        return;
    }
    let c = track[x].get_or_insert(Cell {
        lo: v,
        hi: v,
        first: v,
        last: v,
    });
    c.lo = c.lo.min(v);
    c.hi = c.hi.max(v);
    c.last = v;
}

/// Plots the estimates file against the truth file into a PNG.
pub fn plot_files(truth: &Path, estimates: &Path, png: &Path) -> Result<(), Box<dyn Error>> {
    // Pass 1: the time span.
    let mut times = Columns::open(estimates, &["t"])?;
    let mut t = [0.0];
    let mut span = (f64::INFINITY, f64::NEG_INFINITY);
    while times.next_into(&mut t)? {
        if t[0].is_finite() {
            span = (span.0.min(t[0]), span.1.max(t[0]));
        }
    }
    if !(span.0.is_finite() && span.1 > span.0) {
        // No rows, or one instant: a one-second window from it.
        span = if span.0.is_finite() {
            (span.0, span.0 + 1.0)
        } else {
            (0.0, 1.0)
        };
    }
    // Pass 2: per pixel column, truth Ω (3), errors (9), the band (3 panels), flags.
    let mut rows = Matched::open(truth, estimates, &SHARED, &EXTRA)?;
    let (mut e, mut tr) = ([0.0; 20], [0.0; 10]);
    let empty: Track = vec![None; PLOT_W];
    let mut motion = vec![empty.clone(); 3];
    let mut error = vec![empty.clone(); 9];
    let mut band = vec![empty; 3];
    let mut flagged = vec![false; PLOT_W];
    let column = |t: f64| {
        let f = (t - span.0) / (span.1 - span.0);
        ((f * (PLOT_W - 1) as f64).round().max(0.0) as usize).min(PLOT_W - 1)
    };
    while rows.next_into(&mut e, &mut tr)? {
        let x = column(e[0]);
        for a in 0..3 {
            add(&mut motion[a], x, tr[1 + a]);
        }
        for s in 0..9 {
            add(&mut error[s], x, e[1 + s] - tr[1 + s]);
        }
        for p in 0..3 {
            let sd = (0..3).map(|a| e[10 + 3 * p + a]).fold(0.0f64, f64::max);
            add(&mut band[p], x, 3.0 * sd);
        }
        flagged[x] |= e[19] != 0.0;
    }
    let height = TOP + 4 * (PANEL + GAP) + 20;
    let mut canvas = Canvas::new(WIDTH as usize, height as usize, [255, 255, 255]);
    canvas.text(
        LEFT,
        12,
        "ERROR = ESTIMATE - TRUTH   GREY: +-3 REPORTED SD   ORANGE: FLAGGED   X RED Y GREEN Z BLUE",
        2,
        INK,
    );
    let panels: [(&str, &[Track], Option<&Track>); 4] = [
        ("OMEGA, TRUTH (RAD/S)", &motion, None),
        ("OMEGA ERROR (RAD/S)", &error[0..3], Some(&band[0])),
        ("DOMEGA ERROR (RAD/S2)", &error[3..6], Some(&band[1])),
        ("SIGMA0 ERROR (M/S2)", &error[6..9], Some(&band[2])),
    ];
    for (p, (title, series, band)) in panels.iter().enumerate() {
        let top = TOP + p as i64 * (PANEL + GAP);
        let frame = match band {
            None => Frame::around(span, series, top),
            Some(b) => Frame::symmetric(span, series, b, top),
        };
        frame.axes(&mut canvas, title, p == 3);
        if let Some(b) = band {
            for (x, c) in b.iter().enumerate() {
                if let Some(c) = c {
                    let (y0, y1) = (frame.y(c.hi), frame.y(-c.hi));
                    canvas.fill(LEFT + x as i64, y0, 1, y1 - y0 + 1, BAND);
                }
            }
            for (x, f) in flagged.iter().enumerate() {
                if *f {
                    canvas.fill(LEFT + x as i64, top + PANEL - 5, 1, 5, FLAGGED);
                }
            }
        }
        for (s, colour) in series.iter().zip(AXIS) {
            frame.track(&mut canvas, s, colour);
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
    /// The range of the series with a margin.
    fn around(t: (f64, f64), series: &[Track], top: i64) -> Frame {
        let mut v = (f64::INFINITY, f64::NEG_INFINITY);
        for c in series.iter().flatten().flatten() {
            v = (v.0.min(c.lo), v.1.max(c.hi));
        }
        if !v.0.is_finite() {
            v = (-1.0, 1.0);
        }
        let pad = (v.1 - v.0).max(1e-3 * v.0.abs().max(v.1.abs())).max(1e-9);
        Frame {
            t,
            v: (v.0 - 0.15 * pad, v.1 + 0.15 * pad),
            top,
        }
    }

    /// Symmetric about zero: the larger of the 98th percentiles (over pixel columns) of the
    /// largest error and of the band, with a margin; rarer excursions are clipped at the edge.
    fn symmetric(t: (f64, f64), series: &[Track], band: &Track, top: i64) -> Frame {
        let q98 = |mut v: Vec<f64>| {
            if v.is_empty() {
                return 0.0;
            }
            v.sort_by(f64::total_cmp);
            v[((v.len() - 1) as f64 * 0.98).round() as usize]
        };
        let errs: Vec<f64> = (0..PLOT_W)
            .filter_map(|x| {
                series
                    .iter()
                    .filter_map(|s| s[x].map(|c| c.lo.abs().max(c.hi.abs())))
                    .reduce(f64::max)
            })
            .collect();
        let bands: Vec<f64> = band.iter().flatten().map(|c| c.hi).collect();
        let m = q98(errs).max(q98(bands));
        let m = if m.is_finite() && m > 0.0 {
            1.2 * m
        } else {
            1.0
        };
        Frame { t, v: (-m, m), top }
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

    /// A series' range in every pixel column, joined from each column's last value to the
    /// next one's first.
    fn track(&self, c: &mut Canvas, s: &Track, colour: Rgb) {
        let mut last: Option<(i64, f64)> = None;
        for (x, cell) in s.iter().enumerate() {
            let x = LEFT + x as i64;
            let Some(cell) = cell else {
                continue;
            };
            if let Some((px, pv)) = last {
                c.line((px, self.y(pv)), (x, self.y(cell.first)), colour);
            }
            c.line((x, self.y(cell.lo)), (x, self.y(cell.hi)), colour);
            last = Some((x, cell.last));
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
