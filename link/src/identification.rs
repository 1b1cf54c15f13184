//! Identification in flight (paper §6): the reference-rate points of TC[200,9], the
//! summary TM[200,128] and one TM[200,129] per channel of a solution.

use crate::codec::{Get, Put};
use crate::cuc::{cuc_nanos, TIME_LEN};

/// Octets per reference point in TC[200,9]: time (CUC 4+3 with its P-field), Ω (3 × f32).
pub const POINT_LEN: usize = TIME_LEN + 12;
/// Most reference points in one TC[200,9].
pub const MAX_POINTS: usize = 16;
/// Largest reference rate component accepted, rad/s.
pub const REFERENCE_MAX: f32 = 50.0;
/// Largest reference period TC[200,8] accepts, ms.
pub const PERIOD_MAX_MS: u16 = 1000;
/// Longest window TC[200,8] accepts, ms (one hour).
pub const WINDOW_MAX_MS: u32 = 3_600_000;

/// Source of the field in TC[200,8]: a reference rate on the bus (TC[200,9]).
pub const SOURCE_REFERENCE: u8 = 1;
/// Source of the field in TC[200,8]: the estimator itself in a torque-free tumble, the body's
/// inertia given (six f32 after the window: xx, yy, zz, xy, xz, yz).
pub const SOURCE_TUMBLE: u8 = 2;

/// One reference point: on-board time (ns since boot) and Ω (rad/s, body frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferencePoint {
    /// Nanoseconds since boot.
    pub t: u64,
    /// Ω, rad/s.
    pub omega: [f32; 3],
}

impl ReferencePoint {
    /// The point as TC[200,9] carries it (the inverse of [`points`], to the CUC resolution).
    pub fn encode(&self) -> [u8; POINT_LEN] {
        let mut out = [0u8; POINT_LEN];
        out[..TIME_LEN].copy_from_slice(&crate::cuc::cuc(self.t));
        Put::new(&mut out[TIME_LEN..]).f32s(&self.omega);
        out
    }
}

/// The application data of TC[200,9] carrying `points` (u8 n, then each [`ReferencePoint::encode`]d)
/// into `out`; `None` if `out` is too small or there are more than 255 points ([`MAX_POINTS`]
/// is what the unit accepts: acceptance says so, not the encoder).
pub fn points_data(points: &[ReferencePoint], out: &mut [u8]) -> Option<usize> {
    let mut p = Put::new(out);
    p.u8(u8::try_from(points.len()).ok()?);
    for point in points {
        p.bytes(&point.encode());
    }
    p.finish()
}

/// The points of TC[200,9] application data, already checked by acceptance (u8 n, then n ×
/// [`POINT_LEN`]); stops at the first that does not read.
pub fn points(data: &[u8]) -> impl Iterator<Item = ReferencePoint> + '_ {
    let n = data.first().map_or(0, |n| usize::from(*n));
    let mut g = Get::new(data.get(1..).unwrap_or(&[]));
    (0..n).map_while(move |_| {
        let t = cuc_nanos(&g.array::<TIME_LEN>()?)?;
        let omega = g.f32s::<3>()?;
        Some(ReferencePoint { t, omega })
    })
}

/// Application data of TM[200,128], the summary of a solution.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IdentificationSummary {
    /// The solution's number (it names the solution TC[200,11] commits).
    pub solution: u16,
    /// Channels (one TM[200,129] follows per channel).
    pub channels: u8,
    /// Sample sets in the sums.
    pub sets: u32,
    /// Sets the reference did not cover (before its first points, across a gap, or left when
    /// the window closed).
    pub not_covered: u32,
    /// Sets with a reading missing (not usable: the sums are shared by all channels).
    pub incomplete: u32,
    /// Reference points taken.
    pub points: u32,
    /// Reference points that restarted the reference after a gap or a step back in time.
    pub restarts: u32,
    /// ρ of paper eq. 12, m: the instrument origin seen from the centre of mass (which is at
    /// −ρ from the origin; the sign `ballisto com` writes). Streams before telemetry format 4
    /// sent the centre of mass from the origin, −ρ: [`Self::decode`] turns it round
    /// ([`RHO_CONVENTION`]).
    pub rho: [f32; 3],
    /// Its standard deviation per axis, m.
    pub rho_sd: [f32; 3],
    /// The frame's uncertainty: rotation (rad), translation (m), size (relative).
    pub frame: [f32; 3],
}

