//! A built-in scenario in place of the parts: sample sets computed from a known motion, for
//! boards without accelerometers (QEMU in CI) and as a reference the ground can recompute.
//!
//! The body tumbles smoothly ([`motion`]); each channel reads paper eq. (4),
//! `p = s·(σ0 + Ω′×R + Ω×(Ω×R))`, plus a deterministic pseudo-noise of the channel's RMS. One
//! part can be silenced for a while ([`Outage`]), and one stuck (its output frozen at its last
//! value over the same kind of window), so that the health, event, exclusion and fault
//! isolation paths run too.

use embassy_sync::blocking_mutex::raw::RawMutex;
use embassy_sync::channel::Sender;
use estimator_core::linalg::{add, cross, dot, Vec3};

use ballisto_fw::config::{AppConfig, MAX_PARTS};
use ballisto_fw::sampler::{Health, HealthBoard, LoopHealth, PartHealth, SampleSet};
use ballisto_fw::time::{seconds, Nanos, TimeBase};

/// The motion at time `t` (s since the first instant): σ0, Ω′, Ω (body frame).
pub fn motion(t: f64) -> (Vec3<f64>, Vec3<f64>, Vec3<f64>) {
    use libm::{cos, sin};
    let omega = [
        0.3 + 0.4 * sin(0.5 * t),
        -0.4 + 0.3 * cos(0.3 * t),
        0.8 + 0.2 * sin(0.7 * t),
    ];
    let domega = [
        0.2 * cos(0.5 * t),
        -0.09 * sin(0.3 * t),
        0.14 * cos(0.7 * t),
    ];
    let sigma0 = [0.02 * sin(t), -0.01, 0.03 * cos(0.3 * t)];
    (sigma0, domega, omega)
}

/// A torque-free rigid body (Euler's equations `J Ω′ = (J Ω) × Ω`, principal axes along the
/// body frame's), integrated by classical fourth-order Runge–Kutta at a fixed step: the motion
/// identification without a reference takes (TC[200,8] source 2), in place of [`motion`].
/// Its own integrator, not the search's (estimator-core keeps that one private): the truth
/// must not share a discretisation with what is checked against it.
#[derive(Clone, Copy, Debug)]
pub struct Tumble {
    inertia: Vec3<f64>,
    /// Ω at the first instant, and now.
    omega0: Vec3<f64>,
    omega: Vec3<f64>,
    /// The step, s.
    step: f64,
    /// Steps taken.
    k: u32,
}

impl Tumble {
    /// Principal moments `inertia` (kg·m², any common scale), Ω = `omega0` (rad/s) at the first
    /// instant, integrated in steps of `step` s.
    pub const fn new(inertia: Vec3<f64>, omega0: Vec3<f64>, step: f64) -> Self {
        Tumble {
            inertia,
            omega0,
            omega: omega0,
            step,
            k: 0,
        }
    }

    /// Ω′ at Ω (Euler's equations).
    fn derivative(&self, w: &Vec3<f64>) -> Vec3<f64> {
        let j = &self.inertia;
        let c = cross(&[j[0] * w[0], j[1] * w[1], j[2] * w[2]], w);
        [c[0] / j[0], c[1] / j[1], c[2] / j[2]]
    }

    /// The motion `k` steps after the first instant (σ0 = 0, Ω′, Ω): integrated forward from
    /// where the last call left it (or from the start again, if `k` is earlier).
    pub fn at(&mut self, k: u32) -> (Vec3<f64>, Vec3<f64>, Vec3<f64>) {
        if k < self.k {
            (self.omega, self.k) = (self.omega0, 0);
        }
        while self.k < k {
            let h = self.step;
            let w = self.omega;
            let along = |d: &Vec3<f64>, f: f64| [w[0] + f * d[0], w[1] + f * d[1], w[2] + f * d[2]];
            let k1 = self.derivative(&w);
            let k2 = self.derivative(&along(&k1, h / 2.0));
            let k3 = self.derivative(&along(&k2, h / 2.0));
            let k4 = self.derivative(&along(&k3, h));
            for (c, x) in self.omega.iter_mut().enumerate() {
                *x += h / 6.0 * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c]);
            }
            self.k += 1;
        }
        ([0.0; 3], self.derivative(&self.omega), self.omega)
    }
}

/// A part silenced (or stuck) from `from` to `to` (s since the first instant).
#[derive(Clone, Copy, Debug)]
pub struct Outage {
    /// The part slot.
    pub part: usize,
    /// Start, s.
    pub from: f64,
    /// End, s.
    pub to: f64,
}

/// Sets in a row without a value after which a part is reported down (as the sampler does).
const DOWN_AFTER: u32 = 10;

/// Geometry of one channel: position, axis, noise.
type Geometry = ([f64; 3], [f64; 3], f64);

/// The built-in scenario's sample source.
pub struct Synthetic {
    period: Nanos,
    channels: [[Option<Geometry>; 3]; MAX_PARTS],
    outage: Option<Outage>,
    stuck: Option<Outage>,
    /// Free flight: no specific force at the origin (the identification's field).
    free_flight: bool,
    /// A torque-free tumble in place of [`motion`] (in free flight).
    tumble: Option<Tumble>,
    /// Each part's last output (what a stuck part repeats).
    last: [[f32; 3]; MAX_PARTS],
    parts: [Option<PartHealth>; MAX_PARTS],
    silent: [u32; MAX_PARTS],
    health: LoopHealth,
}

