//! The sufficient statistics of the identification: `Σ k kᵀ`, and per channel `Σ p k` and
//! `Σ p²`, with `k` the field's ten terms.

use crate::linalg::{Sym3, Vec3};
use crate::real::Real;

/// Terms of the field vector `k = (vec L, 1)`.
pub const TERMS: usize = 10;

/// The field's terms at one instant: `vec L` (row-major) with `L = Γ + {Ω}² + {Ω′}` (paper
/// eq. 4; `{v}` the skew matrix, `{v} u = v × u`), then 1 for the bias.
pub fn field_terms(omega: &Vec3<f64>, domega: &Vec3<f64>, gamma: &Sym3<f64>) -> [f64; TERMS] {
    let a = Sym3::skew_squared(omega).add_scaled(1.0, gamma).to_mat();
    let [x, y, z] = *domega;
    [
        a[0][0],
        a[0][1] - z,
        a[0][2] + y,
        a[1][0] + z,
        a[1][1],
        a[1][2] - x,
        a[2][0] - y,
        a[2][1] + x,
        a[2][2],
        1.0,
    ]
}

/// Running sums over the sample sets of a window (f64 whatever the sample scalar: a window
/// of 10⁵ sets must keep the residual, 10⁻⁵ of `Σ p²`, above the round-off).
#[derive(Clone, Debug)]
pub struct FieldSums<const CAP: usize> {
    /// `Σ k kᵀ` (upper triangle: `gram[i][j]`, `j ≥ i`).
    gram: [[f64; TERMS]; TERMS],
    /// `Σ pᵢ k` per channel.
    cross: [[f64; TERMS]; CAP],
    /// `Σ pᵢ²` per channel.
    square: [f64; CAP],
    /// Sets added.
    sets: u32,
    /// Channels per set.
    channels: usize,
}

impl<const CAP: usize> Default for FieldSums<CAP> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const CAP: usize> FieldSums<CAP> {
    /// Empty sums for no channels ([`FieldSums::clear`] sets the count).
    pub const fn new() -> Self {
        FieldSums {
            gram: [[0.0; TERMS]; TERMS],
            cross: [[0.0; TERMS]; CAP],
            square: [0.0; CAP],
            sets: 0,
            channels: 0,
        }
    }

    /// Forgets every set; the next ones have `channels` channels (at most `CAP`).
    pub fn clear(&mut self, channels: usize) {
        *self = Self::new();
        self.channels = channels.min(CAP);
    }

    /// Adds one sample set: the field's terms `k` ([`field_terms`]) and every channel's
    /// reading. A set with another channel count or a reading or term that is not finite is
    /// not added (returns `false`): a missing reading would make the shared `Σ k kᵀ` wrong
    /// for that channel.
    pub fn add<T: Real>(&mut self, k: &[f64; TERMS], p: &[T]) -> bool {
        if p.len() != self.channels
            || !k.iter().all(|v| v.is_finite())
            || !p.iter().all(|v| v.is_finite())
        {
            return false;
        }
        for i in 0..TERMS {
            for j in i..TERMS {
                self.gram[i][j] += k[i] * k[j];
            }
        }
        for (c, v) in p.iter().enumerate() {
            let v = v.to_f64();
            for (s, ki) in self.cross[c].iter_mut().zip(k.iter()) {
                *s += v * ki;
            }
            self.square[c] += v * v;
        }
        self.sets = self.sets.saturating_add(1);
        true
    }

    /// Sets added since the last clear.
    pub fn sets(&self) -> u32 {
        self.sets
    }

    /// Channels per set.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// `Σ k kᵀ`, both triangles.
    pub(super) fn gram(&self) -> [[f64; TERMS]; TERMS] {
        let mut g = self.gram;
        for i in 0..TERMS {
            for j in 0..i {
                g[i][j] = g[j][i];
            }
        }
        g
    }

    /// Channel `c`'s `Σ p k` and `Σ p²` (zero beyond the channels).
    pub(super) fn channel(&self, c: usize) -> ([f64; TERMS], f64) {
        match (self.cross.get(c), self.square.get(c)) {
            (Some(x), Some(s)) if c < self.channels => (*x, *s),
            _ => ([0.0; TERMS], 0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::{cross, mat_vec};

    /// `zᵀ vec L` is `s·(L R)`, and `L R` is `Γ R + Ω × (Ω × R) + Ω′ × R` (paper eq. 4).
    #[test]
    fn terms_are_the_field_gradient() {
        let (w, dw, r, s) = (
            [0.3, -1.2, 0.7],
            [2.0, 0.5, -1.1],
            [0.1, -0.05, 0.2],
            [0.6, 0.0, 0.8],
        );
        let gamma = Sym3([1e-3, -2e-3, 1e-3, 5e-4, 0.0, -1e-4]);
        let k = field_terms(&w, &dw, &gamma);
        let lr = {
            let cc = cross(&w, &cross(&w, &r));
            let g = mat_vec(&gamma.to_mat(), &r);
            let a = cross(&dw, &r);
            [
                cc[0] + g[0] + a[0],
                cc[1] + g[1] + a[1],
                cc[2] + g[2] + a[2],
            ]
        };
        let want = s[0] * lr[0] + s[1] * lr[1] + s[2] * lr[2];
        let mut got = 0.0;
        for j in 0..3 {
            for l in 0..3 {
                got += s[j] * r[l] * k[3 * j + l];
            }
        }
        assert!((got - want).abs() < 1e-15, "{got} {want}");
        assert_eq!(k[9], 1.0);
    }

    #[test]
    fn a_set_with_a_missing_or_bad_reading_is_not_added() {
        let mut s = FieldSums::<4>::new();
        s.clear(3);
        let k = field_terms(&[1.0, 0.0, 0.0], &[0.0; 3], &Sym3([0.0; 6]));
        assert!(s.add(&k, &[1.0f32, 2.0, 3.0]));
        assert!(!s.add(&k, &[1.0f32, 2.0]));
        assert!(!s.add(&k, &[1.0f32, f32::NAN, 3.0]));
        let mut bad = k;
        bad[2] = f64::INFINITY;
        assert!(!s.add(&bad, &[1.0f32, 2.0, 3.0]));
        assert_eq!(s.sets(), 1);
        assert_eq!(s.channel(1).1, 4.0);
        assert_eq!(s.channel(3), ([0.0; TERMS], 0.0));
    }
}
