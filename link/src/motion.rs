//! The motion report, TM[3,25] SID 1: one estimate and what it was computed from.

use estimator_core::linalg::Sym3;
use estimator_core::{Estimate, Flags};

use crate::codec::{Get, Put};
use crate::ids::sid;
use crate::masks::{ChannelSet, PartSet};
use crate::mode::{Mode, ModelCode};

/// The motion report (TM[3,25], SID 1): one estimate and what it was computed from.
#[derive(Clone, Copy, Debug)]
pub struct MotionReport {
    /// Sample set index.
    pub k: u32,
    /// The estimate (every field the estimates file has).
    pub estimate: Estimate<f32>,
    /// Parts without a value in this set.
    pub missing_parts: PartSet,
    /// Parts excluded automatically.
    pub excluded_parts: PartSet,
    /// Channels not in the solve, commanded or automatic.
    pub excluded_channels: ChannelSet,
    /// The mode and the model the estimate was made in (`None` when decoded from a layout
    /// before telemetry format 2).
    pub context: Option<(Mode, ModelCode)>,
}

/// Application data length of the motion report.
pub const MOTION_LEN: usize = 160;

/// Application data length of the motion report before the protection levels were added
/// (telemetry format 2): decoded with the levels absent.
pub const MOTION_LEN_NO_PROTECTION: usize = 148;

/// Application data length of the motion report before the mode and model were added
/// (telemetry format 1, from issue 15): decoded with [`MotionReport::context`] `None`.
pub const MOTION_LEN_NO_CONTEXT: usize = 146;

/// Application data length of the motion report before the branch margin was added (firmware
/// 0.x up to issue 15): decoded with the margin absent (NaN; an empty cell in the estimates
/// file).
pub const MOTION_LEN_NO_MARGIN: usize = 142;

impl MotionReport {
    /// Encodes the application data; returns its length ([`MOTION_LEN`]), or `None` if it does
    /// not fit or the report has no context (mode and model).
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let e = &self.estimate;
        let mut p = Put::new(out);
        p.u16(sid::MOTION)
            .u32(self.k)
            .f32s(&e.sigma0)
            .f32s(&e.domega)
            .f32s(&e.omega)
            .f32s(&e.field.0)
            .u16(e.flags.0)
            .f32(e.chi2)
            .u8(e.dof)
            .u8(e.branches)
            .u8(e.frame)
            .u8(e.epsilon as u8)
            .f32s(&e.sd_sigma0)
            .f32s(&e.sd_domega)
            .f32s(&e.sd_omega)
            .f32s(&e.sd_field.0)
            .u8(self.missing_parts.0)
            .u8(self.excluded_parts.0)
            .u32(self.excluded_channels.0)
            .f32(e.branch_margin);
        // Only the decoder of an old layout leaves the context out; such a report is not sent.
        let (mode, model) = self.context?;
        p.u8(mode as u8).u8(model as u8);
        // No bound: NaN, as an absent branch margin.
        p.f32s(&e.protection.unwrap_or([f32::NAN; 3]));
        p.finish()
    }

    /// Decodes the application data after the SID and `k`, of length `len` (one of
    /// [`MOTION_LEN`], [`MOTION_LEN_NO_PROTECTION`], [`MOTION_LEN_NO_CONTEXT`],
    /// [`MOTION_LEN_NO_MARGIN`]: the older layouts lack the fields added at their end).
    #[cfg_attr(not(feature = "ground"), allow(dead_code))]
    pub(crate) fn decode(g: &mut Get, len: usize) -> Option<Self> {
        let mut e = Estimate::<f32> {
            sigma0: g.f32s()?,
            domega: g.f32s()?,
            omega: g.f32s()?,
            field: Sym3(g.f32s()?),
            flags: Flags(g.u16()?),
            chi2: g.f32()?,
            dof: g.u8()?,
            branches: g.u8()?,
            frame: g.u8()?,
            ..Estimate::default()
        };
        e.epsilon = g.u8()? as i8;
        e.sd_sigma0 = g.f32s()?;
        e.sd_domega = g.f32s()?;
        e.sd_omega = g.f32s()?;
        e.sd_field = Sym3(g.f32s()?);
        let mut m = MotionReport {
            k: 0,
            estimate: e,
            missing_parts: PartSet(g.u8()?),
            excluded_parts: PartSet(g.u8()?),
            excluded_channels: ChannelSet(g.u32()?),
            context: None,
        };
        m.estimate.branch_margin = if len > MOTION_LEN_NO_MARGIN {
            g.f32()?
        } else {
            f32::NAN
        };
        if len >= MOTION_LEN_NO_PROTECTION {
            let mode = Mode::try_from(g.u8()?).ok()?;
            let model = ModelCode::try_from(g.u8()?).ok()?;
            m.context = Some((mode, model));
        }
        if len == MOTION_LEN {
            let pl: [f32; 3] = g.f32s()?;
            m.estimate.protection = pl.iter().all(|v| v.is_finite()).then_some(pl);
        }
        Some(m)
    }
}
