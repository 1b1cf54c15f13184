//! The identification in an image built without it (feature `identification` off): the same
//! interface, nothing started, nothing solved — so that none of its code is in the image.

use ballisto_link::identification::{IdentificationSummary, ReferencePoint};
use estimator_core::identify::{Identified, IdentifyError};
use estimator_core::Arrangement;

use super::Counters;
use crate::config::MAX_CHANNELS;
use crate::time::Nanos;

/// No identification.
#[derive(Default)]
pub struct Identification;

impl Identification {
    /// No window.
    pub const fn new() -> Self {
        Identification
    }

    /// Starts nothing (the link's acceptance refuses the command before: unknown).
    pub fn start(&mut self, _: Nanos, _: u16, _: u32, _: usize, _: f32) {}

    /// Never started.
    pub fn started(&self) -> bool {
        false
    }

    /// Ignores the set.
    pub fn on_set(&mut self, _: Nanos, _: &[f32]) {}

    /// Ignores the points.
    pub fn on_points(&mut self, _: impl Iterator<Item = ReferencePoint>) {}

    /// No window to solve.
    pub fn solve(
        &mut self,
        _: &Arrangement<MAX_CHANNELS>,
    ) -> Result<(&Identified<MAX_CHANNELS>, IdentificationSummary), Option<IdentifyError>> {
        Err(None)
    }

    /// No solution.
    pub fn solution(&self, _: u16) -> Option<&Identified<MAX_CHANNELS>> {
        None
    }

    /// Nothing counted.
    pub fn counters(&self) -> Counters {
        Counters::default()
    }
}
