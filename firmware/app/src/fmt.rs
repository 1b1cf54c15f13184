//! Logging without caring where it goes (as embassy's crates do): `trace!` … `error!` route to
//! `defmt` with the `defmt` feature (the STM32 board: RTT through the probe), to nothing
//! otherwise (the arguments are still evaluated by reference, so a log line never changes
//! what the code does). Formats use `{}` for numbers and `{:?}` for the types that derive
//! both `Debug` and `defmt::Format`.
#![macro_use]
#![allow(unused_macros)]

macro_rules! log_with {
    ($level:ident, $s:literal $(, $x:expr)* $(,)?) => {
        {
            #[cfg(feature = "defmt")]
            ::defmt::$level!($s $(, $x)*);
            #[cfg(not(feature = "defmt"))]
            let _ = ($( & $x ),*);
        }
    };
}

macro_rules! trace {
    ($($t:tt)*) => { log_with!(trace, $($t)*) };
}

macro_rules! debug {
    ($($t:tt)*) => { log_with!(debug, $($t)*) };
}

macro_rules! info {
    ($($t:tt)*) => { log_with!(info, $($t)*) };
}

macro_rules! warn {
    ($($t:tt)*) => { log_with!(warn, $($t)*) };
}

macro_rules! error {
    ($($t:tt)*) => { log_with!(error, $($t)*) };
}
