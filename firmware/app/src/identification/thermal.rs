//! Identification in flight across the orbit's thermal cycle: each window's parts'
//! mean temperatures, and every channel's bias against them across the windows solved since
//! boot (`estimator_core::thermal::Track`), in the application task.
//!
//! A window's bias of a channel is for the readings as the estimator got them, brought to
//! `t_ref` by the coefficients in use: where the coefficient is off, the windows' biases lie on
//! a line in their temperatures, and the track fits it. Once it decides a channel (three
//! windows over 10 °C), a commit (TC[200,11]) stores the line's bias at `t_ref` and the
//! coefficient corrected by its slope with the solution's geometry; the scale's coefficient
//! stays the one in use (free flight does not separate a scale from its lever arm). Every
//! solution is followed by the track of each channel (TM[200,130]).
//!
//! The temperatures of a window are the parts' last reads at each new read (a few per second,
//! outside the sets' path): the mean over the window's time, which is the mean over its sets
//! to the change of one read interval (≈ 0.006 °C on a ±20 °C orbit).

use ballisto_link::identification::{
    ThermalTrack, TRACK_ADDED, TRACK_DETERMINED, TRACK_SCALE_DRIFT,
};
use estimator_core::identify::{Identified, Param};
use estimator_core::thermal::{Line, Thermal, Track};
use estimator_core::Arrangement;

use crate::config::{MAX_CHANNELS, MAX_PARTS};

// Channels are bits of a `u32` here.
const _: () = assert!(MAX_CHANNELS <= 32);

/// The window's temperatures and the track.
#[derive(Clone, Debug)]
pub struct ThermalTracking {
    /// Each part's temperatures read during the open window: sum (°C) and count.
    sum: [f32; MAX_PARTS],
    count: [u32; MAX_PARTS],
    /// Whether a solution of the open window joined the track (solving it again adds nothing).
    added: bool,
    track: Track<MAX_CHANNELS>,
    /// Channels (bit per channel) that joined from a window holding a position component.
    held_position: u32,
}

impl Default for ThermalTracking {
    fn default() -> Self {
        Self::new()
    }
}

impl ThermalTracking {
    /// No window, no track.
    pub const fn new() -> Self {
        ThermalTracking {
            sum: [0.0; MAX_PARTS],
            count: [0; MAX_PARTS],
            added: false,
            track: Track::new(),
            held_position: 0,
        }
    }

    /// A window starts: its temperatures from now.
    pub fn start(&mut self) {
        self.sum = [0.0; MAX_PARTS];
        self.count = [0; MAX_PARTS];
        self.added = false;
    }

    /// The parts' temperatures (°C, NaN: not read) after a new read, during the window.
    pub fn observe(&mut self, celsius: &[f32; MAX_PARTS]) {
        for ((s, n), t) in self.sum.iter_mut().zip(self.count.iter_mut()).zip(celsius) {
            if t.is_finite() {
                *s += t;
                *n += 1;
            }
        }
    }

    /// The arrangement in force changed: the windows' biases were found for the old one.
    pub fn forget(&mut self) {
        self.track.clear();
        self.added = false;
        self.held_position = 0;
    }

    /// Part `part`'s mean temperature over the window (°C; NaN if never read).
    fn window_temperature(&self, part: Option<usize>) -> f32 {
        match part.and_then(|p| Some((self.sum.get(p)?, self.count.get(p)?))) {
            Some((s, &n)) if n > 0 => s / n as f32,
            _ => f32::NAN,
        }
    }

