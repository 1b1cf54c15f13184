//! A scenario's faults: the `[[faults]]` table and the simulator's fault it describes.

use super::*;

/// A fault of one part.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultSpec {
    /// The part.
    pub part: String,
    /// "stuck", "bias-jump", "drift", "noise-burst", "saturation", "dead", "corrupt" or
    /// "timeout".
    pub kind: String,
    /// Start (s).
    pub start: f64,
    /// End (s); default: to the end of the run.
    #[serde(default)]
    pub end: Option<f64>,
    /// bias-jump: m/s² per part axis.
    #[serde(default)]
    pub bias: Option<[f64; 3]>,
    /// drift: the bias's growth, m/s² per s per part axis.
    #[serde(default)]
    pub rate: Option<[f64; 3]>,
    /// noise-burst: m/s²/√Hz.
    #[serde(default)]
    pub density: Option<f64>,
    /// corrupt: probability per byte read.
    #[serde(default)]
    pub probability: Option<f64>,
    /// timeout: stall per transaction (s).
    #[serde(default)]
    pub stall: Option<f64>,
}

impl Scenario {
    /// The fault of a spec.
    pub fn fault(&self, f: &FaultSpec) -> Result<Fault, String> {
        if !self.parts.iter().any(|p| p.name == f.part) {
            return Err("no such part".into());
        }
        let end = f.end.unwrap_or(f64::INFINITY);
        if !(f.start.is_finite() && end > f.start) {
            return Err("needs a finite start before its end".into());
        }
        let need = |v: Option<f64>, name: &str| -> Result<f64, String> {
            match v {
                Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
                Some(_) => Err(format!("{name} must be finite and >= 0")),
                None => Err(format!("kind = \"{}\" needs {name}", f.kind)),
            }
        };
        let given = [
            ("bias", f.bias.is_some()),
            ("rate", f.rate.is_some()),
            ("density", f.density.is_some()),
            ("probability", f.probability.is_some()),
            ("stall", f.stall.is_some()),
        ];
        let kind = match f.kind.as_str() {
            "stuck" => FaultKind::Stuck,
            "saturation" => FaultKind::Saturation,
            "dead" => FaultKind::Dead,
            "bias-jump" => match f.bias {
                Some(b) if finite(&b) => FaultKind::BiasJump { bias: b },
                _ => return Err("kind = \"bias-jump\" needs a finite bias = [x, y, z]".into()),
            },
            "drift" => match f.rate {
                Some(r) if finite(&r) => FaultKind::Drift { rate: r },
                _ => return Err("kind = \"drift\" needs a finite rate = [x, y, z] (m/s² per s)".into()),
            },
            "noise-burst" => FaultKind::NoiseBurst {
                density: need(f.density, "density")?,
            },
            "corrupt" => {
                let p = need(f.probability, "probability")?;
                if p > 1.0 {
                    return Err("probability must be <= 1".into());
                }
                FaultKind::Corrupt { probability: p }
            }
            "timeout" => FaultKind::Timeout {
                stall: need(f.stall, "stall")?,
            },
            k => {
                return Err(format!(
                "kind = \"{k}\": expected stuck, bias-jump, drift, noise-burst, saturation, dead, corrupt or timeout"
            ))
            }
        };
        let wanted = match kind {
            FaultKind::BiasJump { .. } => Some("bias"),
            FaultKind::Drift { .. } => Some("rate"),
            FaultKind::NoiseBurst { .. } => Some("density"),
            FaultKind::Corrupt { .. } => Some("probability"),
            FaultKind::Timeout { .. } => Some("stall"),
            _ => None,
        };
        if let Some((extra, _)) = given
            .iter()
            .find(|(name, set)| *set && Some(*name) != wanted)
        {
            return Err(format!("{extra} does not apply to kind = \"{}\"", f.kind));
        }
        Ok(Fault {
            start: f.start,
            end,
            kind,
        })
    }

    /// The faults of the part `name`.
    pub fn faults_of(&self, name: &str) -> Vec<Fault> {
        self.faults
            .iter()
            .filter(|f| f.part == name)
            .filter_map(|f| self.fault(f).ok())
            .collect()
    }
}
