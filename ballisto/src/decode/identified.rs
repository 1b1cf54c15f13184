//! The identification solution a stream carries, as an arrangement file.

use std::fmt::Write as _;
use std::path::Path;

use ballisto_link::decode::Report;

use super::Stream;

/// The last identification solution in a decoded stream (TM\[200,128\] and its N × TM\[200,129\])
/// as an arrangement file (docs/formats.md) over the channel names of the nominal `arrangement`
/// file: positions, axes, bias and scale with the deviations of what the window determined
/// (a held parameter gets no `*_sd` key: not identified, kept at the value in use), the frame's
/// uncertainty, and a header saying where it came from. Errors: no solution in the stream, a
/// channel report missing, or another channel count than the nominal file's.
pub fn identified_arrangement(
    stream: &Stream,
    source: &Path,
    arrangement: &Path,
) -> Result<String, String> {
    use ballisto_config::arrangement_file::ArrangementFile;
    use ballisto_link::identification::IdentifiedChannel;
    let summary = stream
        .packets
        .iter()
        .rev()
        .find_map(|p| match &p.report {
            Report::IdentificationSummary(s) => Some(*s),
            _ => None,
        })
        .ok_or_else(|| {
            format!(
                "{}: no identification solution (TM[200,128])",
                source.display()
            )
        })?;
    let mut channels: Vec<Option<IdentifiedChannel>> = vec![None; usize::from(summary.channels)];
    for p in &stream.packets {
        if let Report::IdentifiedChannel(c) = &p.report {
            if c.solution == summary.solution {
                if let Some(slot) = channels.get_mut(usize::from(c.channel)) {
                    *slot = Some(*c);
                }
            }
        }
    }
    let nominal = ArrangementFile::read(arrangement).map_err(|e| e.to_string())?;
    let specs = nominal
        .expanded_channels(&arrangement.display().to_string())
        .map_err(|e| e.to_string())?;
    if specs.len() != channels.len() {
        return Err(format!(
            "{}: {} channels, the solution has {}",
            arrangement.display(),
            specs.len(),
            channels.len()
        ));
    }
    let mut out = Vec::with_capacity(specs.len());
    for (i, (spec, c)) in specs.iter().zip(channels.iter()).enumerate() {
        let c = c.ok_or_else(|| {
            format!(
                "{}: solution {}: no report of channel {i} (TM[200,129])",
                source.display(),
                summary.solution
            )
        })?;
        let fit = estimator_core::identify::ChannelFit {
            channel: estimator_core::Channel {
                position: c.position.map(f64::from),
                axis: c.axis.map(f64::from),
                noise: f64::from(c.noise),
                bias: f64::from(c.bias),
                scale: f64::from(c.scale),
            },
            sd: c.sd.map(f64::from),
            held: c.held,
            residual_rms: f64::from(c.residual_rms),
        };
        out.push(crate::calibrate::identified_channel(
            &spec.name, spec.range, &fit,
        ));
    }
    let file = ArrangementFile {
        model: nominal.model.clone(),
        frame_rotation_sd: Some(f64::from(summary.frame[0])),
        frame_translation_sd: Some(f64::from(summary.frame[1])),
        frame_size_sd: Some(f64::from(summary.frame[2])),
        frame_relative_rotation_sd: Some(f64::from(summary.frame[0])),
        channels: out,
        sensors: Vec::new(),
    };
    let mut header = format!(
        "# Identified in flight (paper §6): solution {} decoded from {}, {} sample sets, {} reference points; nominal geometry {}.\n",
        summary.solution,
        source.display(),
        summary.sets,
        summary.points,
        arrangement.display()
    );
    let (r, sd) = (summary.rho, summary.rho_sd);
    let _ = writeln!(
        header,
        "# rho = [{:.6}, {:.6}, {:.6}] m, sd [{:.2e}, {:.2e}, {:.2e}] m: {}.\n# The scale is held in free fall (one product with the lever arm).",
        r[0], r[1], r[2], sd[0], sd[1], sd[2], crate::com::RHO_MEANING
    );
    header.push_str("# A missing *_sd key means that parameter was not identified.\n");
    Ok(header + &file.to_toml())
}
