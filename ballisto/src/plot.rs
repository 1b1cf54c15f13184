//! The plot of `ballisto sim --estimate` / `--firmware`: what a person checking an estimate
//! needs to see — the motion (Ω of the truth), then the **error** of Ω, Ω′ and σ0 against the
//! truth over time with the band of ±3 reported standard deviations (grey) and the rows the
//! estimator flagged (orange strip): an error outside the band without a flag is a silently
//! wrong estimate. x red, y green, z blue. One PNG.
//!
//! The files are streamed (two passes; per pixel column the range of every series), so memory
//! does not grow with the record. Drawn with `plotters` (bitmap backend) in a font compiled in
//! (`epaint_default_fonts`' Ubuntu Light): no system fonts needed.

use std::error::Error;
use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::columns::{Columns, Matched};

const WIDTH: u32 = 1200;
const HEIGHT: u32 = 1200;
/// Columns the series are reduced to: at least the plotting width in pixels (about 1100), so
/// that every pixel column is drawn through its range (fewer, and the pixel columns between
/// two show as white stripes through a long record's envelope).
const PLOT_W: usize = 1200;
const AXIS: [RGBColor; 3] = [
    RGBColor(200, 0, 0),
    RGBColor(0, 140, 0),
    RGBColor(0, 0, 200),
];
const BAND: RGBColor = RGBColor(215, 215, 215);
const FLAGGED: RGBColor = RGBColor(255, 150, 0);
/// The family the compiled-in font is registered under ([`font`]).
pub(crate) const FONT: &str = "sans-serif";

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

/// What to plot.
pub struct PlotJob<'a> {
    /// The truth file.
    pub truth: &'a Path,
    /// The estimates file.
    pub estimates: &'a Path,
    /// The samples file, whose `temp_<channel>` columns (where it has them) are drawn in a
    /// panel of their own: one line per part.
    pub samples: Option<&'a Path>,
    /// Lines over the plot saying what it shows (the scenario, the kind of parts).
    pub heading: &'a [String],
    /// The PNG to write.
    pub png: &'a Path,
}

/// Plots the estimates file against the truth file into a PNG.
pub fn plot_files(job: &PlotJob) -> Result<(), Box<dyn Error>> {
    let (truth, estimates) = (job.truth, job.estimates);
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
    let temperature = match job.samples {
        Some(samples) => temperatures(samples, &column)?,
        None => Vec::new(),
    };
    let tracks = Tracks {
        motion,
        error,
        band,
        flagged,
        temperature,
    };
    draw(job, span, &tracks)
}

/// Per pixel column, the temperature of each part in `samples` (its first `temp_` column:
/// the part's channels share one sensor); none without such columns.
fn temperatures(
    samples: &Path,
    column: &dyn Fn(f64) -> usize,
) -> Result<Vec<(String, Track)>, String> {
    let mut parts: Vec<(String, String)> = Vec::new();
    for name in crate::columns::header(samples)? {
        let Some(channel) = name.strip_prefix("temp_") else {
            continue;
        };
        let part = channel.rsplit_once('.').map_or(channel, |(p, _)| p);
        if parts.iter().all(|(p, _)| p != part) {
            parts.push((part.to_string(), name.clone()));
        }
    }
    if parts.is_empty() {
        return Ok(Vec::new());
    }
    let names: Vec<&str> = std::iter::once("t")
        .chain(parts.iter().map(|(_, c)| c.as_str()))
        .collect();
    let mut rows = Columns::open(samples, &names)?;
    let mut row = vec![0.0; names.len()];
    let mut tracks: Vec<Track> = vec![vec![None; PLOT_W]; parts.len()];
    // An empty field is a part not read at that instant: no point.
    while rows.next_with_gaps(&mut row)? {
        let x = column(row[0]);
        for (track, v) in tracks.iter_mut().zip(&row[1..]) {
            add(track, x, *v);
        }
    }
    Ok(parts.into_iter().map(|(p, _)| p).zip(tracks).collect())
}

