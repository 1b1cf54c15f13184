//! The boot count: boots since power was applied, kept in two words of RAM that a reset leaves
//! alone (the board's: `.uninit` on the STM32H743, memory beyond the image under QEMU) and a
//! power loss does not. The board reads its reset cause first; this module only counts.

pub use ballisto_link::{BootInfo, ResetCause};

/// Counts this boot in `retained` (the count and its complement, as the last boot left them)
/// and says which boot it is. After a power-on the words are not read (their contents are
/// whatever the RAM came up with): the count is 1. After any other reset the stored count
/// goes up by one if the pair is whole; if it is not (a first boot without power-on
/// detection, damaged RAM) the count is 0, "unknown", and stays 0 until the next power-on
/// rather than restart at a count that would look true.
pub fn count_boot(retained: &mut [u32; 2], cause: ResetCause) -> BootInfo {
    let count = if cause == ResetCause::PowerOn {
        1
    } else if retained[1] == !retained[0] && retained[0] != 0 {
        retained[0].saturating_add(1)
    } else {
        0
    };
    *retained = [count, !count];
    BootInfo { count, cause }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_resets_from_a_power_on_and_says_unknown_when_it_cannot() {
        // RAM after power-on: anything; a power-on does not read it.
        let mut words = [0xDEAD_BEEF, 0x1234_5678];
        assert_eq!(count_boot(&mut words, ResetCause::PowerOn).count, 1);
        assert_eq!(count_boot(&mut words, ResetCause::Software).count, 2);
        let third = count_boot(&mut words, ResetCause::Watchdog);
        assert_eq!((third.count, third.cause), (3, ResetCause::Watchdog));
        // A flipped bit in either word: unknown, and unknown until power-on.
        words[0] ^= 4;
        assert_eq!(count_boot(&mut words, ResetCause::Pin).count, 0);
        assert_eq!(count_boot(&mut words, ResetCause::Software).count, 0);
        assert_eq!(count_boot(&mut words, ResetCause::PowerOn).count, 1);
        // Erased or zeroed RAM without a power-on flag is not a count either.
        for mut w in [[0, 0], [u32::MAX, u32::MAX], [0, u32::MAX]] {
            assert_eq!(count_boot(&mut w, ResetCause::Unknown).count, 0);
        }
        // The count saturates rather than wrap to a plausible small number.
        let mut w = [u32::MAX - 1, !(u32::MAX - 1)];
        assert_eq!(count_boot(&mut w, ResetCause::Software).count, u32::MAX);
        assert_eq!(count_boot(&mut w, ResetCause::Software).count, u32::MAX);
    }
}
