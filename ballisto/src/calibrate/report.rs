//! The calibration report for people: Markdown (what was identified, from what, with which
//! deviations, what was held) and a PNG of the residuals before and after.

use std::error::Error;
use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::fit::PARAMETERS;
use super::{CalibrateJob, CalibrationSummary};
use estimator_core::identify::Param;

const WIDTH: u32 = 1200;
const HEIGHT: u32 = 900;
const BEFORE: RGBColor = RGBColor(220, 60, 30);
const AFTER: RGBColor = RGBColor(20, 60, 200);

/// The report for people: per channel the change from nominal, the standard deviations and
/// the residual before and after.
pub fn markdown(s: &CalibrationSummary, job: &CalibrateJob, png: Option<&str>) -> String {
    let mut r = format!(
        "# Calibration of {}\n\nRecord {}: {} static poses, {}; Ω from {}; {} alternations.\n\n",
        job.arrangement.display(),
        job.samples.display(),
        s.poses,
        s.motion_described(),
        match job.reference {
            Some(p) => format!("the reference {}", p.display()),
            None => "the estimator (self-calibration)".into(),
        },
        s.identification.iterations
    );
    match &s.validation {
        Ok(v) => r.push_str(&format!("- Validation: {}.\n", v.describe())),
        Err(why) => r.push_str(&format!("- Not validated: {why}.\n")),
    }
    if let Some(d) = &s.reference_dropped {
        r.push_str(&format!("- Reference: {d}.\n"));
    }
    if let Some(f) = &s.reference_found {
        r.push_str(&format!("- {}.\n", capitalised(&f.describe())));
    }
    for w in &s.warnings {
        r.push_str(&format!("- **Warning**: {w}.\n"));
    }
    for c in &s.identification.conventions {
        r.push_str(&format!("- Held by convention: {c}.\n"));
    }
    if let Some(k) = &s.identification.kinematic {
        r.push_str(&format!("- Self-calibration: {}.\n", k.describe()));
    }
    let f = &s.identification.frame;
    r.push_str(&format!(
        "- The frame's uncertainty (what no channel's own parameters carry; added to every estimate's deviations): rotation {:.3e} rad, translation {:.3e} m, size {:.3e}, axes against lever arms {:.3e} rad.\n",
        f.rotation, f.translation, f.size, f.relative_rotation
    ));
    if let Some(png) = png {
        r.push_str(&format!(
            "\n![Residuals with the nominal and with the identified geometry]({png})\n"
        ));
    }
    r.push_str("\nEach identified parameter ± its standard deviation (the data's, each channel's motion samples and pose means weighed by their measured scatter); \"held\" where the record does not determine it.\n");
    r.push_str("\n| channel | scale | axis tilt sd (mrad) | bias (m/s²) | position (mm) | residual RMS before → after (m/s²) | not identified |\n|---|---|---|---|---|---|---|\n");
    for (name, c) in s.names.iter().zip(s.identification.channels.iter()) {
        let g = &c.geometry;
        let pm = |j: usize| {
            if c.sd[j].is_finite() {
                format!(" ± {:.2e}", c.sd[j])
            } else {
                " (held)".into()
            }
        };
        let mm = |j: usize| {
            if c.sd[j].is_finite() {
                format!("{:.2}", c.sd[j] * 1e3)
            } else {
                "held".into()
            }
        };
        let tilt = if c.sd[1].is_finite() && c.sd[2].is_finite() {
            format!("{:.2}, {:.2}", c.sd[1] * 1e3, c.sd[2] * 1e3)
        } else {
            "held".into()
        };
        r.push_str(&format!(
            "| {name} | {:.5}{} | {tilt} | {:.4}{} | {:.2}, {:.2}, {:.2} ± {}, {}, {} | {:.3e} → {:.3e} | {} |\n",
            g.scale,
            pm(Param::Scale as usize),
            g.bias,
            pm(Param::Bias as usize),
            g.position.x * 1e3,
            g.position.y * 1e3,
            g.position.z * 1e3,
            mm(Param::PositionX as usize),
            mm(Param::PositionY as usize),
            mm(Param::PositionZ as usize),
            c.residual_rms.0,
            c.residual_rms.1,
            c.held.join("; ")
        ));
    }
    r.push_str(&format!("\nParameters: {}.\n", PARAMETERS.join(", ")));
    r
}

