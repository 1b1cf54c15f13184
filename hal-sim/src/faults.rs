//! Faults scheduled in time. Measurement faults act inside a part (what it measures);
//! connection faults act on its bus slot (what the controller sees on the wires). Either way
//! the firmware notices them only through the bus, never by a back door.

/// What goes wrong.
#[derive(Clone, Debug, PartialEq)]
pub enum FaultKind {
    /// The output freezes at its value when the fault starts (samples keep coming).
    Stuck,
    /// A bias step (m/s², part axes) added to the output.
    BiasJump {
        /// The added bias per axis.
        bias: [f64; 3],
    },
    /// A bias that grows from zero at the fault's start at this rate (m/s² per s, part
    /// axes): a part that drifts (temperature, ageing), too slow for one sample to show.
    Drift {
        /// The bias's growth per axis, m/s² per s.
        rate: [f64; 3],
    },
    /// Extra white noise of this density (m/s²/√Hz).
    NoiseBurst {
        /// Noise density.
        density: f64,
    },
    /// The output is pinned at positive full scale on every axis (over-range shock).
    Saturation,
    /// The part does not answer: MISO stuck high (SPI reads 0xFF) or no acknowledge (I²C).
    Dead,
    /// Each byte the controller reads has one random bit flipped with this probability.
    Corrupt {
        /// Probability per byte (0..=1).
        probability: f64,
    },
    /// Every transaction stalls this long (s) and fails with a timeout.
    Timeout {
        /// Stall before the controller gives up.
        stall: f64,
    },
}

impl FaultKind {
    /// Whether the fault acts on the bus connection rather than on the measurement.
    pub fn on_bus(&self) -> bool {
        matches!(
            self,
            FaultKind::Dead | FaultKind::Corrupt { .. } | FaultKind::Timeout { .. }
        )
    }

    /// The name used in scenario files.
    pub fn name(&self) -> &'static str {
        match self {
            FaultKind::Stuck => "stuck",
            FaultKind::BiasJump { .. } => "bias-jump",
            FaultKind::Drift { .. } => "drift",
            FaultKind::NoiseBurst { .. } => "noise-burst",
            FaultKind::Saturation => "saturation",
            FaultKind::Dead => "dead",
            FaultKind::Corrupt { .. } => "corrupt",
            FaultKind::Timeout { .. } => "timeout",
        }
    }
}

/// A fault active for `start ≤ t < end` (simulated seconds).
#[derive(Clone, Debug, PartialEq)]
pub struct Fault {
    /// Start time, s.
    pub start: f64,
    /// End time, s (`f64::INFINITY`: to the end of the run).
    pub end: f64,
    /// What goes wrong.
    pub kind: FaultKind,
}

impl Fault {
    /// Whether the fault is active at `t`.
    pub fn active(&self, t: f64) -> bool {
        self.start <= t && t < self.end
    }
}

/// The faults active at `t`.
pub fn active_at(faults: &[Fault], t: f64) -> impl Iterator<Item = &FaultKind> {
    faults.iter().filter(move |f| f.active(t)).map(|f| &f.kind)
}