impl Synthetic {
    /// Samples for the parts and arrangement of `config`, a part silent over `outage` and one
    /// whose output is frozen over `stuck`.
    pub fn new(config: &AppConfig, outage: Option<Outage>, stuck: Option<Outage>) -> Self {
        let mut channels = [[None; 3]; MAX_PARTS];
        let mut parts = [None; MAX_PARTS];
        for (i, p) in config.sampling.parts() {
            parts[i] = Some(PartHealth {
                running: true,
                ..PartHealth::default()
            });
            for (slot, c) in channels[i].iter_mut().zip(p.channels.iter()) {
                *slot = c
                    .and_then(|c| config.arrangement.channels().get(usize::from(c)))
                    .map(|ch| (ch.position, ch.axis, ch.noise));
            }
        }
        Synthetic {
            period: config.sampling.period_ns(),
            channels,
            outage,
            stuck,
            free_flight: false,
            tumble: None,
            last: [[0.0; 3]; MAX_PARTS],
            parts,
            silent: [0; MAX_PARTS],
            health: LoopHealth::default(),
        }
    }

    /// The same motion in free flight, the origin at the centre of mass: σ0 = 0 (the field
    /// identification in flight takes).
    pub fn in_free_flight(mut self) -> Self {
        self.free_flight = true;
        self
    }

    /// A torque-free tumble in free flight in place of [`motion`]: `inertia` (principal
    /// moments) and Ω = `omega0` at the first instant, integrated at the sample period.
    pub fn tumbling(mut self, inertia: Vec3<f64>, omega0: Vec3<f64>) -> Self {
        self.free_flight = true;
        self.tumble = Some(Tumble::new(inertia, omega0, seconds(self.period)));
        self
    }

    /// The motion at set `k` (s since the first instant `s`): σ0, Ω′, Ω.
    pub fn motion_at(&mut self, k: u32, s: f64) -> (Vec3<f64>, Vec3<f64>, Vec3<f64>) {
        let (sigma0, domega, omega) = match self.tumble.as_mut() {
            Some(tumble) => tumble.at(k),
            None => motion(s),
        };
        let sigma0 = if self.free_flight { [0.0; 3] } else { sigma0 };
        (sigma0, domega, omega)
    }

    /// The sample period, ns.
    pub fn period(&self) -> Nanos {
        self.period
    }

    /// The set of index `k`, at instant `t` (time base), `k` periods after the first.
    pub fn set(&mut self, k: u32, t: Nanos) -> SampleSet {
        let s = seconds(u64::from(k) * self.period);
        let (sigma0, domega, omega) = self.motion_at(k, s);
        let mut out = [None; MAX_PARTS];
        for (i, (chans, slot)) in self.channels.iter().zip(out.iter_mut()).enumerate() {
            let Some(h) = self.parts[i].as_mut() else {
                continue;
            };
            h.reads = h.reads.wrapping_add(1);
            if self
                .outage
                .is_some_and(|o| o.part == i && s >= o.from && s < o.to)
            {
                h.missed = h.missed.wrapping_add(1);
                self.silent[i] += 1;
                if self.silent[i] >= DOWN_AFTER {
                    h.running = false;
                }
                continue;
            }
            self.silent[i] = 0;
            h.running = true;
            if self
                .stuck
                .is_some_and(|o| o.part == i && s >= o.from && s < o.to)
            {
                *slot = Some(self.last[i]);
                continue;
            }
            let mut v = [0.0f32; 3];
            for (j, (x, g)) in v.iter_mut().zip(chans.iter()).enumerate() {
                let Some((r, axis, noise)) = g else { continue };
                // Paper eq. (4).
                let field = add(
                    &add(&sigma0, &cross(&domega, r)),
                    &cross(&omega, &cross(&omega, r)),
                );
                let n = noise * 1.732 * pseudo_uniform(k, (3 * i + j) as u32);
                *x = (dot(axis, &field) + n) as f32;
            }
            self.last[i] = v;
            *slot = Some(v);
        }
        self.health.sets = self.health.sets.wrapping_add(1);
        SampleSet::new(k, t, out)
    }

    /// Every counter.
    pub fn snapshot(&self) -> Health {
        Health {
            parts: self.parts,
            sampling: self.health,
        }
    }
}

/// A deterministic number in [-1, 1) from a sample index and a channel.
fn pseudo_uniform(k: u32, channel: u32) -> f64 {
    let mut x = (u64::from(k) << 8 | u64::from(channel)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    x ^= x >> 29;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 32;
    (x >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The sampling task of a board without parts: the set of each instant `t0 + k/rate` from
/// the built-in scenario, for `instants` instants (or for ever).
pub async fn synthetic_task<T: TimeBase, M: RawMutex, const Q: usize>(
    source: &mut Synthetic,
    time: &mut T,
    queue: Sender<'_, M, SampleSet, Q>,
    board: &HealthBoard<M>,
    t0: Nanos,
    instants: Option<u32>,
) {
    let mut k = 0u32;
    while instants.is_none_or(|n| k < n) {
        let t = t0 + u64::from(k) * source.period();
        time.wait_until(t).await;
        let set = source.set(k, t);
        if queue.try_send(set).is_err() {
            source.health.dropped = source.health.dropped.wrapping_add(1);
        }
        board.publish(source.snapshot());
        k += 1;
    }
}
