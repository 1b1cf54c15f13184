//! The reference rate as the bus sends it (TC[200,9]): its last three points, and Ω and Ω′ at
//! any instant between the first and the last of them.

use ballisto_link::identification::ReferencePoint;

/// What a new point did to the track.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Push {
    /// It extends the track.
    Extended,
    /// It starts a new track: the first point, or one after a gap longer than the track
    /// allows, or one not after the last (a reference restarted).
    Restarted,
}

/// The last three reference points.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReferenceTrack {
    t: [u64; 3],
    omega: [[f64; 3]; 3],
    n: usize,
    max_gap: u64,
}

impl ReferenceTrack {
    /// An empty track; two points further apart than `max_gap` ns are not joined.
    pub const fn new(max_gap: u64) -> Self {
        ReferenceTrack {
            t: [0; 3],
            omega: [[0.0; 3]; 3],
            n: 0,
            max_gap,
        }
    }

    /// Takes a point.
    pub fn push(&mut self, p: &ReferencePoint) -> Push {
        let omega = p.omega.map(f64::from);
        let joined = self.n > 0 && {
            let last = self.t[self.n - 1];
            p.t > last && p.t - last <= self.max_gap
        };
        if !joined {
            self.t[0] = p.t;
            self.omega[0] = omega;
            self.n = 1;
            return Push::Restarted;
        }
        if self.n == 3 {
            self.t.copy_within(1.., 0);
            self.omega.copy_within(1.., 0);
            self.n = 2;
        }
        self.t[self.n] = p.t;
        self.omega[self.n] = omega;
        self.n += 1;
        Push::Extended
    }

    /// Its first point's time, if it has one.
    pub fn first(&self) -> Option<u64> {
        (self.n > 0).then_some(self.t[0])
    }

    /// The instants the track covers: from its first to its last point, once it has three.
    pub fn span(&self) -> Option<(u64, u64)> {
        (self.n == 3).then_some((self.t[0], self.t[2]))
    }

    /// Ω and Ω′ at `t` (within [`ReferenceTrack::span`]) from the parabola through the three
    /// points (Ω′ its derivative: the error is of the order of the reference period squared
    /// times Ω‴, where a straight line between two points would leave half a period times Ω″).
    pub fn field_at(&self, t: u64) -> Option<([f64; 3], [f64; 3])> {
        let (t0, t2) = self.span()?;
        if t < t0 || t > t2 {
            return None;
        }
        let s = |a: u64| (a as i64 - self.t[1] as i64) as f64 * 1e-9;
        let (h0, h2, x) = (s(t0), s(t2), s(t));
        let mut w = [0.0; 3];
        let mut dw = [0.0; 3];
        for k in 0..3 {
            let (w0, w1, w2) = (self.omega[0][k], self.omega[1][k], self.omega[2][k]);
            let (d0, d2) = ((w0 - w1) / h0, (w2 - w1) / h2);
            let c = (d2 - d0) / (h2 - h0);
            let b = d2 - c * h2;
            w[k] = w1 + x * (b + c * x);
            dw[k] = b + 2.0 * c * x;
        }
        Some((w, dw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(t: f64, w: [f64; 3]) -> ReferencePoint {
        ReferencePoint {
            t: (t * 1e9) as u64,
            omega: w.map(|v| v as f32),
        }
    }

    /// A parabola in time is reproduced exactly, with its derivative.
    #[test]
    fn a_parabola_and_its_derivative_come_back() {
        let f = |t: f64| [1.0 + 0.5 * t - 0.25 * t * t, -2.0 * t, 0.75];
        let df = |t: f64| [0.5 - 0.5 * t, -2.0, 0.0];
        let mut tr = ReferenceTrack::new(200_000_000);
        for t in [1.0, 1.1, 1.2] {
            tr.push(&point(t, f(t)));
        }
        for t in [1.0, 1.05, 1.13, 1.2] {
            let (w, dw) = tr.field_at((t * 1e9) as u64).unwrap();
            for k in 0..3 {
                assert!((w[k] - f(t)[k]).abs() < 1e-6, "{t} {k}");
                assert!((dw[k] - df(t)[k]).abs() < 1e-4, "{t} {k}");
            }
        }
        assert_eq!(tr.field_at(1_250_000_000), None);
    }

    #[test]
    fn a_gap_or_a_step_back_restarts_the_track() {
        let mut tr = ReferenceTrack::new(150_000_000);
        assert_eq!(tr.push(&point(1.0, [0.0; 3])), Push::Restarted);
        assert_eq!(tr.push(&point(1.1, [0.0; 3])), Push::Extended);
        assert_eq!(tr.push(&point(1.3, [0.0; 3])), Push::Restarted);
        assert_eq!(tr.span(), None);
        assert_eq!(tr.push(&point(1.4, [0.0; 3])), Push::Extended);
        assert_eq!(tr.push(&point(1.35, [0.0; 3])), Push::Restarted);
    }
}