/// Application data length of TM[200,128].
pub const SUMMARY_LEN: usize = 60;

/// Octet 3 of TM[200,128] since telemetry format 4: the vector at octet 24 is ρ of paper eq. 12
/// (the origin from the centre of mass). It was a spare 0 before, when that vector was the
/// centre of mass from the origin (−ρ).
pub const RHO_CONVENTION: u8 = 1;

impl IdentificationSummary {
    /// Encodes the application data.
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let mut p = Put::new(out);
        p.u16(self.solution)
            .u8(self.channels)
            .u8(RHO_CONVENTION)
            .u32(self.sets)
            .u32(self.not_covered)
            .u32(self.incomplete)
            .u32(self.points)
            .u32(self.restarts)
            .f32s(&self.rho)
            .f32s(&self.rho_sd)
            .f32s(&self.frame);
        p.finish()
    }

    /// Decodes the application data (exactly [`SUMMARY_LEN`] octets).
    pub fn decode(data: &[u8]) -> Option<Self> {
        if data.len() != SUMMARY_LEN {
            return None;
        }
        let mut g = Get::new(data);
        let solution = g.u16()?;
        let channels = g.u8()?;
        // Format ≤ 3 (octet 0) sent −ρ.
        let sign = if g.u8()? == RHO_CONVENTION { 1.0 } else { -1.0 };
        Some(IdentificationSummary {
            solution,
            channels,
            sets: g.u32()?,
            not_covered: g.u32()?,
            incomplete: g.u32()?,
            points: g.u32()?,
            restarts: g.u32()?,
            rho: g.f32s::<3>()?.map(|v| sign * v),
            rho_sd: g.f32s()?,
            frame: g.f32s()?,
        })
    }
}

/// Application data of TM[200,129]: one channel of a solution.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IdentifiedChannel {
    /// The solution's number.
    pub solution: u16,
    /// The channel.
    pub channel: u8,
    /// Parameters held at their previous value (bit 0 scale, 1 tilt a, 2 tilt b, 3–5
    /// position x–z, 6 bias): what the window did not determine to half the tolerance; the
    /// scale is always held (in free fall it is one product with the lever arm).
    pub held: u8,
    /// Position, m.
    pub position: [f32; 3],
    /// Unit axis.
    pub axis: [f32; 3],
    /// Bias, m/s².
    pub bias: f32,
    /// Scale.
    pub scale: f32,
    /// Standard deviations: scale, tilt a, tilt b (rad), position x, y, z (m), bias (m/s²);
    /// a held parameter's is its tolerance.
    pub sd: [f32; 7],
    /// RMS of the channel's residual over the window, m/s².
    pub residual_rms: f32,
    /// The channel's declared noise, m/s² (the residual's expectation).
    pub noise: f32,
}

/// Application data length of TM[200,129].
pub const CHANNEL_LEN: usize = 72;

impl IdentifiedChannel {
    /// Encodes the application data.
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let mut p = Put::new(out);
        p.u16(self.solution)
            .u8(self.channel)
            .u8(self.held)
            .f32s(&self.position)
            .f32s(&self.axis)
            .f32(self.bias)
            .f32(self.scale)
            .f32s(&self.sd)
            .f32(self.residual_rms)
            .f32(self.noise);
        p.finish()
    }

    /// Decodes the application data (exactly [`CHANNEL_LEN`] octets).
    pub fn decode(data: &[u8]) -> Option<Self> {
        if data.len() != CHANNEL_LEN {
            return None;
        }
        let mut g = Get::new(data);
        Some(IdentifiedChannel {
            solution: g.u16()?,
            channel: g.u8()?,
            held: g.u8()?,
            position: g.f32s()?,
            axis: g.f32s()?,
            bias: g.f32()?,
            scale: g.f32()?,
            sd: g.f32s()?,
            residual_rms: g.f32()?,
            noise: g.f32()?,
        })
    }
}

