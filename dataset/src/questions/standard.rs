//! Standard view-dependent questions in the OSMa-Bench categories, every one a yes/no
//! question, a count or a colour, asked only where the scene settles it clearly and a
//! perfect map's graph gives the same answer ([`super::facts`]), and drawn so that neither
//! a template nor its classes tell the answer ([`super::draw`]):
//!
//! | category | templates (per side: yes and no, or zero and not) |
//! |---|---|
//! | Binary General | is there a X (1), is the X <colour> (1) |
//! | Binary Existence-Based | is there a X (2) |
//! | Binary Logical | X and Y (1), X or Y (1) |
//! | Measurement | how many X (2; zero for a class the scene lacks) |
//! | Object Attributes | what colour is the X (up to 3; colours are drawn evenly per object) |
//! | Object Relations - Spatial | is the Y the closest object to the X (1), is there a X next to / near the Y (1) |
//! | Object Relations - Functional | is the X resting on the Y / the floor (2) |
//! | Comparison | more X than Y (1), is the X larger than the Y (1) |

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::{QuestionForm, Relation};

use super::draw::{Candidate, draw_balanced, is_nonzero, is_yes};
use super::facts::SceneFacts;
use super::priors::{AskedAs, QuestionPriors};
use super::wording::{plural, with_article};
use crate::convert::lexicon::is_shell_class;
use crate::spec::Regime;

/// What the templates of a scene ask from: its facts, its room's odds and a draw.
pub struct Asking<'a> {
    pub facts: &'a SceneFacts<'a>,
    pub priors: &'a QuestionPriors<'a>,
    pub room: &'a str,
    pub regime: Regime,
    pub lexicon: &'a [String],
    pub rng: Rng,
}

impl Asking<'_> {
    /// The classes a question may name: the lexicon without the room's shell.
    pub fn askable(&self) -> Vec<&str> {
        self.lexicon.iter().map(String::as_str).filter(|c| !is_shell_class(c)).collect()
    }

    /// `form` as a candidate, when the scene settles it, with its odds among the layouts
    /// where questions `asked` that way would ask it.
    pub fn candidate(&self, asked: AskedAs, form: QuestionForm, text: String) -> Option<Candidate> {
        let answer = self.facts.truth(&form)?;
        let odds = match &form {
            QuestionForm::Count { class } => self.priors.presence_odds(asked, self.room, self.regime, class),
            other => self.priors.yes_odds(asked, self.room, self.regime, other),
        };
        Some(Candidate { form, text, answer, odds })
    }

    /// Existence candidates over every askable class, worded by `text`.
    pub fn existence(&self, asked: AskedAs, text: impl Fn(&str) -> String) -> Vec<Candidate> {
        self.askable().into_iter().filter_map(|c| self.candidate(asked, QuestionForm::Exists { class: c.into() }, text(c))).collect()
    }

    /// Count candidates over every askable class (zero for a class the scene lacks).
    pub fn counts(&self, asked: AskedAs, text: impl Fn(&str) -> String) -> Vec<Candidate> {
        self.askable().into_iter().filter_map(|c| self.candidate(asked, QuestionForm::Count { class: c.into() }, text(c))).collect()
    }

    /// `n` distinct pairs of askable classes, each class drawn as often as a room like this
    /// one has it (the odds, not this scene: the pairs must not depend on its answers).
    fn pairs(&mut self, n: usize) -> Vec<(String, String)> {
        let classes: Vec<(String, f64)> =
            self.askable().into_iter().map(|c| (c.to_string(), self.priors.presence_odds(AskedAs::Standard, self.room, self.regime, c))).collect();
        let total: f64 = classes.iter().map(|(_, w)| w).sum();
        let draw = |rng: &mut Rng| {
            let mut at = rng.unit() * total;
            for (c, w) in &classes {
                if at < *w {
                    return c.clone();
                }
                at -= w;
            }
            classes.last().map(|(c, _)| c.clone()).unwrap_or_default()
        };
        let mut pairs = Vec::new();
        for _ in 0..n * 4 {
            if pairs.len() == n || classes.len() < 2 {
                break;
            }
            let (a, b) = (draw(&mut self.rng), draw(&mut self.rng));
            if a != b && !pairs.iter().any(|(x, y)| (x == &a && y == &b) || (x == &b && y == &a)) {
                pairs.push((a, b));
            }
        }
        pairs
    }
}