/// Registers the compiled-in font once.
pub(crate) fn font() -> Result<(), String> {
    static REGISTER: Once = Once::new();
    let mut result = Ok(());
    REGISTER.call_once(|| {
        result = plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .map_err(|_| "the plot's font could not be loaded".to_string());
    });
    result
}

/// The time of pixel column `x`'s centre.
fn column_t(span: (f64, f64), x: usize) -> f64 {
    span.0 + (x as f64 + 0.5) / PLOT_W as f64 * (span.1 - span.0)
}

/// The series of a plot, reduced to pixel columns.
struct Tracks {
    /// The truth's Ω, per axis.
    motion: Vec<Track>,
    /// The errors of Ω, Ω′ and σ0, per axis.
    error: Vec<Track>,
    /// The ±3 sd band of each error panel.
    band: Vec<Track>,
    /// The columns holding a flagged row.
    flagged: Vec<bool>,
    /// Each part's temperature (°C), by name; empty where the record has none.
    temperature: Vec<(String, Track)>,
}

/// Colours of the parts' temperatures (cycled).
const PARTS: [RGBColor; 8] = [
    RGBColor(200, 0, 0),
    RGBColor(0, 140, 0),
    RGBColor(0, 0, 200),
    RGBColor(200, 120, 0),
    RGBColor(140, 0, 160),
    RGBColor(0, 150, 150),
    RGBColor(90, 90, 90),
    RGBColor(160, 100, 60),
];

/// The heading (the job's lines and the legend), then the panels: the truth's Ω, the error of
/// Ω, Ω′ and σ0 with the ±3 sd band and the flagged rows, and the parts' temperatures where
/// the record has them.
fn draw(job: &PlotJob, span: (f64, f64), tracks: &Tracks) -> Result<(), Box<dyn Error>> {
    font()?;
    let png = job.png;
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", png.display());
    let with_temperature = !tracks.temperature.is_empty();
    let height = HEIGHT + if with_temperature { PANEL_H } else { 0 };
    let root = BitMapBackend::new(png, (WIDTH, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let legend = "error = estimate − truth   grey: ±3 reported sd   orange: flagged rows   x red, y green, z blue";
    let lines: Vec<&str> = job
        .heading
        .iter()
        .map(String::as_str)
        .chain([legend])
        .collect();
    let (top, body) = root.split_vertically(HEADING_LINE * lines.len() as u32 + 10);
    for (i, line) in lines.iter().enumerate() {
        let style = TextStyle::from((FONT, if i == 0 { 20 } else { 17 }).into_font())
            .pos(Pos::new(HPos::Center, VPos::Top));
        top.draw(&Text::new(
            line.to_string(),
            ((WIDTH / 2) as i32, 6 + (HEADING_LINE as usize * i) as i32),
            style,
        ))
        .map_err(|e| err(&e))?;
    }
    let panels = body.split_evenly((if with_temperature { 5 } else { 4 }, 1));
    let specs: [(&str, &[Track], Option<&Track>); 4] = [
        ("Ω, truth (rad/s)", &tracks.motion, None),
        (
            "Ω error (rad/s)",
            &tracks.error[0..3],
            Some(&tracks.band[0]),
        ),
        (
            "Ω' error (rad/s²)",
            &tracks.error[3..6],
            Some(&tracks.band[1]),
        ),
        (
            "σ0 error (m/s²)",
            &tracks.error[6..9],
            Some(&tracks.band[2]),
        ),
    ];
    for (area, (title, series, band)) in panels.iter().zip(specs) {
        let v = match band {
            None => around(series),
            Some(b) => symmetric(series, b),
        };
        let mut chart = panel(area, title, span, v).map_err(|e| err(&e))?;
        let dt = (span.1 - span.0) / PLOT_W as f64;
        if let Some(b) = band {
            let cells = b.iter().enumerate().filter_map(|(x, c)| c.map(|c| (x, c)));
            chart
                .draw_series(cells.map(|(x, c)| {
                    let t = column_t(span, x);
                    let h = c.hi.min(v.1);
                    Rectangle::new([(t - 0.5 * dt, -h), (t + 0.5 * dt, h)], BAND.filled())
                }))
                .map_err(|e| err(&e))?;
            let strip = 0.03 * (v.1 - v.0);
            let marks = tracks.flagged.iter().enumerate().filter(|(_, f)| **f);
            chart
                .draw_series(marks.map(|(x, _)| {
                    let t = column_t(span, x);
                    Rectangle::new(
                        [(t - 0.5 * dt, v.0), (t + 0.5 * dt, v.0 + strip)],
                        FLAGGED.filled(),
                    )
                }))
                .map_err(|e| err(&e))?;
        }
        for (s, colour) in series.iter().zip(AXIS) {
            // Partly transparent: where the axes' envelopes overlap (a fast motion over a long
            // record), each shows through.
            chart
                .draw_series(LineSeries::new(envelope(s, span, v), colour.mix(0.6)))
                .map_err(|e| err(&e))?;
        }
    }
    if let Some(area) = panels.get(4) {
        let series: Vec<Track> = tracks.temperature.iter().map(|(_, t)| t.clone()).collect();
        let v = around(&series);
        let names: Vec<&str> = tracks.temperature.iter().map(|(n, _)| n.as_str()).collect();
        let title = format!("part temperature (°C): {}", names.join(", "));
        let mut chart = panel(area, &title, span, v).map_err(|e| err(&e))?;
        for (i, s) in series.iter().enumerate() {
            chart
                .draw_series(LineSeries::new(
                    envelope(s, span, v),
                    PARTS[i % PARTS.len()],
                ))
                .map_err(|e| err(&e))?;
        }
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// Height of one heading line, and of one panel added to the plot's height.
const HEADING_LINE: u32 = 24;
const PANEL_H: u32 = 280;

type Panel<'a> = ChartContext<
    'a,
    BitMapBackend<'a>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A panel's chart: its caption, the time axis and the value range `v`.
fn panel<'a>(
    area: &DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>,
    title: &str,
    span: (f64, f64),
    v: (f64, f64),
) -> Result<Panel<'a>, String> {
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 18))
        .margin(8)
        .margin_right(24)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(span.0..span.1, v.0..v.1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc("t (s)")
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 14))
        .draw()
        .map_err(|e| e.to_string())?;
    Ok(chart)
}

