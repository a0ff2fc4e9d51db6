use super::*;

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
