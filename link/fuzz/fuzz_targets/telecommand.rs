//! Arbitrary octets as a received telecommand: the parser must answer every input with an
//! accepted command or a refusal, never panic (the first octet also picks the channel count
//! the ranges are checked against).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = ballisto_link::telecommand::fuzz_one(data);
});
