//! What a scene's prompt settles, and so which questions the prompt-grounded templates ask
//! of it: a count or an existence of a class the prompt states (answered by the prompt) or
//! of a class the scene lacks altogether (zero, no), and relations between classes the
//! prompt states and the camera saw. A class only the room's dressing holds (a rug, a vase
//! the prompt never names) is left to the standard questions. The odds a prompt-grounded
//! question is drawn against are read off the pool's layouts under this same condition
//! ([`super::priors::AskedAs::PromptGrounded`]): a dressing class is asked here only when
//! the prompt states it or the scene lacks it, and odds taken over every layout would make
//! its answer predictable.

use std::collections::BTreeSet;

use osmab_evaluator::vqa::QuestionForm;

use super::facts::SceneFacts;
use crate::convert::lexicon::{is_shell_class, normalise_name};
use crate::spec::SceneSpec;

/// The release class of a prompt category (none for the room's shell or unknown names).
pub fn class_of(category: &str) -> Option<&'static str> {
    normalise_name(category).filter(|c| !is_shell_class(c))
}

/// The release classes a prompt states objects of.
pub fn stated_classes(spec: &SceneSpec) -> BTreeSet<&'static str> {
    spec.objects.iter().filter_map(|o| class_of(&o.category)).collect()
}

/// Whether the prompt-grounded templates ask `form` of a scene with `facts` whose prompt
/// states `stated`: a count or existence of a stated class or of one the scene lacks, a
/// relation between two stated classes the camera saw; any other form as the standard
/// templates would.
pub fn prompt_settles(form: &QuestionForm, stated: &BTreeSet<&str>, facts: &SceneFacts) -> bool {
    match form {
        QuestionForm::Count { class } | QuestionForm::Exists { class } => stated.contains(class.as_str()) || facts.counted(class) == Some(0),
        QuestionForm::Related { subject, object, .. } => [subject, object].iter().all(|c| stated.contains(c.as_str()) && facts.seen(c)),
        _ => true,
    }
}