/// [`ThermalTrack::state`]: this solution's bias of the channel joined the track (its window's
/// parts had a temperature, the bias was determined and the residual within its limit).
pub const TRACK_ADDED: u8 = 1;
/// [`ThermalTrack::state`]: the track decides the channel (at least three windows over at
/// least 10 °C): a commit (TC[200,11]) stores its `t_ref`, `bias` and `bias_tc`.
pub const TRACK_DETERMINED: u8 = 2;

/// [`ThermalTrack::state`]: a window behind the line held a position component of the channel
/// while no scale coefficient is in use: the lever arm could not take up the scale's drift with
/// temperature, and the slope may carry part of it (up to the scale's coefficient × the
/// channel's mean specific force along its axis) beyond the deviation stated.
pub const TRACK_SCALE_DRIFT: u8 = 4;

/// Application data of TM[200,130]: one channel's bias against temperature across the windows
/// solved since boot, sent after a solution's channels. Reals NaN where there is no
/// line yet (fewer than two windows, or all at one temperature).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ThermalTrack {
    /// The solution after which it is sent.
    pub solution: u16,
    /// The channel.
    pub channel: u8,
    /// [`TRACK_ADDED`] | [`TRACK_DETERMINED`] | [`TRACK_SCALE_DRIFT`].
    pub state: u8,
    /// Windows in the track.
    pub windows: u16,
    /// This solution's window: the channel's part's mean temperature, °C (NaN: not read).
    pub window_temperature: f32,
    /// The span of the windows' temperatures, °C.
    pub span: f32,
    /// The temperature `bias` refers to, °C: the coefficients' in use, or the windows' mean.
    pub t_ref: f32,
    /// The bias at `t_ref`, m/s², and its standard deviation.
    pub bias: f32,
    /// Standard deviation of `bias`.
    pub bias_sd: f32,
    /// The bias's temperature coefficient, m/s² per °C (the one in use corrected by the
    /// track's slope).
    pub bias_tc: f32,
    /// Standard deviation of `bias_tc`.
    pub bias_tc_sd: f32,
    /// The windows' scatter about the line over their stated deviations (χ² per degree of
    /// freedom; the deviations above are scaled by its root where it exceeds 1).
    pub scatter: f32,
}

/// Application data length of TM[200,130].
pub const TRACK_LEN: usize = 38;

impl ThermalTrack {
    /// Encodes the application data.
    pub fn encode(&self, out: &mut [u8]) -> Option<usize> {
        let mut p = Put::new(out);
        p.u16(self.solution)
            .u8(self.channel)
            .u8(self.state)
            .u16(self.windows)
            .f32(self.window_temperature)
            .f32(self.span)
            .f32(self.t_ref)
            .f32(self.bias)
            .f32(self.bias_sd)
            .f32(self.bias_tc)
            .f32(self.bias_tc_sd)
            .f32(self.scatter);
        p.finish()
    }

