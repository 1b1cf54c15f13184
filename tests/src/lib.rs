//! Shared pieces of the end-to-end tests: test cases (arrangement families × motions), a slow
//! f64 multi-start maximum-likelihood reference, error statistics, scenarios' records, and
//! scenarios drawn at random for the identification.

pub mod board;
pub mod cases;
pub mod csv;
pub mod drawn;
pub mod fault_matrix;
pub mod faults;
pub mod frame;
pub mod ml;
pub mod nine;
pub mod recorded;
pub mod report;
pub mod stats;
