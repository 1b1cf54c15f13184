//! Numbers as the files write them, fast: the same text as Rust's `Display` (shortest
//! round-trip digits, never an exponent), built from the shortest digits of the `zmij` crate
//! (Schubfach, as `ryu` but faster: 17 ns against 26 ns per value measured on 37 × 10⁶ values
//! like an estimates row's) instead of `core::fmt`'s Grisu/Dragon path. Measured: `core::fmt`
//! float formatting was the largest cost of `ballisto estimate` (≈ 27 % of 6.5 s for 10⁶ rows,
//! `perf`); the test below checks the text is identical on specials, boundaries and millions of
//! random values.

/// Appends `v` as `format!("{v}")` would.
pub(crate) fn push_f64(out: &mut Vec<u8>, v: f64) {
    if !v.is_finite() {
        // NaN and infinities: rare, and std's text is the reference.
        out.extend_from_slice(format!("{v}").as_bytes());
        return;
    }
    let mut buf = zmij::Buffer::new();
    let s = buf.format_finite(v).as_bytes();
    let (negative, s) = match s.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, s),
    };
    if let Some(dot) = s.iter().position(|&b| b == b'.') {
        if !s.contains(&b'e') && push_plain(out, v, negative, &s[..dot], &s[dot + 1..]) {
            return;
        }
    }
    let (mantissa, exp) = match s.iter().position(|&b| b == b'e') {
        Some(i) => (&s[..i], parse_exp(&s[i + 1..])),
        None => (s, 0),
    };
    // Digits without the point; `point` = digits before it.
    let mut digits = [0u8; 32];
    let mut n = 0;
    let mut point = None;
    for &b in mantissa {
        if b == b'.' {
            point = Some(n);
        } else if n < digits.len() {
            digits[n] = b;
            n += 1;
        }
    }
    let point = point.unwrap_or(n) as i32;
    // value = 0.D × 10^k with D the significant digits.
    let lead = digits[..n].iter().take_while(|&&d| d == b'0').count();
    let trail = digits[lead..n]
        .iter()
        .rev()
        .take_while(|&&d| d == b'0')
        .count();
    let d = &digits[lead..n - trail];
    let k = point - lead as i32 + exp;
    let len = d.len() as i32;
    if len > 0 && may_be_tie(v, k, len) {
        // The exact value may lie halfway between two shortest candidates: the digit generator then rounds
        // to even, `Display` away from zero. Leave those few to `Display`.
        out.extend_from_slice(format!("{v}").as_bytes());
        return;
    }
    if negative {
        out.push(b'-');
    }
    if d.is_empty() {
        out.push(b'0');
        return;
    }
    if k <= 0 {
        out.extend_from_slice(b"0.");
        out.extend(std::iter::repeat_n(b'0', (-k) as usize));
        out.extend_from_slice(d);
    } else if k >= len {
        out.extend_from_slice(d);
        out.extend(std::iter::repeat_n(b'0', (k - len) as usize));
    } else {
        out.extend_from_slice(&d[..k as usize]);
        out.push(b'.');
        out.extend_from_slice(&d[k as usize..]);
    }
}

/// Whether the exact value of `v` can be a tie for its shortest digits (`len` significant
/// digits, the point after `k` of them): only if its exact decimal expansion is one digit
/// longer. `v = m·2^e` (m odd) has exactly `-e` fractional decimal digits when `e < 0`, and
/// is an integer otherwise (then a tie needs digits beyond the shortest ones: `k > len`).
fn may_be_tie(v: f64, k: i32, len: i32) -> bool {
    let bits = v.to_bits();
    let exponent = ((bits >> 52) & 0x7FF) as i32;
    let fraction = bits & ((1u64 << 52) - 1);
    let (m, e) = if exponent == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1u64 << 52), exponent - 1075)
    };
    if m == 0 {
        return false;
    }
    let e = e + m.trailing_zeros() as i32;
    if e >= 0 {
        k > len
    } else {
        -e == len - k + 1
    }
}

/// The common case: the digit generator wrote `int.frac` without an exponent (its shortest digits, `frac`
/// "0" for an integer). `Display` writes the same without a `.0`. Returns `false` (nothing
/// written) when the value may be a tie (see [`may_be_tie`]).
fn push_plain(out: &mut Vec<u8>, v: f64, negative: bool, int: &[u8], frac: &[u8]) -> bool {
    let integral = frac == b"0";
    let (k, len) = if int == b"0" {
        if integral {
            // Zero.
            (0, 0)
        } else {
            let lead = frac.iter().take_while(|&&d| d == b'0').count() as i32;
            (-lead, frac.len() as i32 - lead)
        }
    } else if integral {
        let trail = int.iter().rev().take_while(|&&d| d == b'0').count();
        (int.len() as i32, (int.len() - trail) as i32)
    } else {
        (int.len() as i32, (int.len() + frac.len()) as i32)
    };
    if len > 0 && may_be_tie(v, k, len) {
        return false;
    }
    if negative {
        out.push(b'-');
    }
    out.extend_from_slice(int);
    if !integral {
        out.push(b'.');
        out.extend_from_slice(frac);
    }
    true
}

fn parse_exp(s: &[u8]) -> i32 {
    let (neg, s) = match s.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, s),
    };
    let v = s
        .iter()
        .fold(0i32, |a, &b| a * 10 + i32::from(b.wrapping_sub(b'0')));
    if neg {
        -v
    } else {
        v
    }
}

/// Appends an integer as `Display` would.
pub(crate) fn push_int(out: &mut Vec<u8>, v: impl itoa::Integer) {
    out.extend_from_slice(itoa::Buffer::new().format(v).as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(v: f64) {
        let mut out = Vec::new();
        push_f64(&mut out, v);
        assert_eq!(std::str::from_utf8(&out).unwrap(), format!("{v}"), "{v:e}");
    }

    #[test]
    fn same_text_as_display() {
        for v in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            0.5,
            100.0,
            1e15,
            1e16,
            1e17,
            1.5e300,
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            -2.2250738585072014e-308,
            123456789012345680.0,
            0.000001,
            1e-7,
            1e23,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ] {
            check(v);
        }
        // Random bit patterns (every exponent), random f32 values widened (the firmware's
        // estimates), and decimal-looking values (times, readings).
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for _ in 0..1_000_000 {
            let r = next();
            check(f64::from_bits(r));
            check(f64::from(f32::from_bits(r as u32)));
            check((r % 2_000_001) as f64 / 100.0 - 10_000.0);
            check(((r >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 20.0);
        }
    }

    #[test]
    fn integers_as_display() {
        let mut out = Vec::new();
        push_int(&mut out, -7i8);
        out.push(b',');
        push_int(&mut out, 65535u16);
        assert_eq!(out, b"-7,65535");
    }
}
