use super::*;
use crate::semseg::report::MetricTriple;

/// A score document as the untyped scorer wrote it (keys sorted, NaN as null), with
/// segmentation, a subset, relative change and VQA with per-scene answers.
const STORED: &str = r#"{"complete":false,"evaluator_version":"0.1.0","missing_maps":["camera/scene_001"],"relative_change":{"baseline":{"overall":{"fmiou":0.0,"macc":0.0,"miou":0.0},"overall_mean":{"fmiou":0.0,"macc":0.0,"miou":0.0}},"camera":{"overall":{"fmiou":-0.125,"macc":null,"miou":-0.5},"overall_mean":{"fmiou":-0.125,"macc":null,"miou":-0.5}}},"release":"2026.1","semseg":{"baseline":{"overall":{"fmiou":0.8,"macc":0.75,"miou":0.5},"overall_mean":{"fmiou":0.8,"macc":0.75,"miou":0.5},"scenes":{"scene_000":{"fmiou":0.8,"macc":0.75,"miou":0.5}},"subsets":{"furniture":{"overall":{"fmiou":0.8,"macc":0.75,"miou":0.5},"overall_mean":{"fmiou":0.8,"macc":0.75,"miou":0.5},"scenes":1}}},"camera":{"overall":{"fmiou":0.7,"macc":null,"miou":0.25},"overall_mean":{"fmiou":0.7,"macc":null,"miou":0.25},"scenes":{"scene_000":{"fmiou":0.7,"macc":null,"miou":0.25}},"subsets":{"furniture":{"overall":{"fmiou":0.7,"macc":null,"miou":0.25},"overall_mean":{"fmiou":0.7,"macc":null,"miou":0.25},"scenes":1}}}},"vqa":{"all_lightings":{"overall":{"accuracy":0.5,"ci95":null,"correct":1,"scenes":1,"total":2},"prompt_grounded":{"categories":{"PromptGT-Measurement":{"accuracy":1.0,"ci95":null,"correct":1,"scenes":1,"total":1}},"groups":{"Measurements":{"accuracy":1.0,"ci95":null,"correct":1,"scenes":1,"total":1}},"overall":{"accuracy":1.0,"ci95":null,"correct":1,"scenes":1,"total":1}},"standard":{"categories":{"Object Relations - Spatial":{"accuracy":0.0,"ci95":null,"correct":0,"scenes":1,"total":1}},"groups":{"Relations":{"accuracy":0.0,"ci95":null,"correct":0,"scenes":1,"total":1}},"overall":{"accuracy":0.0,"ci95":null,"correct":0,"scenes":1,"total":1}},"subsets":{"furniture":{"overall":{"accuracy":0.5,"ci95":[0.25,0.75],"correct":1,"scenes":1,"total":2},"prompt_grounded":{"categories":{},"groups":{},"overall":{"accuracy":null,"ci95":null,"correct":0,"scenes":0,"total":0}},"standard":{"categories":{},"groups":{},"overall":{"accuracy":null,"ci95":null,"correct":0,"scenes":0,"total":0}}}}},"answered_by":{"none":1,"symbolic":1},"judged_by":{"none":1,"rule":1},"lightings":{},"scenes":{"baseline":{"scene_000":{"answers":[{"answer":"2","answered_by":"symbolic","category":"PromptGT-Measurement","correct":true,"id":"q1","judged_by":"rule"},{"answer":"No answer","answered_by":"none","category":"Object Relations - Spatial","correct":false,"id":"q2","judged_by":"none"}],"correct":1,"total":2}}}}}"#;

#[test]
fn a_stored_document_reads_and_writes_back_byte_for_byte() {
    let scores: Scores = serde_json::from_str(STORED).unwrap();
    assert_eq!(serde_json::to_string(&scores).unwrap(), STORED);
    let untyped: serde_json::Value = serde_json::from_str(STORED).unwrap();
    assert_eq!(serde_json::to_string(&untyped).unwrap(), STORED, "the fixture is in the untyped writer's key order");
}