    /// Decodes the application data (exactly [`TRACK_LEN`] octets).
    pub fn decode(data: &[u8]) -> Option<Self> {
        if data.len() != TRACK_LEN {
            return None;
        }
        let mut g = Get::new(data);
        Some(ThermalTrack {
            solution: g.u16()?,
            channel: g.u8()?,
            state: g.u8()?,
            windows: g.u16()?,
            window_temperature: g.f32()?,
            span: g.f32()?,
            t_ref: g.f32()?,
            bias: g.f32()?,
            bias_sd: g.f32()?,
            bias_tc: g.f32()?,
            bias_tc_sd: g.f32()?,
            scatter: g.f32()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cuc::cuc;

    #[test]
    fn reports_round_trip() {
        let s = IdentificationSummary {
            solution: 3,
            channels: 12,
            sets: 4000,
            not_covered: 7,
            incomplete: 1,
            points: 400,
            restarts: 2,
            rho: [0.02, -0.01, 0.03],
            rho_sd: [1e-4, 2e-4, 3e-4],
            frame: [1e-4, 3e-4, 1e-3],
        };
        let mut b = [0u8; 80];
        assert_eq!(s.encode(&mut b), Some(SUMMARY_LEN));
        assert_eq!(IdentificationSummary::decode(&b[..SUMMARY_LEN]), Some(s));
        // A format-3 summary (octet 3 spare, 0) carried the centre of mass from the origin:
        // read as ρ, turned round.
        assert_eq!(b[3], RHO_CONVENTION);
        b[3] = 0;
        let old = IdentificationSummary::decode(&b[..SUMMARY_LEN]).unwrap();
        assert_eq!(old.rho, s.rho.map(|v| -v));
        assert_eq!(old.rho_sd, s.rho_sd);
        let c = IdentifiedChannel {
            solution: 3,
            channel: 11,
            held: 0b1000001,
            position: [0.1, -0.2, 0.3],
            axis: [0.6, 0.0, 0.8],
            bias: 0.25,
            scale: 1.01,
            sd: [0.02, 1e-4, 2e-4, 1e-5, 2e-5, 3e-5, 1e-4],
            residual_rms: 1.5e-3,
            noise: 1.4e-3,
        };
        assert_eq!(c.encode(&mut b), Some(CHANNEL_LEN));
        assert_eq!(IdentifiedChannel::decode(&b[..CHANNEL_LEN]), Some(c));
        assert_eq!(IdentifiedChannel::decode(&b[..CHANNEL_LEN - 1]), None);
        let k = ThermalTrack {
            solution: 3,
            channel: 2,
            state: TRACK_ADDED | TRACK_DETERMINED,
            windows: 9,
            window_temperature: 31.5,
            span: 38.0,
            t_ref: 22.4,
            bias: 0.081,
            bias_sd: 1e-5,
            bias_tc: 1.2e-3,
            bias_tc_sd: 2e-6,
            scatter: f32::NAN,
        };
        assert_eq!(k.encode(&mut b), Some(TRACK_LEN));
        let back = ThermalTrack::decode(&b[..TRACK_LEN]).unwrap();
        assert!(back.scatter.is_nan());
        assert_eq!(
            ThermalTrack {
                scatter: 0.0,
                ..back
            },
            ThermalTrack { scatter: 0.0, ..k }
        );
        assert_eq!(ThermalTrack::decode(&b[..TRACK_LEN + 1]), None);
    }

    #[test]
    fn points_read_back_to_the_cuc_resolution() {
        let mut data = [0u8; 1 + 2 * POINT_LEN];
        data[0] = 2;
        for (i, t) in [1_500_000_000u64, 2_000_123_456].iter().enumerate() {
            let off = 1 + i * POINT_LEN;
            data[off..off + TIME_LEN].copy_from_slice(&cuc(*t));
            let mut p = Put::new(&mut data[off + TIME_LEN..off + POINT_LEN]);
            p.f32s(&[1.0, -2.0, 0.5 * i as f32]);
        }
        let got: [ReferencePoint; 2] = {
            let mut it = points(&data);
            [it.next().unwrap(), it.next().unwrap()]
        };
        assert_eq!(got[0].t, 1_500_000_000);
        // CUC fine resolution 2⁻²⁴ s ≈ 60 ns.
        assert!(got[1].t.abs_diff(2_000_123_456) <= 60);
        assert_eq!(got[1].omega, [1.0, -2.0, 0.5]);
        // The encoder writes what was read.
        for (i, p) in got.iter().enumerate() {
            let off = 1 + i * POINT_LEN;
            assert_eq!(p.encode()[..], data[off..off + POINT_LEN]);
        }
    }
}