/// Through every pixel column of `s`: its first value, its range, its last value (so that a
/// record of any length draws its envelope, not a block of every sample).
fn envelope(s: &Track, span: (f64, f64), v: (f64, f64)) -> Vec<(f64, f64)> {
    s.iter()
        .enumerate()
        .flat_map(|(x, c)| {
            let t = column_t(span, x);
            c.map(|c| [c.first, c.lo, c.hi, c.last].map(|y| (t, y.clamp(v.0, v.1))))
                .into_iter()
                .flatten()
        })
        .collect()
}

/// The range of the series, with a margin.
fn around(series: &[Track]) -> (f64, f64) {
    let mut v = (f64::INFINITY, f64::NEG_INFINITY);
    for c in series.iter().flatten().flatten() {
        v = (v.0.min(c.lo), v.1.max(c.hi));
    }
    if !v.0.is_finite() {
        v = (-1.0, 1.0);
    }
    let pad = (v.1 - v.0).max(1e-3 * v.0.abs().max(v.1.abs())).max(1e-9);
    (v.0 - 0.15 * pad, v.1 + 0.15 * pad)
}

/// Symmetric about zero: the larger of the 98th percentile (over pixel columns) of the largest
/// error and the median of the band, with a margin; rarer excursions, and a band that widens
/// where the estimate is ill-conditioned, are clipped at the edge.
fn symmetric(series: &[Track], band: &Track) -> (f64, f64) {
    let quantile = |mut v: Vec<f64>, q: f64| {
        if v.is_empty() {
            return 0.0;
        }
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * q).round() as usize]
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
    let m = quantile(errs, 0.98).max(quantile(bands, 0.5));
    let m = if m.is_finite() && m > 0.0 {
        1.2 * m
    } else {
        1.0
    };
    (-m, m)
}
