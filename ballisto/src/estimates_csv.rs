//! The estimates file (interfaces.md) and the truth file share these column names.

use std::io::Write;

use estimator_core::{Estimate, Real};

/// The contract columns, in order (interfaces.md).
pub const COLUMNS: [&str; 17] = [
    "t", "sigma0_x", "sigma0_y", "sigma0_z", "domega_x", "domega_y", "domega_z", "omega_x",
    "omega_y", "omega_z", "A_xx", "A_yy", "A_zz", "A_xy", "A_xz", "A_yz", "flags",
];

/// Extra columns that follow the contract ones.
pub const EXTRA_COLUMNS: [&str; 20] = [
    "chi2",
    "dof",
    "branches",
    "frame",
    "sd_sigma0_x",
    "sd_sigma0_y",
    "sd_sigma0_z",
    "sd_domega_x",
    "sd_domega_y",
    "sd_domega_z",
    "sd_omega_x",
    "sd_omega_y",
    "sd_omega_z",
    "epsilon",
    "sd_A_xx",
    "sd_A_yy",
    "sd_A_zz",
    "sd_A_xy",
    "sd_A_xz",
    "sd_A_yz",
];

/// Writes the header line.
pub fn write_header<W: Write>(w: &mut W) -> std::io::Result<()> {
    writeln!(w, "{},{}", COLUMNS.join(","), EXTRA_COLUMNS.join(","))
}

/// Writes one row.
pub fn write_row<W: Write, T: Real>(w: &mut W, t: f64, e: &Estimate<T>) -> std::io::Result<()> {
    let f = |x: T| x.to_f64();
    let a = &e.field.0;
    write!(w, "{t}")?;
    for v in e.sigma0.iter().chain(e.domega.iter()).chain(e.omega.iter()) {
        write!(w, ",{}", f(*v))?;
    }
    for v in a.iter() {
        write!(w, ",{}", f(*v))?;
    }
    write!(w, ",{}", e.flags.0)?;
    write!(w, ",{},{},{},{}", f(e.chi2), e.dof, e.branches, e.frame)?;
    for v in e
        .sd_sigma0
        .iter()
        .chain(e.sd_domega.iter())
        .chain(e.sd_omega.iter())
    {
        write!(w, ",{}", f(*v))?;
    }
    write!(w, ",{}", e.epsilon)?;
    for v in e.sd_field.0.iter() {
        write!(w, ",{}", f(*v))?;
    }
    writeln!(w)
}