/// The standard questions of a scene: (category, question), before ids are given.
pub fn standard_questions(asking: &mut Asking) -> Vec<(&'static str, Candidate)> {
    let mut out = existence_questions(asking);
    out.extend(logical_questions(asking));
    let counts = asking.counts(AskedAs::Standard, |c| format!("How many {} are there in the scene?", plural(c)));
    out.extend(in_category("Measurement", draw_balanced(counts, is_nonzero, 2, &mut asking.rng)));
    out.extend(in_category("Object Attributes", colours(asking, 3)));
    out.extend(relation_questions(asking));
    out.extend(comparison_questions(asking));
    out
}

/// `drawn` questions, each of `category`.
fn in_category(category: &'static str, drawn: Vec<Candidate>) -> impl Iterator<Item = (&'static str, Candidate)> {
    drawn.into_iter().map(move |c| (category, c))
}

/// Binary General and Binary Existence-Based: one draw of "is there a X" for both
/// categories, so they never ask the same question, then "is the X <colour>".
fn existence_questions(asking: &mut Asking) -> Vec<(&'static str, Candidate)> {
    let in_scene = |c: &str| format!("Is there {} in the scene?", with_article(c));
    let existence = draw_balanced(asking.existence(AskedAs::Standard, in_scene), is_yes, 3, &mut asking.rng);
    let per_side = existence.len() / 2;
    let (yes, no) = existence.split_at(per_side);
    let general = if per_side == 3 { 1 } else { 0 };
    let mut out: Vec<(&'static str, Candidate)> = Vec::new();
    out.extend(in_category("Binary General", yes[..general].iter().chain(&no[..general]).cloned().collect()));
    out.extend(in_category("Binary Existence-Based", yes[general..].iter().chain(&no[general..]).cloned().collect()));
    out.extend(in_category("Binary General", has_colour(asking)));
    out
}

/// Binary Logical: "X and Y" and "X or Y" over pairs of classes drawn by their odds.
fn logical_questions(asking: &mut Asking) -> Vec<(&'static str, Candidate)> {
    let pairs = asking.pairs(40);
    let all: Vec<Candidate> = pairs
        .iter()
        .filter_map(|(a, b)| {
            let text = format!("Is there {} and {} in the scene?", with_article(a), with_article(b));
            asking.candidate(AskedAs::Standard, QuestionForm::ExistsAll { classes: vec![a.clone(), b.clone()] }, text)
        })
        .collect();
    let any: Vec<Candidate> = pairs
        .iter()
        .filter_map(|(a, b)| {
            let text = format!("Is there {} or {} in the scene?", with_article(a), with_article(b));
            asking.candidate(AskedAs::Standard, QuestionForm::ExistsAny { classes: vec![a.clone(), b.clone()] }, text)
        })
        .collect();
    let mut out: Vec<(&'static str, Candidate)> = in_category("Binary Logical", draw_balanced(all, is_yes, 1, &mut asking.rng)).collect();
    out.extend(in_category("Binary Logical", draw_balanced(any, is_yes, 1, &mut asking.rng)));
    out
}

/// Object Relations, spatial (the closest object, next to / near) and functional (resting on).
fn relation_questions(asking: &mut Asking) -> Vec<(&'static str, Candidate)> {
    let singles = asking.facts.singles();
    let present: Vec<&str> = asking.facts.classes().filter(|c| asking.facts.seen(c)).collect();
    let mut nearest = Vec::new();
    let mut resting = Vec::new();
    for x in &singles {
        for y in present.iter().filter(|y| **y != x.label) {
            let form = QuestionForm::NearestIs { class: x.label.clone(), nearest: y.to_string() };
            nearest.extend(asking.candidate(AskedAs::Standard, form, format!("Is the {y} the closest object to the {}?", x.label)));
        }
        for support in present.iter().copied().filter(|s| *s != x.label).chain(["floor"]) {
            let form = QuestionForm::RestsOn { class: x.label.clone(), support: support.to_string() };
            resting.extend(asking.candidate(AskedAs::Standard, form, format!("Is the {} resting on the {support}?", x.label)));
        }
    }
    let mut beside = Vec::new();
    for a in &present {
        for b in present.iter().filter(|b| *b != a) {
            for relation in [Relation::NextTo, Relation::Near] {
                let form = QuestionForm::Related { subject: a.to_string(), relation, object: b.to_string() };
                beside.extend(asking.candidate(AskedAs::Standard, form, format!("Is there {} {} the {b} in the scene?", with_article(a), relation.words())));
            }
        }
    }
    let mut out: Vec<(&'static str, Candidate)> = in_category("Object Relations - Spatial", draw_balanced(nearest, is_yes, 1, &mut asking.rng)).collect();
    out.extend(in_category("Object Relations - Spatial", draw_balanced(beside, is_yes, 1, &mut asking.rng)));
    out.extend(in_category("Object Relations - Functional", draw_balanced(resting, is_yes, 2, &mut asking.rng)));
    out
}

/// Comparison: more X than Y, and is the X larger than the Y.
fn comparison_questions(asking: &mut Asking) -> Vec<(&'static str, Candidate)> {
    let singles = asking.facts.singles();
    let present: Vec<&str> = asking.facts.classes().filter(|c| asking.facts.seen(c)).collect();
    let mut more = Vec::new();
    for a in &present {
        for b in present.iter().filter(|b| *b != a) {
            let form = QuestionForm::MoreThan { more: a.to_string(), fewer: b.to_string() };
            more.extend(asking.candidate(AskedAs::Standard, form, format!("Are there more {} than {} in the scene?", plural(a), plural(b))));
        }
    }
    let mut larger = Vec::new();
    for a in &singles {
        for b in singles.iter().filter(|b| b.label != a.label) {
            let form = QuestionForm::LargerThan { a: a.label.clone(), b: b.label.clone() };
            larger.extend(asking.candidate(AskedAs::Standard, form, format!("Is the {} larger than the {}?", a.label, b.label)));
        }
    }
    let mut out: Vec<(&'static str, Candidate)> = in_category("Comparison", draw_balanced(more, is_yes, 1, &mut asking.rng)).collect();
    out.extend(in_category("Comparison", draw_balanced(larger, is_yes, 1, &mut asking.rng)));
    out
}

/// The colour names instances of `class` are drawn in (its palette in the class table),
/// each equally likely; every name the questions use for a class the table does not colour.
pub fn palette(class: &str) -> Vec<&'static str> {
    let names = crate::classes::table().class(class).map(|c| c.colour_names()).unwrap_or_default();
    if names.len() >= 2 { names } else { vec!["black", "white", "grey", "brown", "red", "orange", "yellow", "green", "blue", "purple", "pink"] }
}

/// "Is the X <colour>?" of single objects with a clear colour: one asked with its own
/// colour, one with another drawn evenly from its class's palette (every name of a class's
/// palette is as likely for it, so the asked colour tells nothing).
fn has_colour(asking: &mut Asking) -> Vec<Candidate> {
    let mut coloured: Vec<_> = asking.facts.singles().into_iter().filter(|o| o.colour.is_some()).collect();
    if coloured.len() < 2 {
        return Vec::new();
    }
    let first = coloured.swap_remove(asking.rng.below(coloured.len()));
    let second = coloured.swap_remove(asking.rng.below(coloured.len()));
    let own = first.colour.clone().expect("coloured");
    let theirs = second.colour.clone().expect("coloured");
    let others: Vec<&str> = palette(&second.label).into_iter().filter(|c| *c != theirs).collect();
    let other = others[asking.rng.below(others.len())].to_string();
    [(first, own), (second, other)]
        .into_iter()
        .filter_map(|(o, colour)| {
            let form = QuestionForm::HasColour { class: o.label.clone(), colour: colour.clone() };
            asking.candidate(AskedAs::Standard, form, format!("Is the {} {colour}?", o.label))
        })
        .collect()
}

/// "What colour is the X?" of up to `n` single objects with a clear colour, picked evenly.
fn colours(asking: &mut Asking, n: usize) -> Vec<Candidate> {
    let mut coloured: Vec<_> = asking.facts.singles().into_iter().filter(|o| o.colour.is_some()).collect();
    let mut out = Vec::new();
    while out.len() < n && !coloured.is_empty() {
        let o = coloured.swap_remove(asking.rng.below(coloured.len()));
        out.extend(asking.candidate(AskedAs::Standard, QuestionForm::Colour { class: o.label.clone() }, format!("What colour is the {}?", o.label)));
    }
    out
}
