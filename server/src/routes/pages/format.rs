//! How numbers and text appear on the pages: percentages with one decimal, an en dash
//! where a value is undefined, sizes in binary units, text escaped for inline SVG.

/// A fraction in percent with one decimal, or an en dash where undefined.
pub fn percent(v: Option<f64>) -> String {
    v.map(|x| format!("{:.1}", 100.0 * x)).unwrap_or_else(|| "–".into())
}

/// A relative change in percent with its sign, or an en dash where undefined.
pub fn signed_percent(v: Option<f64>) -> String {
    v.map(|x| format!("{:+.1}%", 100.0 * x)).unwrap_or_else(|| "–".into())
}

/// A 95 % interval in percent (`lo–hi`), or an en dash.
pub fn interval(ci95: Option<[f64; 2]>) -> String {
    match ci95 {
        Some([lo, hi]) => format!("{:.1}–{:.1}", lo * 100.0, hi * 100.0),
        None => "–".into(),
    }
}

/// A byte count in binary units with one decimal (`12.3 MiB`).
pub fn human_size(bytes: u64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit < units.len() - 1 {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 { format!("{bytes} B") } else { format!("{value:.1} {}", units[unit]) }
}

/// Text made safe inside SVG markup.
pub fn escape_xml(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_as_the_paper_prints_them() {
        assert_eq!(percent(Some(0.4567)), "45.7");
        assert_eq!(percent(None), "–");
        assert_eq!(signed_percent(Some(-0.125)), "-12.5%");
        assert_eq!(interval(Some([0.25, 0.5])), "25.0–50.0");
        assert_eq!(human_size(1536), "1.5 KiB");
        assert_eq!(human_size(12), "12 B");
        assert_eq!(escape_xml("<a & \"b\">"), "&lt;a &amp; &quot;b&quot;&gt;");
    }
}
