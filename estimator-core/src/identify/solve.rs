//! The solve: every channel of the arrangement from the window's sums, then the centre of mass
//! from the positions.

use super::fit::{Problem, State};
use super::model::{Param, Tolerance, PARAMS};
use super::result::{ChannelFit, Identified, IdentifyError};
use super::sums::FieldSums;
use crate::arrangement::Arrangement;
use crate::real::Real;

// Every function of the solve (here, in `fit` and in `cholesky`) is `#[inline]`: its code is
// then generated in the crate that calls it, at that crate's optimisation level — the
// firmware's application, built for size — and not at estimator-core's speed level (`3` in
// the flight profile), where `normal` alone unrolled to 4.7 KB of the flight image. The solve
// runs once per telecommand. `Problem::fit` and `settle` are out of line: inlined, the two
// passes each carried a copy (1.1 KB of the image, measured).

/// Identifies every channel of `nominal` from the sums of a window (paper §6; see the module
/// documentation): two passes, the second with the positions' nominal values moved to the
/// centre of mass the first found.
#[inline(never)]
pub fn identify<const CAP: usize>(
    sums: &FieldSums<CAP>,
    nominal: &Arrangement<CAP>,
    tolerance: &Tolerance,
) -> Result<Identified<CAP>, IdentifyError> {
    let n = nominal.len();
    if sums.channels() != n {
        return Err(IdentifyError::ChannelCount {
            sums: sums.channels(),
            arrangement: n,
        });
    }
    if (sums.sets() as usize) <= PARAMS {
        return Err(IdentifyError::TooFewSets { have: sums.sets() });
    }
    let gram = sums.gram();
    let mut out = Identified {
        fits: [ChannelFit::default(); CAP],
        len: n,
        rho: [0.0; 3],
        rho_sd: [tolerance.position; 3],
        sets: sums.sets(),
        tolerance: *tolerance,
    };
    // `c`: the centre of mass from the origin (−ρ) while the passes run.
    let mut c = [0.0f64; 3];
    for _pass in 0..2 {
        for (i, ch) in nominal.channels().iter().enumerate() {
            let (g, sq) = sums.channel(i);
            let problem = Problem {
                gram: &gram,
                cross: &g,
                square: sq,
                sets: f64::from(sums.sets()),
                tolerance,
            };
            let position = [
                ch.position[0] - c[0],
                ch.position[1] - c[1],
                ch.position[2] - c[2],
            ];
            let start = State::new(ch.scale, ch.axis, position, ch.bias);
            out.fits[i] = problem
                .fit(start, ch.noise)
                .ok_or(IdentifyError::NotConverged { channel: i })?;
        }
        // The centre of mass: the positions' mean offset from nominal, weighted per axis.
        for l in 0..3 {
            let (mut sw, mut swx, mut k) = (0.0, 0.0, 0.0);
            for (f, ch) in out.fits[..n].iter().zip(nominal.channels()) {
                if !f.is_held(Param::ALL[3 + l]) && f.sd[3 + l] > 0.0 {
                    let w = 1.0 / (f.sd[3 + l] * f.sd[3 + l]);
                    sw += w;
                    swx += w * (ch.position[l] - f.channel.position[l]);
                    k += 1.0;
                }
            }
            if sw > 0.0 {
                c[l] = swx / sw;
                out.rho_sd[l] = Real::sqrt(1.0 / sw + tolerance.position * tolerance.position / k);
            }
        }
    }
    // Positions from the instrument origin; ρ (paper eq. 12) the origin from the centre of mass.
    for f in out.fits[..n].iter_mut() {
        for l in 0..3 {
            f.channel.position[l] += c[l];
        }
    }
    out.rho = c.map(|v| -v);
    Ok(out)
}