    /// A solution of the open window (`id`): each channel whose bias it determined (not held)
    /// with its residual within `residual_limit` × its noise joins the track at its part's
    /// (`part_of`) mean temperature, once per window (solving the window again adds nothing).
    /// Returns the channels added (bit per channel).
    pub fn add_solution(
        &mut self,
        id: &Identified<MAX_CHANNELS>,
        part_of: impl Fn(usize) -> Option<usize>,
        residual_limit: f64,
    ) -> u32 {
        if self.added {
            return 0;
        }
        self.added = true;
        let mut added = 0;
        for (c, f) in id.channels().iter().enumerate() {
            let t = self.window_temperature(part_of(c));
            let usable =
                !f.is_held(Param::Bias) && f.residual_rms <= residual_limit * f.channel.noise;
            let bias_sd = f.sd[Param::Bias as usize];
            if usable && self.track.add(c, f64::from(t), f.channel.bias, bias_sd) {
                added |= 1 << c;
                let position = [Param::PositionX, Param::PositionY, Param::PositionZ];
                if position.into_iter().any(|p| f.is_held(p)) {
                    self.held_position |= 1 << c;
                }
            }
        }
        added
    }

    /// TM[200,130] of channel `c` (read from part `part`) after solution `number`, which
    /// `added` ([`Self::add_solution`]) says joined the track or not; `in_use`: the arrangement
    /// the windows' readings were compensated with.
    pub fn report(
        &self,
        number: u16,
        c: usize,
        part: Option<usize>,
        added: u32,
        in_use: &Arrangement<MAX_CHANNELS>,
    ) -> ThermalTrack {
        let joined = added & (1 << c) != 0;
        let mut r = ThermalTrack {
            solution: number,
            channel: c as u8,
            state: if joined { TRACK_ADDED } else { 0 },
            windows: self.track.windows(c),
            window_temperature: self.window_temperature(part),
            span: f32::NAN,
            t_ref: f32::NAN,
            bias: f32::NAN,
            bias_sd: f32::NAN,
            bias_tc: f32::NAN,
            bias_tc_sd: f32::NAN,
            scatter: f32::NAN,
        };
        let scale_tc = in_use.thermal(c).map_or(0.0, |th| th.scale_tc);
        if self.held_position & (1 << c) != 0 && scale_tc == 0.0 {
            r.state |= TRACK_SCALE_DRIFT;
        }
        if let Some((line, bias_tc, thermal)) = self.line(c, in_use) {
            if line.determined() && thermal.is_some() {
                r.state |= TRACK_DETERMINED;
            }
            r.span = line.span as f32;
            r.t_ref = line.t_ref as f32;
            r.bias = line.bias as f32;
            r.bias_sd = line.bias_sd as f32;
            r.bias_tc = bias_tc as f32;
            r.bias_tc_sd = line.bias_tc_sd as f32;
            r.scatter = line.scatter as f32;
        }
        r
    }

    /// Channel `c`'s line at the `t_ref` of the coefficients in use (or the windows' mean
    /// without), the bias coefficient it gives (the one in use corrected by the slope) and the
    /// coefficients with the scale's kept (`None` if beyond any part's, `Thermal::new`).
    fn line(
        &self,
        c: usize,
        in_use: &Arrangement<MAX_CHANNELS>,
    ) -> Option<(Line, f64, Option<Thermal>)> {
        let used = in_use.thermal(c);
        let line = self.track.line(c, used.map(|th| th.t_ref))?;
        let (base, scale_tc) = used.map_or((0.0, 0.0), |th| (th.bias_tc, th.scale_tc));
        let bias_tc = base + line.bias_tc;
        let thermal = Thermal::new(line.t_ref, bias_tc, scale_tc).ok();
        Some((line, bias_tc, thermal))
    }

    /// Puts into `arrangement` (a commit's, with the coefficients `in_use` already) every
    /// channel's bias and coefficients the track decides. Returns how many.
    pub fn apply(
        &self,
        arrangement: &mut Arrangement<MAX_CHANNELS>,
        in_use: &Arrangement<MAX_CHANNELS>,
    ) -> usize {
        let mut applied = 0;
        for c in 0..arrangement.len() {
            let Some((line, _, Some(thermal))) = self.line(c, in_use) else {
                continue;
            };
            let Some(scale) = arrangement.channels().get(c).map(|ch| ch.scale) else {
                continue;
            };
            if line.determined()
                && arrangement.set_calibration(c, line.bias, scale).is_ok()
                && arrangement.set_thermal(c, Some(thermal)).is_ok()
            {
                applied += 1;
            }
        }
        applied
    }
}
