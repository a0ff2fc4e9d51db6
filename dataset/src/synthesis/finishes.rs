//! Which finish an instance is drawn in. A class's palette (the class table's `finishes`)
//! gives a set of colour names; the name is drawn evenly among them and then a finish of
//! that name, so within a class every colour name is equally likely: a class tells nothing
//! of an instance's colour, and a colour asked about tells nothing of the answer.

use osmab_evaluator::synthetic::Rng;

use crate::classes::{Colouring, Finish, PrintTone, table};

/// How an instance's pack texture is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Look {
    /// In its own colours (a screen, leaves, a clock's face).
    Own,
    /// Its main material recoloured in a finish of its class's palette.
    Finish(&'static Finish),
    /// Its own print toned (a book's cover art, in a cover tone), or for a picture a print
    /// drawn from `art` in a print tone ([`super::artwork`]).
    Print { tone: &'static PrintTone, art: u64 },
}

impl Look {
    /// What a description says of it: " in oak", " printed in sepia", or nothing.
    pub fn described(&self) -> String {
        match self {
            Look::Own => String::new(),
            Look::Finish(f) => format!(" in {}", f.name.replace('_', " ")),
            Look::Print { tone, .. } => format!(" printed in {}", tone.name.replace('_', " ")),
        }
    }
}

/// The look of an instance of `category` drawn from the state of `rng` without advancing
/// it: a finish ([`finish_drawn`]), a print tone drawn evenly for a class of prints (a cover
/// tone for a class of covers), or its own colours.
pub fn look_drawn(category: &str, rng: &Rng) -> Look {
    let tones = match table().class(category).map(|c| &c.colouring) {
        Some(Colouring::Print) => table().print_tones(),
        Some(Colouring::Cover) => table().cover_tones(),
        _ => &[],
    };
    if tones.is_empty() {
        return finish_drawn(category, rng).map_or(Look::Own, Look::Finish);
    }
    let mut draw = Rng::new(rng.clone().next_u64() ^ 0x9_1217);
    let tone = &tones[draw.below(tones.len())];
    Look::Print { tone, art: draw.next_u64() }
}

/// The finish of an instance of `category` drawn from the state of `rng` without advancing
/// it (sizes and layouts stay those of the seed); `None` for classes that keep their own
/// colours or are not in the table.
pub fn finish_drawn(category: &str, rng: &Rng) -> Option<&'static Finish> {
    let class = table().class(category)?;
    let names = class.colour_names();
    if matches!(class.colouring, Colouring::Own) || names.is_empty() {
        return None;
    }
    let mut draw = Rng::new(rng.clone().next_u64() ^ 0xF1_215E);
    let name = names[draw.below(names.len())];
    let of_name: Vec<&'static Finish> = class.finishes().into_iter().filter(|f| f.colour_name() == Some(name)).collect();
    Some(of_name[draw.below(of_name.len())])
}

/// Whether instances of `category` keep their texture's own colours (no colour is asked).
pub fn keeps_own_colours(category: &str) -> bool {
    table().class(category).is_none_or(|c| matches!(c.colouring, Colouring::Own | Colouring::Print | Colouring::Cover))
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    #[test]
    fn every_colour_name_of_a_class_is_drawn_about_equally_often() {
        for class in ["sofa", "dining table", "mug", "office chair", "storage rack"] {
            let names = table().class(class).unwrap().colour_names();
            let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
            let mut rng = Rng::new(7);
            let draws = 4000;
            for _ in 0..draws {
                rng.next_u64();
                *counts.entry(finish_drawn(class, &rng).unwrap().colour_name().unwrap()).or_default() += 1;
            }
            assert_eq!(counts.len(), names.len(), "{class}: every name is drawn");
            let expected = draws as f64 / names.len() as f64;
            for (name, n) in counts {
                assert!((n as f64 - expected).abs() < 0.2 * expected, "{class}: {name} drawn {n} times, about {expected:.0} expected");
            }
        }
    }

    #[test]
    fn classes_of_own_colours_get_no_finish_and_drawing_does_not_advance_the_generator() {
        let rng = Rng::new(3);
        assert_eq!(finish_drawn("television", &rng), None);
        assert!(keeps_own_colours("plant") && !keeps_own_colours("sofa"));
        let before = rng.clone().next_u64();
        let _ = finish_drawn("sofa", &rng);
        assert_eq!(rng.clone().next_u64(), before);
    }

    #[test]
    fn a_picture_is_drawn_as_a_print_in_every_tone_and_asked_no_colour() {
        assert!(keeps_own_colours("picture"));
        assert_eq!(finish_drawn("picture", &Rng::new(1)), None);
        let mut rng = Rng::new(5);
        let mut tones = std::collections::BTreeSet::new();
        for _ in 0..200 {
            rng.next_u64();
            let before = rng.clone().next_u64();
            match look_drawn("picture", &rng) {
                Look::Print { tone, .. } => tones.insert(tone.name.as_str()),
                other => panic!("a picture drawn as {other:?}"),
            };
            assert_eq!(rng.clone().next_u64(), before, "drawing a look does not advance the generator");
        }
        assert_eq!(tones.len(), table().print_tones().len(), "every tone is drawn: {tones:?}");
        assert!(matches!(look_drawn("sofa", &rng), Look::Finish(_)));
        assert_eq!(look_drawn("television", &rng), Look::Own);
    }

    #[test]
    fn a_book_is_drawn_in_every_cover_tone_and_asked_no_colour() {
        assert!(keeps_own_colours("book"));
        assert_eq!(finish_drawn("book", &Rng::new(1)), None);
        let mut rng = Rng::new(7);
        let mut tones = std::collections::BTreeSet::new();
        for _ in 0..200 {
            rng.next_u64();
            match look_drawn("book", &rng) {
                Look::Print { tone, .. } => tones.insert(tone.name.as_str()),
                other => panic!("a book drawn as {other:?}"),
            };
        }
        let covers: std::collections::BTreeSet<&str> = table().cover_tones().iter().map(|t| t.name.as_str()).collect();
        assert_eq!(tones, covers, "every cover tone is drawn, and only cover tones");
    }
}
