//! Floating-point summation and formatting exactly as NumPy and Python do them.
//!
//! The published OSMa-Bench figures are reproduced bit for bit only when every
//! float64 sum uses NumPy's pairwise summation and values print as Python `repr`.
//! Keep every such sum in this one module.

/// Block size of NumPy's pairwise summation (`PW_BLOCKSIZE`).
const PAIRWISE_BLOCK: usize = 128;

/// `np.sum` of a contiguous float64 array: NumPy's pairwise summation.
pub fn pairwise_sum(values: &[f64]) -> f64 {
    let n = values.len();
    if n < 8 {
        let mut sum = 0.0;
        for &v in values {
            sum += v;
        }
        sum
    } else if n <= PAIRWISE_BLOCK {
        let mut r = [0.0f64; 8];
        r.copy_from_slice(&values[..8]);
        let blocked = n - n % 8;
        let mut i = 8;
        while i < blocked {
            for (j, acc) in r.iter_mut().enumerate() {
                *acc += values[i + j];
            }
            i += 8;
        }
        let mut sum = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for &v in &values[blocked..] {
            sum += v;
        }
        sum
    } else {
        let mut half = n / 2;
        half -= half % 8;
        pairwise_sum(&values[..half]) + pairwise_sum(&values[half..])
    }
}

/// `np.mean` of a float64 array (NaN for an empty one, as NumPy).
pub fn mean(values: &[f64]) -> f64 {
    pairwise_sum(values) / values.len() as f64
}

/// pandas `Series.mean()`: NaN entries are skipped (summed as 0.0 in place, counted out).
pub fn nan_skipping_mean(values: &[f64]) -> f64 {
    let count = values.iter().filter(|v| !v.is_nan()).count();
    if count == 0 {
        return f64::NAN;
    }
    let zeroed: Vec<f64> = values.iter().map(|&v| if v.is_nan() { 0.0 } else { v }).collect();
    pairwise_sum(&zeroed) / count as f64
}

/// Python's `repr(float)`: the shortest string that round-trips, in Python's layout
/// (`0.1`, `1.0`, `1e-05`, `1.5e+16`, `nan`, `inf`).
pub fn python_repr(x: f64) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    if x == 0.0 {
        return if x.is_sign_negative() { "-0.0".into() } else { "0.0".into() };
    }
    // Rust's `{:e}` gives the shortest round-trip digits, e.g. "-1.234e-5".
    let sci = format!("{x:e}");
    let (mantissa, exponent) = sci.split_once('e').expect("LowerExp always has an exponent");
    let exponent: i32 = exponent.parse().expect("LowerExp exponent is an integer");
    let (sign, mantissa) = match mantissa.strip_prefix('-') {
        Some(rest) => ("-", rest),
        None => ("", mantissa),
    };
    let digits: String = mantissa.chars().filter(|c| *c != '.').collect();
    if (-4..16).contains(&exponent) {
        let point = exponent + 1; // digits before the decimal point
        let body = if point <= 0 {
            format!("0.{}{}", "0".repeat((-point) as usize), digits)
        } else if point as usize >= digits.len() {
            format!("{}{}.0", digits, "0".repeat(point as usize - digits.len()))
        } else {
            let (int, frac) = digits.split_at(point as usize);
            format!("{int}.{frac}")
        };
        format!("{sign}{body}")
    } else {
        let (first, rest) = digits.split_at(1);
        let mantissa = if rest.is_empty() { first.to_string() } else { format!("{first}.{rest}") };
        format!("{sign}{mantissa}{}", c_exponent(exponent))
    }
}

/// An exponent as C's `printf` and Python write it: `e+05`, `e-12`, `e+123`.
pub fn c_exponent(exponent: i32) -> String {
    let sign = if exponent < 0 { '-' } else { '+' };
    format!("e{sign}{:02}", exponent.unsigned_abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn python_repr_matches_python_layout() {
        let cases = [
            (0.16071977830389797, "0.16071977830389797"),
            (1.0, "1.0"),
            (100.0, "100.0"),
            (0.5, "0.5"),
            (0.0001, "0.0001"),
            (0.00001, "1e-05"),
            (1.5e-7, "1.5e-07"),
            (1e16, "1e+16"),
            (1234567890123456.0, "1234567890123456.0"),
            (-0.25, "-0.25"),
            (f64::NAN, "nan"),
            (0.0, "0.0"),
        ];
        for (value, expected) in cases {
            assert_eq!(python_repr(value), expected, "repr of {value:e}");
        }
    }

    #[test]
    fn pairwise_sum_uses_numpy_blocking() {
        // Below 8 elements the sum is sequential from 0.0.
        assert_eq!(pairwise_sum(&[0.1, 0.2, 0.3]), (0.0 + 0.1) + 0.2 + 0.3);
        // 8..=128 elements: eight accumulators, combined as a tree.
        // 8..=128 elements: eight accumulators over whole blocks of 8, combined as a
        // tree, then the remainder added one by one.
        let v: Vec<f64> = (0..20).map(|i| 0.1 * i as f64 + 1e-3).collect();
        let r: Vec<f64> = (0..8).map(|j| v[j] + v[j + 8]).collect();
        let tree = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        let expected = tree + v[16] + v[17] + v[18] + v[19];
        assert_eq!(pairwise_sum(&v), expected);
        // Above 128 the array is split at a multiple of 8 near the middle.
        let big: Vec<f64> = (0..300).map(|i| (i as f64).sqrt()).collect();
        assert_eq!(pairwise_sum(&big), pairwise_sum(&big[..144]) + pairwise_sum(&big[144..]));
    }

    #[test]
    fn nan_skipping_mean_ignores_nan_rows() {
        assert_eq!(nan_skipping_mean(&[1.0, f64::NAN, 2.0]), 1.5);
        assert!(nan_skipping_mean(&[f64::NAN]).is_nan());
    }
}
