//! Each part's check from its own signal: stuck, or at its range limit.

use crate::real::Real;

/// Sets in a row with every channel of a part unchanged, bit for bit, after which the part is
/// taken as stuck. A healthy MEMS part's noise spans many codes (ADXL355: about 300 LSB at
/// 1.2 mg; LIS3DH: about 2 LSB), so ten identical sets on all its axes are a stuck output or
/// a saturated one (hal-sim's saturation pins every axis at full scale). Also the sets a part
/// stays out after its last reading at a range limit ([`StuckCheck::with_limits`]).
pub const STUCK_SETS: u16 = 10;

/// Relative margin below a channel's full scale from which a reading is taken as at the limit:
/// 1e-5 of full scale is 5 codes of an ADXL355's 20-bit output, less than one of a LIS3DH's
/// 12-bit one (the rail itself), so nothing but a reading on or next to the rail counts.
pub const RANGE_MARGIN: f64 = 1e-5;

/// The check of each part from its own signal (issue 17: "where the residual has no
/// redundancy"): a part whose every channel repeats the same value for [`STUCK_SETS`] sets is
/// stuck; a part any of whose channels reads at its full scale (given with
/// [`StuckCheck::with_limits`]) is saturated at once — one clipped axis is enough, the
/// others may still move — and stays so until [`STUCK_SETS`] sets after its last reading at
/// the limit (a part that touches the rail now and then is not taken out and re-admitted at
/// every touch). It needs no parity space, so it runs in every model and at any N.
#[derive(Clone, Debug)]
pub struct StuckCheck<T, const CAP: usize> {
    part: [u8; CAP],
    n: usize,
    last: [T; CAP],
    run: [u16; CAP],
    /// Per channel: the magnitude from which a reading is at its range limit (infinite: none).
    limit: [T; CAP],
    /// Per part: sets it stays saturated (0: in range).
    saturated_for: [u16; CAP],
}

impl<T: Real, const CAP: usize> StuckCheck<T, CAP> {
    /// The check for channels whose parts are `part[i]` ([`crate::parity::NO_PART`] for none),
    /// without range limits.
    pub fn new(part: &[u8]) -> Self {
        Self::with_limits(part, &[])
    }

    /// The check with each channel's full scale `range[i]` (m/s², the largest magnitude its
    /// reading can take; missing, infinite, zero or negative: no limit). A reading of
    /// magnitude `range · (1 − RANGE_MARGIN)` or more is at the limit.
    pub fn with_limits(part: &[u8], range: &[f64]) -> Self {
        let mut p = [crate::parity::NO_PART; CAP];
        for (d, s) in p.iter_mut().zip(part) {
            *d = *s;
        }
        let mut limit = [T::of(f64::INFINITY); CAP];
        for (l, r) in limit.iter_mut().zip(range) {
            if *r > 0.0 && r.is_finite() {
                *l = T::of(*r * (1.0 - RANGE_MARGIN));
            }
        }
        StuckCheck {
            part: p,
            n: part.len().min(CAP),
            last: [T::ZERO; CAP],
            run: [0; CAP],
            limit,
            saturated_for: [0; CAP],
        }
    }

    /// One set's readings; returns the parts stuck or saturated now (bit per part number, below
    /// 32). A reading that is not finite (a part without a value) is neither a repeat nor at a
    /// limit.
    pub fn step(&mut self, p: &[T]) -> u32 {
        let mut moved = [false; CAP];
        let mut present = [false; CAP];
        let mut at_limit = [false; CAP];
        for (i, ((&q, last), &limit)) in self
            .part
            .iter()
            .zip(self.last.iter_mut())
            .zip(self.limit.iter())
            .enumerate()
            .take(self.n)
        {
            let q = usize::from(q);
            if q >= CAP {
                continue;
            }
            present[q] = true;
            match p.get(i) {
                // NaN ≠ NaN: a part without a value is never a repeat (and NaN is at no limit).
                Some(v) => {
                    at_limit[q] |= v.abs() >= limit;
                    if *v != *last {
                        moved[q] = true;
                        *last = *v;
                    }
                }
                None => moved[q] = true,
            }
        }
        let mut out = 0u32;
        for (q, (run, sat)) in self
            .run
            .iter_mut()
            .zip(self.saturated_for.iter_mut())
            .enumerate()
        {
            if at_limit[q] {
                *sat = STUCK_SETS;
            } else {
                *sat = sat.saturating_sub(1);
            }
            let saturated = *sat > 0;
            if !present[q] || moved[q] {
                *run = 0;
            } else {
                *run = run.saturating_add(1);
            }
            if (*run >= STUCK_SETS || saturated) && q < 32 {
                out |= 1 << q;
            }
        }
        out
    }
}
