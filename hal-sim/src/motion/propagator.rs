//! Truth at any instant: RK4 on a fixed grid of nodes `k h`, and one partial RK4 step from the
//! node at or before the requested time. Parts sample at their own (offset, jittered) instants
//! and several parts ask in slightly different orders, so recent nodes are kept.

use std::collections::VecDeque;

use estimator_core::linalg::Vec3;

use super::{Motion, Truth};

/// Nodes kept behind the newest one (requests older than this restart from t = 0).
const HISTORY: usize = 4096;

#[derive(Clone, Copy, Debug)]
struct Node {
    k: u64,
    q: [f64; 4],
    w: Vec3<f64>,
}

/// Integrates a [`Motion`] forward on demand and answers [`Truth`] at any time `t ≥ 0`.
pub struct Propagator {
    motion: Motion,
    h: f64,
    nodes: VecDeque<Node>,
}

impl Propagator {
    /// A propagator with grid step `h` (s; RK4, e.g. 2.5 ms for rates up to a few rad/s).
    pub fn new(motion: Motion, h: f64) -> Self {
        let mut q = motion.attitude0;
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        for v in q.iter_mut() {
            *v /= n;
        }
        let w = motion.initial_omega();
        let mut nodes = VecDeque::with_capacity(HISTORY);
        nodes.push_back(Node { k: 0, q, w });
        Propagator { motion, h, nodes }
    }

    /// The motion being integrated.
    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// The truth at time `t` (s). Times shortly before 0 (a part sampling just before a record
    /// starts) are reached by one backward step from 0.
    pub fn truth_at(&mut self, t: f64) -> Truth {
        let k = (t / self.h).floor().max(0.0) as u64;
        let node = self.node(k);
        let tk = node.k as f64 * self.h;
        let (q, w) = if t != tk {
            self.motion.rk4(tk, &node.q, &node.w, t - tk)
        } else {
            (node.q, node.w)
        };
        self.motion.truth(t, &q, &w)
    }

    /// Node `k`, integrating forward to it if needed.
    fn node(&mut self, k: u64) -> Node {
        let first = self.nodes.front().map_or(0, |n| n.k);
        if k < first {
            // Older than the history: start again from t = 0.
            let n0 = Propagator::new(self.motion.clone(), self.h).nodes[0];
            self.nodes.clear();
            self.nodes.push_back(n0);
        }
        loop {
            let last = *self.nodes.back().expect("the node list is never empty");
            if last.k >= k {
                let first = self.nodes.front().map_or(0, |n| n.k);
                return self.nodes[(k - first) as usize];
            }
            let t = last.k as f64 * self.h;
            let (q, w) = self.motion.rk4(t, &last.q, &last.w, self.h);
            if self.nodes.len() == HISTORY {
                self.nodes.pop_front();
            }
            self.nodes.push_back(Node {
                k: last.k + 1,
                q,
                w,
            });
        }
    }
}