#[test]
fn metrics_are_read_by_axis_and_undefined_ones_are_none() {
    let scores: Scores = serde_json::from_str(STORED).unwrap();
    assert_eq!(scores.semseg(Lighting::Baseline, None, Aggregate::Overall, Metric::Miou), Some(0.5));
    assert_eq!(scores.semseg(Lighting::Camera, Some(Regime::Furniture), Aggregate::OverallMean, Metric::Fmiou), Some(0.7));
    assert_eq!(scores.semseg(Lighting::Camera, None, Aggregate::Overall, Metric::Macc), None, "null is undefined");
    assert_eq!(scores.semseg(Lighting::NoLights, None, Aggregate::Overall, Metric::Miou), None, "absent lighting");
    assert_eq!(scores.semseg(Lighting::Baseline, Some(Regime::Manipuland), Aggregate::Overall, Metric::Miou), None, "absent subset");
    assert_eq!(scores.relative_change(Lighting::Camera, Aggregate::Overall, Metric::Miou), Some(-0.5));
    let vqa = scores.vqa.as_ref().unwrap();
    assert_eq!(vqa.over_lightings(Regime::Furniture, QuestionSet::Standard, QuestionGroup::Relations), None);
    assert_eq!(vqa.all_lightings.group_accuracy(QuestionSet::PromptGrounded, QuestionGroup::Measurements), Some(1.0));
}

#[test]
fn the_change_against_baseline_of_any_view_is_the_stored_rule() {
    let scores: Scores = serde_json::from_str(STORED).unwrap();
    for aggregate in Aggregate::ALL {
        for metric in Metric::COLUMNS {
            // The scorer's rule, (value − baseline) / baseline, to the bit.
            let rule = match (scores.semseg(Lighting::Camera, None, aggregate, metric), scores.semseg(Lighting::Baseline, None, aggregate, metric)) {
                (Some(v), Some(b)) => Some((v - b) / b),
                _ => None,
            };
            assert_eq!(scores.change_against_baseline(Lighting::Camera, None, aggregate, metric), rule, "{aggregate} {metric}");
        }
    }
    assert_eq!(
        scores.change_against_baseline(Lighting::Camera, None, Aggregate::Overall, Metric::Miou),
        scores.relative_change(Lighting::Camera, Aggregate::Overall, Metric::Miou)
    );
    assert_eq!(scores.change_against_baseline(Lighting::Camera, Some(Regime::Furniture), Aggregate::Overall, Metric::Miou), Some(-0.5), "a subset too");
    assert_eq!(scores.change_against_baseline(Lighting::Camera, None, Aggregate::Overall, Metric::Macc), None, "an undefined value has no change");
    assert_eq!(scores.change_against_baseline(Lighting::NoLights, None, Aggregate::Overall, Metric::Miou), None, "nor an absent lighting");
    let mut zero = scores.clone();
    zero.semseg.get_mut(&Lighting::Baseline).unwrap().overall.miou = 0.0;
    assert_eq!(zero.change_against_baseline(Lighting::Camera, None, Aggregate::Overall, Metric::Miou), None, "nor a change from zero");
}

#[test]
fn a_summary_drops_per_scene_tables_and_keeps_scene_counts() {
    let summary: Scores = serde_json::from_str::<Scores>(STORED).unwrap().summary();
    let json = serde_json::to_value(&summary).unwrap();
    assert!(json["semseg"]["baseline"].get("scenes").is_none());
    assert_eq!(json["semseg"]["baseline"]["subsets"]["furniture"]["scenes"], 1);
    assert!(json["vqa"].get("scenes").is_none());
    assert_eq!(json["vqa"]["all_lightings"]["overall"]["scenes"], 1);
}

