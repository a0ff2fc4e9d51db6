//! Answer text exactly as OSMa-Bench's judge sees it: `str(x).strip().lower()` in Python,
//! the yes/no test and the number test `re.match(r"^\d+(\.\d+)?$")`, with Python's own
//! definitions of whitespace and of a decimal digit (Unicode 14, as in Python 3.11).

use serde_json::Value;

/// Characters Python's `str.strip()` removes (`str.isspace()`).
const PYTHON_WHITESPACE: [char; 29] = [
    '\u{9}', '\u{a}', '\u{b}', '\u{c}', '\u{d}', '\u{1c}', '\u{1d}', '\u{1e}', '\u{1f}', '\u{20}', '\u{85}', '\u{a0}', '\u{1680}', '\u{2000}', '\u{2001}',
    '\u{2002}', '\u{2003}', '\u{2004}', '\u{2005}', '\u{2006}', '\u{2007}', '\u{2008}', '\u{2009}', '\u{200a}', '\u{2028}', '\u{2029}', '\u{202f}', '\u{205f}',
    '\u{3000}',
];

/// The ranges of Unicode category Nd, what Python's `\d` matches in a `str` pattern.
const DECIMAL_DIGITS: [(u32, u32); 62] = [
    (0x30, 0x39),
    (0x660, 0x669),
    (0x6f0, 0x6f9),
    (0x7c0, 0x7c9),
    (0x966, 0x96f),
    (0x9e6, 0x9ef),
    (0xa66, 0xa6f),
    (0xae6, 0xaef),
    (0xb66, 0xb6f),
    (0xbe6, 0xbef),
    (0xc66, 0xc6f),
    (0xce6, 0xcef),
    (0xd66, 0xd6f),
    (0xde6, 0xdef),
    (0xe50, 0xe59),
    (0xed0, 0xed9),
    (0xf20, 0xf29),
    (0x1040, 0x1049),
    (0x1090, 0x1099),
    (0x17e0, 0x17e9),
    (0x1810, 0x1819),
    (0x1946, 0x194f),
    (0x19d0, 0x19d9),
    (0x1a80, 0x1a89),
    (0x1a90, 0x1a99),
    (0x1b50, 0x1b59),
    (0x1bb0, 0x1bb9),
    (0x1c40, 0x1c49),
    (0x1c50, 0x1c59),
    (0xa620, 0xa629),
    (0xa8d0, 0xa8d9),
    (0xa900, 0xa909),
    (0xa9d0, 0xa9d9),
    (0xa9f0, 0xa9f9),
    (0xaa50, 0xaa59),
    (0xabf0, 0xabf9),
    (0xff10, 0xff19),
    (0x104a0, 0x104a9),
    (0x10d30, 0x10d39),
    (0x11066, 0x1106f),
    (0x110f0, 0x110f9),
    (0x11136, 0x1113f),
    (0x111d0, 0x111d9),
    (0x112f0, 0x112f9),
    (0x11450, 0x11459),
    (0x114d0, 0x114d9),
    (0x11650, 0x11659),
    (0x116c0, 0x116c9),
    (0x11730, 0x11739),
    (0x118e0, 0x118e9),
    (0x11950, 0x11959),
    (0x11c50, 0x11c59),
    (0x11d50, 0x11d59),
    (0x11da0, 0x11da9),
    (0x16a60, 0x16a69),
    (0x16ac0, 0x16ac9),
    (0x16b50, 0x16b59),
    (0x1d7ce, 0x1d7ff),
    (0x1e140, 0x1e149),
    (0x1e2f0, 0x1e2f9),
    (0x1e950, 0x1e959),
    (0x1fbf0, 0x1fbf9),
];

fn is_decimal_digit(c: char) -> bool {
    let c = c as u32;
    DECIMAL_DIGITS.iter().any(|&(lo, hi)| (lo..=hi).contains(&c))
}

/// Python's `str(value)` of a JSON value as `json.load` returns it.
pub fn python_str(value: &Value) -> String {
    match value {
        Value::String(s) => s.clone(),
        Value::Null => "None".into(),
        Value::Bool(true) => "True".into(),
        Value::Bool(false) => "False".into(),
        Value::Number(n) if n.is_f64() => python_float_repr(n.as_f64().unwrap_or(f64::NAN)),
        Value::Number(n) => n.to_string(),
        Value::Array(items) => format!("[{}]", items.iter().map(python_repr).collect::<Vec<_>>().join(", ")),
        Value::Object(map) => {
            format!("{{{}}}", map.iter().map(|(k, v)| format!("{}: {}", python_repr(&Value::String(k.clone())), python_repr(v))).collect::<Vec<_>>().join(", "))
        }
    }
}

