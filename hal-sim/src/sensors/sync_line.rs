//! A synchronisation line (e.g. the ADXL355 SYNC pin of several parts wired to one controller
//! output): the controller pulses it, each part connected to it sees every pulse in order when
//! it next catches up with the time.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

/// Pulses kept on the line for parts that have not caught up yet.
const KEEP: usize = 4096;

#[derive(Default)]
struct Line {
    /// Pulses ever sent.
    count: u64,
    /// The most recent pulse times.
    recent: VecDeque<f64>,
}

/// A shared synchronisation line (cheap to clone: clones are the same wire).
#[derive(Clone, Default)]
pub struct SyncLine(Rc<RefCell<Line>>);

impl SyncLine {
    /// A line with no pulses.
    pub fn new() -> Self {
        Self::default()
    }

    /// A pulse at time `t` (s).
    pub fn pulse(&self, t: f64) {
        let mut l = self.0.borrow_mut();
        if l.recent.len() == KEEP {
            l.recent.pop_front();
        }
        l.recent.push_back(t);
        l.count += 1;
    }

    /// Pulses ever sent.
    pub fn count(&self) -> u64 {
        self.0.borrow().count
    }

    /// The pulses after the first `seen` up to time `now`, oldest first; advances `seen`.
    pub fn take_since(&self, seen: &mut u64, now: f64) -> Vec<f64> {
        let l = self.0.borrow();
        let first = l.count - l.recent.len() as u64;
        let mut out = Vec::new();
        let start = (*seen).max(first);
        for (i, t) in l.recent.iter().enumerate().skip((start - first) as usize) {
            if *t > now {
                break;
            }
            out.push(*t);
            *seen = first + i as u64 + 1;
        }
        *seen = (*seen).max(start);
        out
    }
}
