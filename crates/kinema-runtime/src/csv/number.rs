//! Fast shortest round-trip formatting of `f64` in the exact text of Rust's
//! `{:e}` — the number format of the CSV contract — for large CSVs (a 1000-body chain writes 9 million
//! numbers per 1000 steps).
//!
//! `ryu` finds the shortest digit string that reads back to the same `f64`,
//! as `{:e}` does; this module only rewrites its notation (`0.00123`,
//! `123.0`, `1.5e-7`) into `{:e}`'s (`1.23e-3`, `1.23e2`, `1.5e-7`). About
//! three times faster than `write!("{:e}")`. The text is `{:e}`'s except
//! when two shortest digit strings are exactly equally close to the value
//! (rare: under 1 in 1000 random bit patterns, none among the tests' mechanism-like
//! values): the two libraries may then pick different last digits, both of
//! which read back to the same `f64`.

use std::fmt::Write as _;

/// Appends `v` as `format!("{v:e}")` would.
pub(crate) fn push_e(out: &mut Vec<u8>, buffer: &mut ryu::Buffer, v: f64) {
    if !v.is_finite() || v == 0.0 {
        // NaN, ±inf, ±0: rare; the standard formatter.
        let mut s = String::new();
        let _ = write!(s, "{v:e}");
        out.extend_from_slice(s.as_bytes());
        return;
    }
    let text = buffer.format_finite(v).as_bytes();
    let (negative, text) = match text.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, text),
    };
    let (mantissa, exp10) = match text.iter().position(|&c| c == b'e') {
        Some(i) => (&text[..i], parse_exponent(&text[i + 1..])),
        None => (text, 0),
    };
    let point = mantissa
        .iter()
        .position(|&c| c == b'.')
        .unwrap_or(mantissa.len());
    // The digits without the point; the value is 0.d1d2… × 10^(point + exp10).
    let digits = mantissa.iter().copied().filter(u8::is_ascii_digit);
    let mut leading = 0i32;
    let mut significant: [u8; 32] = [0; 32];
    let mut len = 0usize;
    for d in digits {
        if len == 0 && d == b'0' {
            leading += 1;
            continue;
        }
        if len < significant.len() {
            significant[len] = d;
            len += 1;
        }
    }
    while len > 1 && significant[len - 1] == b'0' {
        len -= 1;
    }
    let exponent = point as i32 - 1 - leading + exp10;
    if negative {
        out.push(b'-');
    }
    out.push(significant[0]);
    if len > 1 {
        out.push(b'.');
        out.extend_from_slice(&significant[1..len]);
    }
    out.push(b'e');
    let mut e = itoa_buffer();
    out.extend_from_slice(format_i32(&mut e, exponent));
}

fn parse_exponent(text: &[u8]) -> i32 {
    let (negative, digits) = match text.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, text),
    };
    let value = digits
        .iter()
        .fold(0i32, |acc, &d| acc * 10 + i32::from(d.wrapping_sub(b'0')));
    if negative { -value } else { value }
}

fn itoa_buffer() -> [u8; 12] {
    [0; 12]
}

/// Formats a small integer into `buffer`, returning the written part.
fn format_i32(buffer: &mut [u8; 12], value: i32) -> &[u8] {
    let mut n = value.unsigned_abs();
    let mut i = buffer.len();
    loop {
        i -= 1;
        buffer[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    if value < 0 {
        i -= 1;
        buffer[i] = b'-';
    }
    &buffer[i..]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Same text as `{:e}` (true), or — an exact tie — the same length
    /// and the same value read back (false).
    fn check(v: f64) -> bool {
        let mut out = Vec::new();
        push_e(&mut out, &mut ryu::Buffer::new(), v);
        let ours = String::from_utf8_lossy(&out).into_owned();
        let theirs = format!("{v:e}");
        if ours == theirs {
            return true;
        }
        let back: f64 = ours.parse().unwrap_or(f64::NAN);
        assert!(
            back.to_bits() == v.to_bits() && ours.len() == theirs.len(),
            "bits {:#x}: {ours} vs {theirs}",
            v.to_bits()
        );
        false
    }

    #[test]
    fn same_text_as_the_standard_formatter() {
        for v in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            123.0,
            1e21,
            1e22,
            1.5e-7,
            1e-300,
            0.1 + 0.2,
            -1.0 / 3.0,
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            123456789012345680.0,
            0.000123,
            std::f64::consts::PI * 1e15,
        ] {
            assert!(check(v), "{v:e}");
        }
        // Random bit patterns (xorshift), across the whole exponent range:
        // ties are rare.
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut ties = 0;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            ties += usize::from(!check(f64::from_bits(x)));
        }
        assert!(ties < 200, "{ties} ties in 200000");
        // Values like a mechanism's: identical text.
        for k in 0..100_000 {
            let v = (f64::from(k) * 0.7361).sin() * 3.7;
            assert!(check(v), "{v:e}");
            assert!(check(v * 1e-3) && check(v * 100.0), "{v:e}");
        }
    }
}
