//! Which finish an instance is drawn in. A class's palette (the class table's `finishes`)
//! gives a set of colour names; the name is drawn evenly among them and then a finish of
//! that name, so within a class every colour name is equally likely: a class tells nothing
//! of an instance's colour, and a colour asked about tells nothing of the answer.

use osmab_evaluator::synthetic::Rng;

use crate::classes::{Colouring, Finish, table};

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
    table().class(category).is_none_or(|c| matches!(c.colouring, Colouring::Own))
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
}