#[test]
fn a_document_without_vqa_serialises_vqa_as_null() {
    let scores = Scores { release: "r".into(), evaluator_version: "v".into(), ..Scores::default() };
    let json = serde_json::to_string(&scores).unwrap();
    assert_eq!(json, r#"{"complete":false,"evaluator_version":"v","missing_maps":[],"relative_change":{},"release":"r","semseg":{},"vqa":null}"#);
}

/// A score of `split` with `scenes[l]` scenes under lighting `l` (furniture first, then
/// manipuland, by `furniture`), and VQA pooled over `vqa_scenes` scenes.
fn scored(split: Split, scenes: &[(Lighting, usize)], furniture: usize, vqa_scenes: usize) -> Scores {
    let triple = MetricTriple { fmiou: 0.5, macc: 0.5, miou: 0.5, ci95: None };
    let mut semseg = BTreeMap::new();
    for &(lighting, n) in scenes {
        let subsets = [(Regime::Furniture, n.min(furniture)), (Regime::Manipuland, n.saturating_sub(furniture))]
            .into_iter()
            .filter(|(_, k)| *k > 0)
            .map(|(r, k)| (r, SubsetScores { overall: triple.clone(), overall_mean: triple.clone(), scenes: k }))
            .collect();
        semseg.insert(
            lighting,
            LightingScores {
                bootstrap_miou: vec![Some(0.5); 10],
                overall: triple.clone(),
                overall_mean: triple.clone(),
                pooled: None,
                scenes: (0..n).map(|k| (format!("scene_{k:03}"), triple.clone())).collect(),
                subsets,
            },
        );
    }
    let relative_change = scenes.iter().map(|(l, _)| (*l, RelativeChange { overall: triple.clone(), overall_mean: triple.clone() })).collect();
    let accuracy = |scenes: usize| Accuracy { accuracy: Some(0.5), ci95: None, correct: 1, scenes, total: 2 };
    let set = |scenes: usize| QuestionSetScores {
        categories: [("Measurement".to_string(), accuracy(scenes)), ("Comparison".to_string(), accuracy(scenes.min(3)))].into_iter().collect(),
        groups: [(QuestionGroup::Measurements, accuracy(scenes))].into_iter().collect(),
        overall: accuracy(scenes),
    };
    let cell = |scenes: usize| VqaCell {
        overall: accuracy(scenes),
        prompt_grounded: set(scenes),
        standard: set(scenes),
        subsets: [
            (
                Regime::Furniture,
                SetsScores { overall: accuracy(scenes.min(furniture)), prompt_grounded: set(scenes.min(furniture)), standard: set(scenes.min(furniture)) },
            ),
            (Regime::Manipuland, SetsScores { overall: accuracy(scenes - scenes.min(furniture)), prompt_grounded: set(0), standard: set(0) }),
        ]
        .into_iter()
        .collect(),
    };
    let answers = SceneAnswers { answers: Vec::new(), correct: 1, total: 2 };
    let vqa = VqaScores {
        all_lightings: cell(vqa_scenes),
        answered_by: BTreeMap::new(),
        judged_by: BTreeMap::new(),
        lightings: scenes.iter().map(|(l, _)| (*l, cell(vqa_scenes))).collect(),
        scenes: [(Lighting::Baseline, [("scene_000".to_string(), answers)].into_iter().collect())].into_iter().collect(),
    };
    Scores {
        complete: true,
        evaluator_version: "v".into(),
        release: "r".into(),
        relative_change,
        semseg,
        split: Some(split),
        vqa: Some(vqa),
        ..Scores::default()
    }
}

#[test]
fn a_val_score_is_shown_whole() {
    let val = scored(Split::Val, &[(Lighting::Baseline, 2)], 1, 2);
    assert_eq!(val.disclosed(), val);
}

#[test]
fn a_test_score_shows_no_number_that_depends_on_fewer_than_five_scenes() {
    // Twelve furniture and eight manipuland scenes under baseline, four under camera.
    let test = scored(Split::Test, &[(Lighting::Baseline, 20), (Lighting::Camera, 4)], 12, 20);
    let shown = test.disclosed();
    let baseline = &shown.semseg[&Lighting::Baseline];
    assert!(baseline.scenes.is_empty() && baseline.bootstrap_miou.is_empty(), "no per-scene rows, no replicates");
    assert_eq!(baseline.pooled, Some(20));
    assert_eq!(baseline.subsets.keys().copied().collect::<Vec<_>>(), [Regime::Furniture, Regime::Manipuland], "12 and 8 scenes: both shown");
    assert!(!shown.semseg.contains_key(&Lighting::Camera), "four scenes under camera: withheld");
    assert_eq!(shown.relative_change.keys().copied().collect::<Vec<_>>(), [Lighting::Baseline]);
    let vqa = shown.vqa.as_ref().unwrap();
    assert!(vqa.lightings.is_empty() && vqa.scenes.is_empty(), "VQA only over all lightings, no per-scene answers");
    assert_eq!(vqa.all_lightings.overall.scenes, 20);
    assert!(
        vqa.all_lightings.standard.categories.is_empty(),
        "a category of three scenes is withheld, and with it its partner: the set's overall minus one would tell the other"
    );
    assert!(vqa.all_lightings.standard.groups.is_empty(), "Comparison, which no group holds, pools three scenes: the set minus its groups would show it");
    assert_eq!(vqa.all_lightings.subsets.keys().copied().collect::<Vec<_>>(), [Regime::Furniture, Regime::Manipuland]);
    assert_eq!(shown.withheld.as_ref().map(|w| w.min_scenes), Some(MIN_TEST_SCENES));

    // Two furniture and two manipuland scenes: nothing at all.
    let small = scored(Split::Test, &[(Lighting::Baseline, 4)], 2, 4).disclosed();
    assert!(small.semseg.is_empty() && small.vqa.is_none() && small.relative_change.is_empty(), "{small:?}");
    // Six scenes, three of each subset: the whole is shown, no subset.
    let six = scored(Split::Test, &[(Lighting::Baseline, 6)], 3, 6).disclosed();
    assert!(six.semseg[&Lighting::Baseline].subsets.is_empty());
    assert!(six.vqa.as_ref().unwrap().all_lightings.subsets.is_empty());
}

#[test]
fn a_test_score_shows_every_fraction_to_the_boards_tenth_of_a_percent() {
    let mut test = scored(Split::Test, &[(Lighting::Baseline, 20), (Lighting::Camera, 20)], 12, 20);
    let camera = test.semseg.get_mut(&Lighting::Camera).unwrap();
    camera.overall = MetricTriple::new(0.752_380_952_380_952_4, 0.412_345_6, f64::NAN);
    test.vqa.as_mut().unwrap().all_lightings.overall.accuracy = Some(56.0 / 176.0);
    let shown = test.disclosed();
    let camera = &shown.semseg[&Lighting::Camera].overall;
    assert_eq!((camera.miou, camera.fmiou), (0.752, 0.412), "79/105 is shown as the board shows it, 75.2 %");
    assert!(camera.macc.is_nan(), "undefined stays undefined");
    assert_eq!(shown.vqa.as_ref().unwrap().all_lightings.overall.accuracy, Some(0.318));
    let change = &shown.relative_change[&Lighting::Camera].overall;
    let baseline = shown.semseg[&Lighting::Baseline].overall.miou;
    assert_eq!(change.miou, disclosure::rounded((0.752 - baseline) / baseline), "the relative change is made from the shown values");
    let json = serde_json::to_string(&shown.semseg).unwrap();
    assert!(!json.contains("0.75238"), "{json}");
}

#[test]
fn two_lightings_that_differ_in_one_scene_tell_nothing_finer_than_the_rounding() {
    // The differencing attack: maps equal under two lightings but in one scene, whose
    // contribution to the pooled numbers is then the difference of the two lightings.
    // Two such submissions whose one scene differs by less than the rounding show the same.
    let attack = |scene_share: f64| {
        let mut test = scored(Split::Test, &[(Lighting::Baseline, 20), (Lighting::Camera, 20)], 12, 20);
        let camera = test.semseg.get_mut(&Lighting::Camera).unwrap();
        camera.overall = MetricTriple::new(0.5 + scene_share / 20.0, 0.6 + scene_share / 20.0, 0.7 + scene_share / 20.0);
        test
    };
    let (one, other) = (attack(0.123_456), attack(0.123_466));
    assert_ne!(one, other, "the hidden values differ");
    assert_eq!(one.disclosed(), other.disclosed(), "the shown ones do not");
}

#[test]
fn the_parts_of_a_partition_are_shown_all_or_none() {
    // Twelve furniture and three manipuland scenes: the manipuland subset is withheld, so
    // the furniture one is too (the whole minus it would be the manipuland subset).
    let test = scored(Split::Test, &[(Lighting::Baseline, 15)], 12, 15).disclosed();
    assert!(test.semseg[&Lighting::Baseline].subsets.is_empty());
    assert!(test.vqa.as_ref().unwrap().all_lightings.subsets.is_empty());
    assert_eq!(test.semseg[&Lighting::Baseline].pooled, Some(15), "the whole is shown");
}

#[test]
fn groups_are_withheld_when_the_categories_they_leave_out_pool_too_few_scenes() {
    // The set's overall minus its groups is the ungrouped categories' accuracy.
    let mut test = scored(Split::Test, &[(Lighting::Baseline, 20)], 12, 20);
    let set = &mut test.vqa.as_mut().unwrap().all_lightings.standard;
    set.categories = [("Measurement".to_string(), set.overall.clone())].into_iter().collect();
    let few = Accuracy { accuracy: Some(0.5), ci95: None, correct: 1, scenes: 3, total: 2 };
    set.categories.insert("Object Attributes".into(), few);
    let shown = test.disclosed();
    assert!(shown.vqa.as_ref().unwrap().all_lightings.standard.groups.is_empty(), "three scenes' ungrouped questions stay hidden");
    let mut many = scored(Split::Test, &[(Lighting::Baseline, 20)], 12, 20);
    let set = &mut many.vqa.as_mut().unwrap().all_lightings.standard;
    set.categories.insert("Object Attributes".into(), set.overall.clone());
    assert!(!many.disclosed().vqa.as_ref().unwrap().all_lightings.standard.groups.is_empty(), "twenty scenes' may show");
}

#[test]
fn a_question_set_or_a_subsets_group_withheld_anywhere_leaves_nothing_to_subtract_elsewhere() {
    let mut test = scored(Split::Test, &[(Lighting::Baseline, 20)], 12, 20);
    let cell = &mut test.vqa.as_mut().unwrap().all_lightings;
    cell.prompt_grounded.overall.scenes = 3;
    let furniture = cell.subsets.get_mut(&Regime::Furniture).unwrap();
    furniture.standard.groups.get_mut(&QuestionGroup::Measurements).unwrap().scenes = 3;
    let shown = test.disclosed();
    let cell = &shown.vqa.as_ref().unwrap().all_lightings;
    assert_eq!(cell.standard.overall.accuracy, None, "the overall minus the standard set would be the three-scene PromptGT set");
    assert_eq!(cell.overall.scenes, 20, "the whole is shown");
    for subset in cell.subsets.values() {
        assert!(!subset.standard.groups.contains_key(&QuestionGroup::Measurements), "withheld in one subset, so in all");
    }
    assert_eq!(disclosure::rounded(-0.0004).to_string(), "0", "no negative zero");
}

#[test]
fn a_shown_relative_change_reads_as_the_board_writes_the_change_of_the_shown_values() {
    // Changes of shown (rounded) scores, many of them a hair from a half step of 0.1 %.
    let page = |x: f64| format!("{:+.1}%", 100.0 * x);
    let mut checked = 0;
    for base in (100..=1000).step_by(7) {
        for value in (0..=1000).step_by(3) {
            let (value, base) = (disclosure::rounded(value as f64 / 1000.0), disclosure::rounded(base as f64 / 1000.0));
            let change = (value - base) / base;
            assert_eq!(page(disclosure::rounded(change)), page(change), "{value} against {base}");
            checked += 1;
        }
    }
    assert!(checked > 40_000);
    assert_eq!(disclosure::rounded((0.024 - 0.128) / 0.128), -0.812, "−81.25 % exactly is −81.2 %, as the board writes it");
}
