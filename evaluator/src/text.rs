//! Names people choose (teams, methods) are shown on pages, in CSV and in terminals:
//! printable text only. Control characters and Unicode format characters (bidirectional
//! overrides such as U+202E, zero-width characters, the BOM, invisible tags) and line or
//! paragraph separators are refused, so a name always reads as what it is.

/// Whether `c` is a control (Cc), format (Cf), line (Zl) or paragraph (Zp) separator
/// character (Unicode 16 tables for Cf), or one that displays as nothing: variation
/// selectors, the combining grapheme joiner, Hangul and Khmer fillers, the blank
/// braille pattern — so two names that look alike are alike.
pub fn is_invisible(c: char) -> bool {
    c.is_control()
        || matches!(
            c as u32,
            0x00AD
                | 0x034F
                | 0x115F..=0x1160
                | 0x17B4..=0x17B5
                | 0x180B..=0x180F
                | 0x2800
                | 0x3164
                | 0xFE00..=0xFE0F
                | 0xFFA0
                | 0xE0100..=0xE01EF
                | 0x0600..=0x0605
                | 0x061C
                | 0x06DD
                | 0x070F
                | 0x0890..=0x0891
                | 0x08E2
                | 0x200B..=0x200F
                | 0x2028..=0x202E
                | 0x2060..=0x2064
                | 0x2066..=0x206F
                | 0xFEFF
                | 0xFFF9..=0xFFFB
                | 0x110BD
                | 0x110CD
                | 0x13430..=0x1343F
                | 0x1BCA0..=0x1BCA3
                | 0x1D173..=0x1D17A
                | 0xE0001
                | 0xE0020..=0xE007F
        )
}

/// What is wrong with `name` as a display name of 1 to `max_chars` characters (already
/// trimmed), if anything.
pub fn display_name_problem(name: &str, max_chars: usize) -> Option<String> {
    let count = name.chars().count();
    if count == 0 || count > max_chars {
        return Some(format!("expected 1 to {max_chars} printable characters, found {count}"));
    }
    name.chars()
        .find(|&c| is_invisible(c))
        .map(|c| format!("expected printable characters only, found U+{:04X} (a control or invisible formatting character)", c as u32))
}

/// Whether `text` (a description; line breaks and tabs allowed) holds a character that
/// changes how the text around it is displayed: bidirectional controls and other format
/// characters.
pub fn first_hidden_format(text: &str) -> Option<char> {
    text.chars().find(|&c| !matches!(c, '\n' | '\r' | '\t') && is_invisible(c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_with_bidi_overrides_zero_width_or_control_characters_are_refused() {
        assert_eq!(display_name_problem("ConceptGraphs (ours) – v2 ✓ 日本", 80), None);
        for evil in [
            "evil\u{202E}gnp.exe",
            "a\u{200B}b",
            "\u{FEFF}name",
            "tab\there",
            "line\u{2028}break",
            "tag\u{E0041}",
            "alpha\u{FE0F}",
            "alpha\u{17B4}",
            "beta\u{034F}",
            "\u{3164}",
            "\u{2800}\u{2800}",
            "\u{115F}\u{1160}",
            "\u{180B}",
        ] {
            let problem = display_name_problem(evil, 80).unwrap_or_else(|| panic!("{evil:?} accepted"));
            assert!(problem.contains("U+"), "{problem}");
        }
        assert!(display_name_problem("", 80).unwrap().contains("1 to 80"));
        assert!(display_name_problem(&"x".repeat(81), 80).unwrap().contains("found 81"));
        assert_eq!(first_hidden_format("line one\nline two\tend"), None);
        assert_eq!(first_hidden_format("abc\u{2066}def"), Some('\u{2066}'));
    }
}