/// The PNG: per sample, the RMS over the channels of the residual with the nominal and with
/// the identified geometry (in a pose, of the pose's mean); per channel, its RMS residual
/// before and after against its noise (black tick). Logarithmic scales.
pub fn residual_png(
    s: &CalibrationSummary,
    times: &[f64],
    png: &Path,
) -> Result<(), Box<dyn Error>> {
    crate::plot::font()?;
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", png.display());
    let (before, after) = &s.identification.residuals;
    let series = |r: &super::fit::Residuals| -> Vec<(f64, f64)> {
        r.per_sample
            .iter()
            .filter(|(k, v)| *k < times.len() && *v > 0.0 && v.is_finite())
            .map(|(k, v)| (times[*k], *v))
            .collect()
    };
    let (b, a) = (series(before), series(after));
    let channels = &s.identification.channels;
    let noise: Vec<f64> = channels.iter().map(|c| c.geometry.noise).collect();
    let values = b
        .iter()
        .chain(a.iter())
        .map(|p| p.1)
        .chain(
            channels
                .iter()
                .flat_map(|c| [c.residual_rms.0, c.residual_rms.1]),
        )
        .chain(noise.iter().copied())
        .filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
        (l.min(v), h.max(v))
    });
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo / 1.5, hi * 1.5)
    } else {
        (1e-4, 1.0)
    };
    let t_span = match (times.first(), times.last()) {
        (Some(t0), Some(t1)) if t1 > t0 => (*t0, *t1),
        _ => (0.0, 1.0),
    };
    let root = BitMapBackend::new(png, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(
            "residuals: red with the nominal geometry, blue with the identified one",
            (crate::plot::FONT, 20),
        )
        .map_err(|e| err(&e))?;
    let (top, bottom) = root.split_vertically(HEIGHT / 2);
    let mut chart = ChartBuilder::on(&top)
        .caption(
            "RMS over the channels per sample (m/s²; in a static pose: of the pose's mean)",
            (crate::plot::FONT, 16),
        )
        .margin(8)
        .margin_right(24)
        .x_label_area_size(36)
        .y_label_area_size(70)
        .build_cartesian_2d(t_span.0..t_span.1, (lo..hi).log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .x_desc("t (s)")
        .label_style((crate::plot::FONT, 14))
        .axis_desc_style((crate::plot::FONT, 14))
        .draw()
        .map_err(|e| err(&e))?;
    for (points, colour) in [(&b, BEFORE), (&a, AFTER)] {
        chart
            .draw_series(points.iter().map(|p| Pixel::new(*p, colour)))
            .map_err(|e| err(&e))?;
    }
    let n = channels.len().max(1);
    let names = &s.names;
    let mut chart = ChartBuilder::on(&bottom)
        .caption(
            "RMS residual per channel (m/s²): before, after; black: its noise",
            (crate::plot::FONT, 16),
        )
        .margin(8)
        .margin_right(24)
        .x_label_area_size(60)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..n as f64, (lo..hi).log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .light_line_style(WHITE)
        .disable_x_mesh()
        .x_labels(0)
        .label_style((crate::plot::FONT, 12))
        .draw()
        .map_err(|e| err(&e))?;
    // Every channel's name under the middle of its bars (the axis's own labels fall on round
    // numbers and drop those that would overlap): upright while the names fit side by side
    // (about 7 px per character at 12 px), else turned to read upwards.
    let longest = names.iter().map(|n| n.chars().count()).max().unwrap_or(1) as i32;
    let (left, _) = chart.backend_coord(&(0.0, lo));
    let (right, _) = chart.backend_coord(&(n as f64, lo));
    let upright = 7 * longest + 4 <= (right - left) / n as i32;
    // The chart gives the backend's pixels; the area draws in its own.
    let base = bottom.get_base_pixel();
    for (i, name) in names.iter().enumerate() {
        let (x, y) = chart.backend_coord(&(i as f64 + 0.5, lo));
        let (x, y) = (x - base.0, y - base.1);
        let (style, at) = if upright {
            let style = TextStyle::from((crate::plot::FONT, 12).into_font())
                .pos(Pos::new(HPos::Center, VPos::Top));
            (style, (x, y + 6))
        } else {
            let style = TextStyle::from((crate::plot::FONT, 12).into_font())
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Right, VPos::Center));
            (style, (x, y + 6))
        };
        bottom
            .draw(&Text::new(name.clone(), at, style))
            .map_err(|e| err(&e))?;
    }
    for (i, c) in channels.iter().enumerate() {
        let x = i as f64;
        for (v, colour, offset) in [
            (c.residual_rms.0, BEFORE, 0.1),
            (c.residual_rms.1, AFTER, 0.5),
        ] {
            if v.is_finite() && v > 0.0 {
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x + offset, lo), (x + offset + 0.35, v)],
                        colour.filled(),
                    )))
                    .map_err(|e| err(&e))?;
            }
        }
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x + 0.05, noise[i]), (x + 0.95, noise[i])],
                BLACK.stroke_width(2),
            )))
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// `text` with its first letter upper case.
fn capitalised(text: &str) -> String {
    let mut c = text.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}
