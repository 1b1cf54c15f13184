//! Time on the link: CCSDS unsegmented time code (CUC) 4+3 with the agency epoch at the unit's
//! boot.

/// CUC P-field: agency-defined epoch (time since boot), 4 coarse octets (s), 3 fine (2⁻²⁴ s).
pub const CUC_P_FIELD: u8 = 0x2F;
/// Length of the TM time field: the P-field and the 7-octet T-field.
pub const TIME_LEN: usize = 8;

/// Time field of a packet stamped `t` (nanoseconds since boot): CUC 4+3 with its P-field.
pub fn cuc(t: u64) -> [u8; TIME_LEN] {
    let coarse = (t / 1_000_000_000) as u32;
    let sub = t % 1_000_000_000;
    let fine = ((sub << 24) + 500_000_000) / 1_000_000_000;
    // Rounding can carry into the next second.
    let (coarse, fine) = if fine >> 24 != 0 {
        (coarse.wrapping_add(1), 0)
    } else {
        (coarse, fine as u32)
    };
    let c = coarse.to_be_bytes();
    let f = fine.to_be_bytes();
    [CUC_P_FIELD, c[0], c[1], c[2], c[3], f[1], f[2], f[3]]
}

/// The CUC 4+3 T-field of `t` (nanoseconds) as one number of 2⁻²⁴ s ticks (the coarse
/// seconds · 2²⁴ + the fine part, rounded as [`cuc`] rounds): what the time correlation is
/// reckoned in, so the unit subtracts and sends it without converting back.
pub fn cuc_ticks(t: u64) -> u64 {
    let [_, c0, c1, c2, c3, f0, f1, f2] = cuc(t);
    u64::from_be_bytes([0, c0, c1, c2, c3, f0, f1, f2])
}

/// The coarse (s) and fine (2⁻²⁴ s) parts of a CUC time field, or `None` if it is not the
/// unit's format.
fn parts(field: &[u8]) -> Option<(u32, u32)> {
    if field.len() != TIME_LEN || field[0] != CUC_P_FIELD {
        return None;
    }
    let coarse = u32::from_be_bytes([field[1], field[2], field[3], field[4]]);
    let fine = u32::from_be_bytes([0, field[5], field[6], field[7]]);
    Some((coarse, fine))
}

/// Seconds since boot of a CUC time field, or `None` if it is not the unit's format.
pub fn cuc_seconds(field: &[u8]) -> Option<f64> {
    let (coarse, fine) = parts(field)?;
    Some(f64::from(coarse) + f64::from(fine) / f64::from(1u32 << 24))
}

/// Nanoseconds since boot of a CUC time field (rounded to the nearest; the inverse of [`cuc`]
/// to its fine resolution), or `None` if it is not the unit's format.
pub fn cuc_nanos(field: &[u8]) -> Option<u64> {
    let (coarse, fine) = parts(field)?;
    let (coarse, fine) = (u64::from(coarse), u64::from(fine));
    Some(coarse * 1_000_000_000 + ((fine * 1_000_000_000 + (1 << 23)) >> 24))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cuc_round_trips_to_the_fine_resolution() {
        for t in [
            0u64,
            1,
            999_999_999,
            1_000_000_000,
            12_345_678_901,
            86_400_000_000_017,
        ] {
            let s = cuc_seconds(&cuc(t)).unwrap();
            assert!(
                (s - t as f64 / 1e9).abs() <= 0.5 / f64::from(1u32 << 24) + 1e-12,
                "{t}"
            );
        }
        assert_eq!(cuc(9_999_999_999)[1..], [0, 0, 0, 10, 0, 0, 0]);
        assert_eq!(cuc_seconds(&[0x2E, 0, 0, 0, 1, 0, 0, 0]), None);
    }
}
