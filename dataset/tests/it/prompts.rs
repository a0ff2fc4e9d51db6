//! Scene prompts: the grammar, the rule filters, and text-spec agreement.

use osmab_dataset::prompts::filters::{FilterRules, Rejection, rejections};
use osmab_dataset::prompts::{grammar_pool, spec_mismatches};
use osmab_dataset::spec::{Regime, RelationKind};

/// The example prompts of OSMa-Bench++'s own generator configuration.
const PAPER_FURNITURE: &str = "A dining room with 1 dining table in the center of the room, 6 dining chairs around it, 1 sideboard against the back wall, and 1 bench near the left wall. Two chairs on one side are placed closer together between the table and the sideboard. The bench is to the left of the sideboard. The sideboard is behind the table from the front half of the room.";
const PAPER_MANIPULAND: &str = "An office with 1 desk and 2 chairs placed on opposite sides. On the desk, there is 1 laptop next to 3 books stacked near one side. Under the desk, there is 1 box placed near the left side. One chair stands in front of the desk and the other stands behind it. The box is under the desk between the desk legs and behind the front chair.";

#[test]
fn the_papers_examples_pass_their_regimes_filters() {
    assert_eq!(rejections(PAPER_FURNITURE, &FilterRules::for_regime(Regime::Furniture)), vec![]);
    assert_eq!(rejections(PAPER_MANIPULAND, &FilterRules::for_regime(Regime::Manipuland)), vec![]);
    // The furniture regime forbids small objects.
    assert!(rejections(PAPER_MANIPULAND, &FilterRules::for_regime(Regime::Furniture)).contains(&Rejection::ContainsForbiddenObjects));
}

#[test]
fn each_rule_names_what_it_rejects() {
    let rules = FilterRules::for_regime(Regime::Furniture);
    let cases = [
        ("A room with several chairs around 1 table and 2 sofas, 3 benches against the wall, 4 shelves. One. Two.", Rejection::VagueWords),
        ("A room with 1 table.", Rejection::TooShort),
        (
            "A room with 1 table. 1 chair#1 is behind the table next to it. The 1 sofa is against the wall. The 2 shelves are along the wall near it.",
            Rejection::ContainsIds,
        ),
        (
            "A room with 1 table and 1 sofa behind it. The mirror is against the wall next to the 1 shelf. The 1 bench is along the wall near it all.",
            Rejection::ContainsRiskyLanguage,
        ),
        (
            "A room with 1 table and 1 sofa. The chair is near the table and the bench. The shelf is near the sofa and the table too, in the room.",
            Rejection::TooFewExplicitCounts,
        ),
    ];
    for (text, expected) in cases {
        let found = rejections(text, &rules);
        assert!(found.contains(&expected), "{expected:?} not in {found:?} for: {text}");
    }
    // Whole words: "handsome" is not the vague "some".
    let handsome = PAPER_FURNITURE.replace("The bench", "The handsome bench");
    assert!(!rejections(&handsome, &rules).contains(&Rejection::VagueWords));
}

#[test]
fn the_grammar_writes_prompts_that_pass_and_agree_with_their_spec() {
    for regime in Regime::ALL {
        let pool = grammar_pool(regime, 60, 7);
        assert_eq!(pool.accepted.len(), 60, "{regime:?}");
        let rules = FilterRules::for_regime(regime);
        for p in &pool.accepted {
            assert_eq!(rejections(&p.text, &rules), vec![], "{}", p.text);
            assert_eq!(spec_mismatches(&p.text, &p.spec), Vec::<String>::new(), "{}", p.text);
            assert_eq!(p.spec.regime, regime);
            // Every relation named in the spec is stated in the text.
            for r in &p.spec.relations {
                assert!(p.text.to_lowercase().contains(r.kind.phrase()), "'{}' missing from: {}", r.kind.phrase(), p.text);
            }
        }
        if regime == Regime::Manipuland {
            for p in &pool.accepted {
                let total: u32 = p.spec.total_objects();
                assert!((4..=18).contains(&total), "{total} objects: {}", p.text);
                assert!(p.spec.relations.iter().any(|r| matches!(r.kind, RelationKind::On | RelationKind::Under | RelationKind::Inside)), "{}", p.text);
            }
        }
    }
}

#[test]
fn the_same_seed_writes_the_same_pool() {
    let a = grammar_pool(Regime::Furniture, 20, 3);
    assert_eq!(a, grammar_pool(Regime::Furniture, 20, 3));
    assert_ne!(a.accepted, grammar_pool(Regime::Furniture, 20, 4).accepted);
}

#[test]
fn spec_text_disagreements_are_found() {
    let pool = grammar_pool(Regime::Furniture, 1, 11);
    let mut prompt = pool.accepted[0].clone();
    prompt.spec.objects[0].count += 1;
    assert!(spec_mismatches(&prompt.text, &prompt.spec).iter().any(|m| m.contains("numerals")));
    prompt.spec.objects[0].count -= 1;
    prompt.spec.relations[0].subject = "piano".into();
    assert!(spec_mismatches(&prompt.text, &prompt.spec).iter().any(|m| m.contains("'piano'")));
}
