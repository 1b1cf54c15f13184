//! Sets of part slots and of channels as the link carries them: bit `i` (value 2^i) is part
//! slot `i` (the order of the configuration) or channel `i` (the order of the arrangement).
//! Two types, so a part set is never taken for a channel set.

macro_rules! bit_set {
    ($(#[$doc:meta])* $name:ident, $bits:ty, $what:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct $name(pub $bits);

        impl $name {
            /// The empty set.
            pub const EMPTY: Self = $name(0);

            #[doc = concat!("Whether ", $what, " `i` is in the set (false beyond the width).")]
            pub const fn contains(self, i: usize) -> bool {
                i < <$bits>::BITS as usize && self.0 & (1 << i) != 0
            }

            #[doc = concat!("The set with ", $what, " `i` added (unchanged beyond the width).")]
            #[must_use]
            pub const fn with(self, i: usize) -> Self {
                if i < <$bits>::BITS as usize {
                    $name(self.0 | (1 << i))
                } else {
                    self
                }
            }

            #[doc = concat!("The set with ", $what, " `i` removed.")]
            #[must_use]
            pub const fn without(self, i: usize) -> Self {
                if i < <$bits>::BITS as usize {
                    $name(self.0 & !(1 << i))
                } else {
                    self
                }
            }

            /// No member.
            pub const fn is_empty(self) -> bool {
                self.0 == 0
            }

            /// Members of `self` not in `other`.
            #[must_use]
            pub const fn minus(self, other: Self) -> Self {
                $name(self.0 & !other.0)
            }
        }
    };
}

bit_set!(
    /// A set of part slots (at most 8).
    PartSet,
    u8,
    "part slot"
);

bit_set!(
    /// A set of channels (at most 32).
    ChannelSet,
    u32,
    "channel"
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn members_come_and_go_within_the_width() {
        let s = PartSet::EMPTY.with(0).with(7).with(8);
        assert_eq!(s, PartSet(0x81));
        assert!(s.contains(7) && !s.contains(8) && !s.contains(1));
        assert_eq!(s.without(0), PartSet(0x80));
        assert!(PartSet::EMPTY.is_empty());
        let c = ChannelSet(0b1011);
        assert_eq!(c.minus(ChannelSet(0b0011)), ChannelSet(0b1000));
        assert!(c.with(31).contains(31) && !c.contains(32));
    }
}
