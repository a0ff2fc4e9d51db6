//! Names only the service gives: its baselines' team and methods (`baseline-…`) and the
//! name anonymous entries are shown under. A team or method named like one of them — in
//! another case, with a Cyrillic letter, a capital I for an l, dashes or spaces moved — is
//! refused, as visitors could not tell them apart (UTS #39 skeletons,
//! `osmab_evaluator::text::impersonates`).

use osmab_evaluator::text::impersonates;

/// Name of the team that owns the reference baselines.
pub const BASELINE_TEAM: &str = "OSMa-Bench baselines";

/// The team shown for an entry that stays anonymous.
pub const ANONYMOUS: &str = "Anonymous";

/// Method names of the baselines start with this.
pub const BASELINE_METHOD_PREFIX: &str = "baseline";

/// Whether `method`, an entry of the baselines' team, is the reference mapper, which maps
/// from the frames as a team's method does, rather than a control made from the ground truth.
pub fn is_reference_mapper(method: &str) -> bool {
    method == osmab_mapper::submission::method_name(osmab_mapper::FeatureSet::Seeing)
}

/// Why `name` may not be a team's name, if it may not.
pub fn team_name_problem(name: &str) -> Option<String> {
    [(BASELINE_TEAM, "the reference baselines' team"), (ANONYMOUS, "what anonymous entries are shown as")]
        .into_iter()
        .find(|(reserved, _)| impersonates(name, reserved, false))
        .map(|(reserved, why)| format!("'{name}' reads as '{reserved}', a name the service reserves ({why}); choose another"))
}

/// Why `name` may not be a method's name on a team's submission, if it may not.
pub fn method_name_problem(name: &str) -> Option<String> {
    if impersonates(name, BASELINE_METHOD_PREFIX, true) {
        return Some(format!(
            "'{name}' reads as a name starting with '{BASELINE_METHOD_PREFIX}', which the service reserves for its reference baselines; choose another"
        ));
    }
    impersonates(name, ANONYMOUS, false)
        .then(|| format!("'{name}' reads as '{ANONYMOUS}', what anonymous entries are shown as; submit with \"anonymous\": true instead"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reserved_names_and_their_look_alikes_are_refused_and_others_are_not() {
        for team in ["OSMa-Bench baselines", "osma bench baselines", "OSMа-Bench baselines", "Anonymous", "\u{0410}nonymous"] {
            assert!(team_name_problem(team).is_some(), "{team}");
        }
        for method in ["baseline-oracle", "Baseline Oracle", "baseIine-oracle", "bаseline-drop", "Аnonymous"] {
            assert!(method_name_problem(method).is_some(), "{method}");
        }
        for fine in ["ConceptGraphs", "BBQ (ours)", "Anonymous Lab", "Our baseline"] {
            assert_eq!((team_name_problem(fine), method_name_problem(fine)), (None, None), "{fine}");
        }
    }
}