/// Python's `repr` of a JSON value (inside lists and dicts).
fn python_repr(value: &Value) -> String {
    match value {
        Value::String(s) if s.contains('\'') && !s.contains('"') => format!("\"{s}\""),
        Value::String(s) => format!("'{}'", s.replace('\\', "\\\\").replace('\'', "\\'")),
        other => python_str(other),
    }
}

/// Python's `repr(float)`: the shortest round-trip digits, scientific when the decimal
/// exponent is below -4 or above 15, always with a dot or an exponent.
pub fn python_float_repr(x: f64) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    // `{:e}` gives the shortest round-trip digits: d.ddde±x.
    let sci = format!("{x:e}");
    let (mantissa, exponent) = sci.split_once('e').expect("{:e} has an exponent");
    let exponent: i32 = exponent.parse().expect("integer exponent");
    let (sign, mantissa) = mantissa.strip_prefix('-').map_or(("", mantissa), |m| ("-", m));
    let digits: String = mantissa.chars().filter(char::is_ascii_digit).collect();
    let decpt = exponent + 1; // value = 0.DIGITS × 10^decpt
    if !(-4 < decpt && decpt <= 16) {
        let rest = &digits[1..];
        let mantissa = if rest.is_empty() { digits[..1].to_string() } else { format!("{}.{rest}", &digits[..1]) };
        let sign_e = if exponent < 0 { '-' } else { '+' };
        return format!("{sign}{mantissa}e{sign_e}{:02}", exponent.abs());
    }
    if decpt <= 0 {
        format!("{sign}0.{}{digits}", "0".repeat((-decpt) as usize))
    } else if decpt as usize >= digits.len() {
        format!("{sign}{digits}{}.0", "0".repeat(decpt as usize - digits.len()))
    } else {
        format!("{sign}{}.{}", &digits[..decpt as usize], &digits[decpt as usize..])
    }
}

/// `str(value).strip().lower()`.
pub fn normalise(value: &Value) -> String {
    python_str(value).trim_matches(|c| PYTHON_WHITESPACE.contains(&c)).to_lowercase()
}

/// Exactly "yes" or "no" (of a normalised answer).
pub fn is_yes_no(normalised: &str) -> bool {
    normalised == "yes" || normalised == "no"
}

/// `^\d+(\.\d+)?$` (of a normalised answer, which has no trailing newline).
pub fn is_number(normalised: &str) -> bool {
    let (whole, fraction) = match normalised.split_once('.') {
        Some((w, f)) => (w, Some(f)),
        None => (normalised, None),
    };
    let digits = |s: &str| !s.is_empty() && s.chars().all(is_decimal_digit);
    digits(whole) && fraction.is_none_or(digits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn answers_normalise_as_python_str_strip_lower() {
        assert_eq!(normalise(&json!("  Yes\n")), "yes");
        assert_eq!(normalise(&json!("\u{1f}No\u{3000}")), "no", "Python strips the unit separators and ideographic space");
        assert_eq!(normalise(&json!(2)), "2");
        assert_eq!(normalise(&json!(2.0)), "2.0", "2 != 2.0 as in the reference");
        assert_eq!(normalise(&json!(true)), "true");
        assert_eq!(normalise(&json!(null)), "none");
        assert_eq!(normalise(&json!(["a", "b"])), "['a', 'b']");
    }

    #[test]
    fn floats_print_as_python_repr() {
        for (x, want) in [
            (0.5, "0.5"),
            (1e16, "1e+16"),
            (1234567890123456.0, "1234567890123456.0"),
            (1e-5, "1e-05"),
            (0.0001, "0.0001"),
            (-2.5e-7, "-2.5e-07"),
            (100.0, "100.0"),
            (0.1 + 0.2, "0.30000000000000004"),
        ] {
            assert_eq!(python_float_repr(x), want, "{x}");
        }
    }

    #[test]
    fn numbers_are_digits_with_an_optional_fraction() {
        for yes in ["0", "12", "3.50", "٣", "１２"] {
            assert!(is_number(yes), "{yes}");
        }
        for no in ["", "1.", ".5", "-1", "1e3", "1,000", "two", "1.2.3", "²"] {
            assert!(!is_number(no), "{no}");
        }
    }
}
