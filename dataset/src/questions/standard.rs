//! Standard view-dependent questions in the OSMa-Bench categories, every one a yes/no
//! question, a count or a colour, asked only where the scene settles it clearly and a
//! perfect map's graph gives the same answer ([`super::facts`]), and drawn so that neither
//! a template nor its classes tell the answer ([`super::draw`]):
//!
//! | category | templates (questions a scene asks on average, either answer equally often over the release) |
//! |---|---|
//! | Binary General | is there a X (2), is the X <colour> (1 asked with its colour, 1 with another) |
//! | Binary Existence-Based | is there a X (4) |
//! | Binary Logical | X and Y (2), X or Y (2) |
//! | Measurement | how many X (4; zero for a class the scene lacks) |
//! | Object Attributes | what colour is the X (up to 3; colours are drawn evenly per object) |
//! | Object Relations - Spatial | is the Y the closest object to the X (2), is there a X next to / near the Y (2) |
//! | Object Relations - Functional | is the X resting on the Y / the floor (4) |
//! | Comparison | more X than Y (2), is the X larger than the Y (2) |

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::{QuestionForm, Relation};

use super::calibration::Observed;
use super::draw::{self, Candidate};
use super::facts::SceneFacts;
use super::priors::{AskedAs, QuestionPriors, template_key};
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
    /// Where every template's candidates are noted before they are drawn, when the odds
    /// are being calibrated ([`super::calibrated_priors`]).
    pub observed: Option<&'a std::cell::RefCell<Vec<Observed>>>,
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
        let odds = self.priors.odds(asked, self.room, self.regime, &form);
        Some(Candidate { form, text, answer, asked, odds })
    }

    /// About `per_template` of `candidates`, drawn so that they tell nothing ([`draw`]);
    /// the candidates the draw considers are noted when calibrating.
    pub fn draw(&mut self, candidates: Vec<Candidate>, per_template: usize) -> Vec<Candidate> {
        let considered = draw::considered(candidates, per_template, &mut self.rng);
        if let Some(observed) = self.observed {
            let noted = considered.iter().map(|c| Observed { template: template_key(c.asked, &c.form), odds: c.odds, positive: c.is_positive() });
            observed.borrow_mut().extend(noted);
        }
        draw::kept(considered, &mut self.rng)
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
    out.extend(in_category("Measurement", asking.draw(counts, 4)));
    out.extend(in_category("Object Attributes", colours(asking, 3)));
    out.extend(relation_questions(asking));
    out.extend(comparison_questions(asking));
    out
}

/// `drawn` questions, each of `category`.
fn in_category(category: &'static str, drawn: Vec<Candidate>) -> impl Iterator<Item = (&'static str, Candidate)> {
    drawn.into_iter().map(move |c| (category, c))
}

/// Binary General and Binary Existence-Based: the "is there a X" candidates shared between
/// the two categories (a third to General, by a draw that knows nothing of the answers), so
/// they never ask the same question; then "is the X <colour>".
fn existence_questions(asking: &mut Asking) -> Vec<(&'static str, Candidate)> {
    let in_scene = |c: &str| format!("Is there {} in the scene?", with_article(c));
    let candidates = asking.existence(AskedAs::Standard, in_scene);
    let (general, existence_based): (Vec<_>, Vec<_>) = candidates.into_iter().partition(|_| asking.rng.below(3) == 0);
    let mut out: Vec<(&'static str, Candidate)> = in_category("Binary General", asking.draw(general, 2)).collect();
    out.extend(in_category("Binary Existence-Based", asking.draw(existence_based, 4)));
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
    let mut out: Vec<(&'static str, Candidate)> = in_category("Binary Logical", asking.draw(all, 2)).collect();
    out.extend(in_category("Binary Logical", asking.draw(any, 2)));
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
    let mut out: Vec<(&'static str, Candidate)> = in_category("Object Relations - Spatial", asking.draw(nearest, 2)).collect();
    out.extend(in_category("Object Relations - Spatial", asking.draw(beside, 2)));
    out.extend(in_category("Object Relations - Functional", asking.draw(resting, 4)));
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
    let mut out: Vec<(&'static str, Candidate)> = in_category("Comparison", asking.draw(more, 2)).collect();
    out.extend(in_category("Comparison", asking.draw(larger, 2)));
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
