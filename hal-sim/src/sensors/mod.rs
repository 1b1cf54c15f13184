//! Register-level models of MEMS accelerometers, seen by the firmware only through a simulated
//! bus ([`crate::bus`]). Each part samples the motion at its own ODR instants (its clock has a
//! ppm offset and jitter), applies its error model and quantises as the real part does.
//!
//! - [`adxl355`]: Analog Devices ADXL355, 20-bit, SPI.
//! - [`lis3dh`]: STMicroelectronics LIS3DH, 8/10/12-bit, I²C.

pub mod adxl355;
pub mod errors;
pub mod frontend;
pub mod lis3dh;
pub mod sample_clock;
pub mod sync_line;
pub mod thermal;

pub use errors::SensorErrors;

/// The true specific force along the part's own x, y, z axes (m/s²) at a time (s).
pub type ForceSource = Box<dyn FnMut(f64) -> [f64; 3]>;
