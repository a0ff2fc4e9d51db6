//! Names people choose (teams, methods) are shown on pages, in CSV and in terminals:
//! printable text only. Control characters and Unicode format characters (bidirectional
//! overrides such as U+202E, zero-width characters, the BOM, invisible tags), line or
//! paragraph separators and stacks of combining marks are refused, so a name always reads as
//! what it is; and a name that looks like a reserved one (a Cyrillic "Аnonymous", a
//! "baseIine-oracle") is told apart by its UTS #39 skeleton.

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

/// Combining marks a name may stack on one character (enough for Vietnamese "ệ" written
/// with two marks); more is "Zalgo" text that spills over the lines around it.
pub const MAX_STACKED_MARKS: usize = 2;

/// Whether `c` is a combining diacritical mark of the blocks that stack on any letter
/// (Combining Diacritical Marks and their Extended and Supplement blocks, marks for symbols,
/// half marks).
fn is_stacking_mark(c: char) -> bool {
    matches!(c as u32, 0x0300..=0x036F | 0x1AB0..=0x1AFF | 0x1DC0..=0x1DFF | 0x20D0..=0x20FF | 0xFE20..=0xFE2F)
}

/// What is wrong with `name` as a display name of 1 to `max_chars` characters (already
/// trimmed), if anything.
pub fn display_name_problem(name: &str, max_chars: usize) -> Option<String> {
    let count = name.chars().count();
    if count == 0 || count > max_chars {
        return Some(format!("expected 1 to {max_chars} printable characters, found {count}"));
    }
    if let Some(c) = name.chars().find(|&c| is_invisible(c)) {
        return Some(format!("expected printable characters only, found U+{:04X} (a control or invisible formatting character)", c as u32));
    }
    let mut stacked = 0;
    for c in name.chars() {
        stacked = if is_stacking_mark(c) { stacked + 1 } else { 0 };
        if stacked > MAX_STACKED_MARKS {
            return Some(format!("expected at most {MAX_STACKED_MARKS} combining marks on a character, found more (U+{:04X})", c as u32));
        }
    }
    None
}

/// Whether `text` (a description; line breaks and tabs allowed) holds a character that
/// changes how the text around it is displayed: bidirectional controls and other format
/// characters.
pub fn first_hidden_format(text: &str) -> Option<char> {
    text.chars().find(|&c| !matches!(c, '\n' | '\r' | '\t') && is_invisible(c))
}

/// The forms two names share when they look alike: UTS #39 skeletons, case folded, with
/// spaces and word-separating punctuation (`-`, `_`, `.`, dashes) dropped — taken before and
/// after folding, as case matters both ways (`baseIine` with a capital I reads "baseline",
/// `BASELINE` is "baseline" although its I alone would read as an l).
pub fn look_alike_keys(name: &str) -> [String; 2] {
    let skeleton = |text: &str| -> String { unicode_security::skeleton(text).collect() };
    let key = |text: &str| -> String {
        skeleton(&skeleton(text).to_lowercase()).chars().filter(|c| !(c.is_whitespace() || matches!(c, '-' | '_' | '.' | '\u{2010}'..='\u{2015}'))).collect()
    };
    [key(name), key(&name.to_lowercase())]
}

/// Whether `name` looks like `reserved` (a skeleton in common) or, with `prefix`, starts
/// like it.
pub fn impersonates(name: &str, reserved: &str, prefix: bool) -> bool {
    let (names, reserved) = (look_alike_keys(name), look_alike_keys(reserved));
    names.iter().any(|n| reserved.iter().any(|r| if prefix { n.starts_with(r.as_str()) } else { n == r }))
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
        assert_eq!(display_name_problem("Nguyễn Thị Ánh – Việt", 80), None, "two marks on a letter are fine");
        let zalgo = format!("Z{}algo", "\u{0301}".repeat(79));
        assert!(display_name_problem(&zalgo, 200).unwrap().contains("combining marks"));
        assert!(display_name_problem(&"x".repeat(81), 80).unwrap().contains("found 81"));
        assert_eq!(first_hidden_format("line one\nline two\tend"), None);
        assert_eq!(first_hidden_format("abc\u{2066}def"), Some('\u{2066}'));
    }

    #[test]
    fn names_that_look_like_reserved_ones_are_told_apart_by_their_skeleton() {
        for lookalike in ["Anonymous", "anonymous", "\u{0410}nonymous", "ANONYM0US", "Anonymоus", "anon ymous", "Аnоnуmоus"] {
            assert!(impersonates(lookalike, "Anonymous", false), "{lookalike}");
        }
        assert!(!impersonates("Anonymous Lab", "Anonymous", false));
        for lookalike in ["baseline-oracle", "Baseline Oracle", "baseIine-oracle", "bаseline_x", "BASELINE"] {
            assert!(impersonates(lookalike, "baseline", true), "{lookalike}");
        }
        assert!(!impersonates("ConceptGraphs", "baseline", true));
        assert!(!impersonates("my baseline", "baseline", true), "only names that start like one");
    }
}
