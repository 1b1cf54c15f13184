//! The crate's internals, for its own tests and benchmarks only: not part of the interface,
//! and free to change. The rest of the crate reaches them as `crate::design` etc.

pub mod design;
pub mod quadratic;
pub mod svd;
pub mod tracker;
