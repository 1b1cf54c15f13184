//! Temperature compensation of the readings (`estimator_core::thermal`): each
//! channel with temperature coefficients is brought to its reading at `t_ref` before the
//! fault monitor and the estimate see it. The correction `gain·p + offset` is computed once per
//! temperature read of the channel's part (a few per second, in f32 as the readings); a set
//! costs one multiply-add per channel. A channel whose part's temperature has not been read yet is
//! used as read (its correction is the identity), and housekeeping shows the temperature as
//! not read.

use estimator_core::Arrangement;

use crate::config::{MAX_CHANNELS, MAX_PARTS};

/// The corrections in force and the temperatures they were made for.
#[derive(Clone, Debug)]
pub struct Compensation {
    gain: [f32; MAX_CHANNELS],
    offset: [f32; MAX_CHANNELS],
    /// Each part's last temperature read (°C; NaN: not read).
    temperature: [f32; MAX_PARTS],
    /// The sampler's count of temperature reads when they were last looked at.
    reads: u32,
}

impl Compensation {
    /// No correction; no temperature read.
    pub const fn new() -> Self {
        Compensation {
            gain: [1.0; MAX_CHANNELS],
            offset: [0.0; MAX_CHANNELS],
            temperature: [f32::NAN; MAX_PARTS],
            reads: 0,
        }
    }

    /// Part `part`, feeding `channels`, reads `celsius`: its channels' corrections for that
    /// temperature from `arrangement`'s coefficients.
    pub fn observe(
        &mut self,
        arrangement: &Arrangement<MAX_CHANNELS>,
        part: usize,
        channels: &[Option<u8>; 3],
        celsius: f32,
    ) {
        if let Some(t) = self.temperature.get_mut(part) {
            *t = celsius;
        }
        self.correct(arrangement, part, channels);
    }

    /// A new arrangement (its coefficients, or none): every part's corrections again at its
    /// last temperature.
    pub fn reconfigure(
        &mut self,
        arrangement: &Arrangement<MAX_CHANNELS>,
        channels: &[[Option<u8>; 3]; MAX_PARTS],
    ) {
        self.gain = [1.0; MAX_CHANNELS];
        self.offset = [0.0; MAX_CHANNELS];
        for (part, chans) in channels.iter().enumerate() {
            self.correct(arrangement, part, chans);
        }
    }

    fn correct(
        &mut self,
        arrangement: &Arrangement<MAX_CHANNELS>,
        part: usize,
        channels: &[Option<u8>; 3],
    ) {
        let Some(&t) = self.temperature.get(part) else {
            return;
        };
        if t.is_nan() {
            return;
        }
        let biases = arrangement.channels();
        for c in channels.iter().flatten() {
            let c = usize::from(*c);
            let (Some(th), Some(ch)) = (arrangement.thermal(c), biases.get(c)) else {
                continue;
            };
            let (gain, offset) = th.linear(t, ch.bias as f32);
            self.gain[c] = gain;
            self.offset[c] = offset;
        }
    }

    /// Whether the sampler's count of temperature reads `reads` is new (and takes it).
    #[inline]
    pub fn news(&mut self, reads: u32) -> bool {
        let new = reads != self.reads;
        self.reads = reads;
        new
    }

    /// Reading `x` of channel `c` brought to its `t_ref` (the identity without coefficients or
    /// a temperature; NaN stays NaN).
    #[inline]
    pub fn corrected(&self, c: usize, x: f32) -> f32 {
        match (self.gain.get(c), self.offset.get(c)) {
            (Some(g), Some(o)) => x * g + o,
            _ => x,
        }
    }

    /// Each part's last temperature read (°C; NaN where none yet).
    pub fn temperatures(&self) -> &[f32; MAX_PARTS] {
        &self.temperature
    }
}

impl Default for Compensation {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator_core::thermal::Thermal;

    /// A part warmed by 20 °C reads what it read at `t_ref` once its temperature is known, and
    /// as read before; a channel without coefficients is untouched.
    #[test]
    fn readings_come_back_to_the_reference() {
        let mut a = Arrangement::<MAX_CHANNELS>::new();
        for k in 0..3 {
            let mut axis = [0.0; 3];
            axis[k] = 1.0;
            a.push([0.1, 0.0, 0.0], axis, 1e-3).unwrap();
        }
        a.set_calibration(0, 0.05, 1.01).unwrap();
        a.set_thermal(0, Some(Thermal::new(25.0, 1.5e-3, 1e-4).unwrap()))
            .unwrap();
        let chans = [[Some(0), Some(1), Some(2)]; 1];
        let mut all = [[None; 3]; MAX_PARTS];
        all[0] = chans[0];
        let mut comp = Compensation::new();
        comp.reconfigure(&a, &all);
        let field = 3.0f64;
        let at_ref = 1.01 * field + 0.05;
        let warm = 1.01 * (1.0 + 1e-4 * 20.0) * field + 0.05 + 1.5e-3 * 20.0;
        let apply = |comp: &Compensation, p: [f32; 3]| [0, 1, 2].map(|c| comp.corrected(c, p[c]));
        let p = apply(&comp, [warm as f32, 2.0, 3.0]);
        assert_eq!(p[0], warm as f32, "no temperature read yet");
        assert!(comp.temperatures()[0].is_nan());
        assert!(comp.news(1) && !comp.news(1));
        comp.observe(&a, 0, &all[0], 45.0);
        let p = apply(&comp, [warm as f32, 2.0, f32::NAN]);
        assert!((f64::from(p[0]) - at_ref).abs() < 1e-5, "{}", p[0]);
        assert_eq!(p[1], 2.0);
        assert!(p[2].is_nan());
        // An arrangement without coefficients: nothing corrected, the temperature kept.
        let mut plain = a.clone();
        plain.set_thermal(0, None).unwrap();
        comp.reconfigure(&plain, &all);
        let p = apply(&comp, [warm as f32, 2.0, 3.0]);
        assert_eq!(p[0], warm as f32);
        assert_eq!(comp.temperatures()[0], 45.0);
    }
}
