//! `osmab eval vqa` on the published OSMa-Bench judgements: every verdict the reference
//! decided locally is reproduced, recorded verdicts are kept for the rest, and the
//! metrics rows are the accuracies counted from the files.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::{fixtures, osmab, path, stdout};

fn published() -> PathBuf {
    fixtures().join("osmabench-v1/vqa-evaluated")
}

fn json_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            out.extend(json_files(&p));
        } else if p.extension().is_some_and(|e| e == "json") {
            out.push(p);
        }
    }
    out.sort();
    out
}

fn entries(file: &Path) -> Vec<Value> {
    serde_json::from_slice::<Value>(&std::fs::read(file).unwrap()).unwrap().as_array().unwrap().clone()
}

/// Python's `f"{x:.2%}"` of a count ratio.
fn pct(right: usize, total: usize) -> String {
    format!("{:.2}%", if total == 0 { 0.0 } else { right as f64 / total as f64 } * 100.0)
}

#[test]
fn with_recorded_verdicts_kept_the_rows_are_the_counted_accuracies() {
    let dir = published().join("conceptgraphs/replica_cad");
    let csv = stdout(&osmab(&["eval", "vqa", path(&dir)]));
    let mut lines = csv.split("\r\n").filter(|l| !l.is_empty());
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(&header[..3], ["File Name", "Overall Accuracy", "Accuracy (No Spatial)"]);
    let categories = &header[3..];
    let mut sorted = categories.to_vec();
    sorted.sort();
    assert_eq!(categories, sorted.as_slice(), "category columns are sorted");
    assert_eq!(categories.len(), 8);
    let rows: BTreeMap<String, Vec<String>> = lines.map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>()).map(|r| (r[0].clone(), r)).collect();
    let files = json_files(&dir);
    assert_eq!(rows.len(), files.len());
    for file in files {
        let items = entries(&file);
        let right = |f: &dyn Fn(&Value) -> bool| items.iter().filter(|e| f(e) && e["similar"].as_str().unwrap().eq_ignore_ascii_case("yes")).count();
        let total = |f: &dyn Fn(&Value) -> bool| items.iter().filter(|e| f(e)).count();
        let mut want = vec![file.file_name().unwrap().to_str().unwrap().to_string()];
        want.push(pct(right(&|_| true), total(&|_| true)));
        let not_spatial = |e: &Value| e["category"] != "Object Relations - Spatial";
        want.push(pct(right(&not_spatial), total(&not_spatial)));
        for category in categories {
            let of = |e: &Value| e["category"] == *category;
            want.push(pct(right(&of), total(&of)));
        }
        assert_eq!(rows[&want[0]], want);
    }
}

#[test]
fn with_recorded_verdicts_removed_every_local_verdict_is_reproduced() {
    let stripped = tempfile::tempdir().unwrap();
    for file in json_files(&published()) {
        let relative = file.strip_prefix(published()).unwrap();
        let mut items = entries(&file);
        for item in &mut items {
            item.as_object_mut().unwrap().remove("similar");
        }
        let target = stripped.path().join(relative);
        std::fs::create_dir_all(target.parent().unwrap()).unwrap();
        std::fs::write(&target, serde_json::to_vec(&items).unwrap()).unwrap();
    }
    let judged = tempfile::tempdir().unwrap();
    let out = osmab(&["eval", "vqa", path(stripped.path()), "--judged-out", path(judged.path())]);
    let csv = stdout(&out);
    assert_eq!(csv.split("\r\n").filter(|l| !l.is_empty()).count(), 221, "a header and 220 rows");

    let is_number = |s: &str| {
        let (whole, fraction) = s.split_once('.').map_or((s, None), |(w, f)| (w, Some(f)));
        !whole.is_empty() && whole.bytes().all(|b| b.is_ascii_digit()) && fraction.is_none_or(|f| !f.is_empty() && f.bytes().all(|b| b.is_ascii_digit()))
    };
    let (mut local, mut undecided) = (0, 0);
    let mut by_kinds = BTreeSet::new();
    for file in json_files(&published()) {
        let original = entries(&file);
        let written = entries(&judged.path().join(file.strip_prefix(published()).unwrap()));
        assert_eq!(original.len(), written.len(), "{}", file.display());
        for (before, after) in original.iter().zip(&written) {
            assert_eq!(before["question"], after["question"], "entries keep their order");
            let gt = before["answer"].as_str().unwrap().trim().to_lowercase();
            let pred = before["scene_graph_answer"].as_str().unwrap().trim().to_lowercase();
            let decidable = (["yes", "no"].contains(&gt.as_str()) && ["yes", "no"].contains(&pred.as_str())) || (is_number(&gt) && is_number(&pred));
            by_kinds.insert(after["judged_by"].as_str().unwrap().to_string());
            if decidable {
                local += 1;
                assert_eq!(after["judged_by"], "local");
                assert_eq!(after["similar"], before["similar"], "{}: {}", file.display(), before["question"]);
            } else {
                undecided += 1;
                assert_eq!((after["judged_by"].as_str(), after["similar"].as_str()), (Some("none"), Some("N/A")));
            }
        }
    }
    assert_eq!((local, undecided), (23_413, 17_137));
    assert_eq!(by_kinds, BTreeSet::from(["local".to_string(), "none".to_string()]));
}

#[test]
fn malformed_answer_files_are_refused_with_file_and_entry() {
    let dir = tempfile::tempdir().unwrap();
    for (name, body, expected) in [
        ("object.json", r#"{"question": "q"}"#, "expected a list"),
        ("missing.json", r#"[{"question": "q", "answer": "Yes"}, {"question": "q2"}]"#, "[1].answer"),
        ("broken.json", r#"[{"question": "#, "not valid JSON"),
    ] {
        let file = dir.path().join(name);
        std::fs::write(&file, body).unwrap();
        let out = osmab(&["eval", "vqa", path(&file)]);
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(name) && stderr.contains(expected), "{stderr}");
    }
}

mod release_questions {
    //! The questions of a built release, answered from scene graphs.

    use std::collections::BTreeMap;

    use osmab_evaluator::scores::Split;
    use osmab_evaluator::submission::release::ReleaseIndex;
    use osmab_evaluator::submission::validate::{SubmissionLimits, validate};
    use osmab_evaluator::vqa::answer::ClassifiedGraph;
    use osmab_evaluator::vqa::graph::SceneGraph;
    use osmab_evaluator::vqa::is_prompt_grounded;
    use osmab_evaluator::vqa::judge::judge_without_llm;
    use osmab_evaluator::vqa::score::{OpenBackends, score_vqa};
    use serde_json::Value;

    use crate::service::test_release;

    /// (correct, total) of the prompt-grounded and the standard questions over every scene
    /// when answered symbolically from `graph_of(scene)`.
    fn accuracy(graph_of: &dyn Fn(&str) -> SceneGraph) -> [(usize, usize); 2] {
        let index = ReleaseIndex::read(test_release()).unwrap();
        let classes = index.class_names();
        let mut tally = [(0, 0); 2];
        for scene in &index.scenes {
            let questions = index.answered_questions(&scene.id).unwrap().expect("the release has questions");
            let graph = graph_of(&scene.id);
            let answerer = ClassifiedGraph::new(&graph, &classes);
            for q in &questions.questions {
                let predicted = answerer.answer(q.form.as_ref().expect("every generated question has a form"));
                let verdict = judge_without_llm(&Value::from(q.answer.clone().unwrap()), &Value::from(predicted), q.form.as_ref(), None);
                let slot = &mut tally[usize::from(!is_prompt_grounded(&q.category))];
                slot.0 += usize::from(verdict.expect("every generated answer can be judged without an LLM").correct);
                slot.1 += 1;
            }
        }
        tally
    }

    /// The oracle's scene graph: the scene's objects the trajectory saw, as the release
    /// keeps them with its ground truth.
    fn oracle_scene_graph(scene: &str) -> SceneGraph {
        let path = test_release().join("ground_truth/objects").join(format!("{scene}.json"));
        let value: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        let objects: Vec<osmab_dataset::questions::SceneObject> = serde_json::from_value(value["objects"].clone()).unwrap();
        SceneGraph::parse(&osmab_dataset::questions::oracle_graph(&objects), "oracle").unwrap()
    }

    #[test]
    fn the_release_asks_prompt_grounded_and_standard_questions_with_hidden_answers() {
        let index = ReleaseIndex::read(test_release()).unwrap();
        let mut prompt_grounded = std::collections::BTreeSet::new();
        // Positive answers (yes, a count above zero) and negative ones over the release.
        let mut sides = [0usize; 2];
        for scene in &index.scenes {
            let public = index.public_questions(&scene.id).unwrap().expect("public questions");
            let answered = index.answered_questions(&scene.id).unwrap().expect("answers with the ground truth");
            assert_eq!(public, answered.without_answers());
            assert!(public.questions.iter().all(|q| q.answer.is_none() && q.form.is_some()));
            let mut per: BTreeMap<&str, usize> = BTreeMap::new();
            for q in &answered.questions {
                *per.entry(q.category.as_str()).or_default() += 1;
                let answer = q.answer.as_deref().unwrap();
                if is_prompt_grounded(&q.category) {
                    assert!(answer == "Yes" || answer == "No" || answer.bytes().all(|b| b.is_ascii_digit()), "{q:?}");
                }
            }
            // Drawn against the odds (of this small release's twenty-prompt pool), a scene may go
            // without a template, even without prompt-grounded questions when the pool makes its
            // prompt's facts near certain; it still asks standard questions of several kinds.
            assert!(answered.questions.len() >= 8, "{}: {per:?}", scene.id);
            assert!(per.keys().filter(|c| !is_prompt_grounded(c)).count() >= 3, "{}: standard categories {per:?}", scene.id);
            prompt_grounded.extend(per.keys().filter(|c| is_prompt_grounded(c)).map(|c| c.to_string()));
            for q in &answered.questions {
                let side = match q.answer.as_deref().unwrap() {
                    "Yes" => 0,
                    "No" | "0" => 1,
                    a if a.bytes().all(|b| b.is_ascii_digit()) => 0,
                    _ => continue,
                };
                sides[side] += 1;
            }
            // Ids and order tell nothing either: opaque ids, in id order.
            let ids: Vec<&str> = answered.questions.iter().map(|q| q.id.as_str()).collect();
            assert!(ids.windows(2).all(|w| w[0] < w[1]), "{ids:?}");
            assert!(ids.iter().all(|id| id.len() == scene.id.len() + 12 && id.starts_with(&format!("{}-q", scene.id))), "{ids:?}");
            let manifest: Value = serde_json::from_slice(&std::fs::read(test_release().join("manifest.json")).unwrap()).unwrap();
            let listed = manifest["files"].as_array().unwrap().iter().any(|f| f["path"] == format!("questions/{}.json", scene.id));
            assert!(listed, "the public questions are release files");
            let public = std::fs::read_to_string(test_release().join(format!("questions/{}.json", scene.id))).unwrap();
            assert!(!public.contains("\"answer\""), "the public question files carry no answers");
            // Val scenes publish their answered questions with their ground truth; test scenes would not.
            let answered = format!("ground_truth/questions/{}.json", scene.id);
            assert_eq!(manifest["files"].as_array().unwrap().iter().any(|f| f["path"] == answered), scene.split == Split::Val);
        }
        assert!(prompt_grounded.len() >= 2, "the release asks prompt-grounded questions of several kinds: {prompt_grounded:?}");
        // Every question is asked with either answer equally often (drawn against its odds),
        // so an answerer that always says yes, or always no, is right about half the time
        // (this small release asks about fifty such questions: a wide band).
        let [positive, negative] = sides;
        let share = positive as f64 / (positive + negative) as f64;
        assert!(positive + negative >= 40 && (0.3..0.7).contains(&share), "{positive} positive and {negative} negative answers");
    }

    /// A graph crafted to probe the answerer without mapping anything: one object of every
    /// class at the room's centre.
    fn everything_graph(_: &str) -> SceneGraph {
        let index = ReleaseIndex::read(test_release()).unwrap();
        let objects: Vec<Value> = index
            .class_names()
            .iter()
            .enumerate()
            .map(|(i, c)| serde_json::json!({"id": format!("n{i}"), "label": c, "bbox_center": [0.0, 0.5, 0.0], "bbox_extent": [0.5, 0.5, 0.5]}))
            .collect();
        SceneGraph::parse(&serde_json::json!({"objects": objects}), "everything").unwrap()
    }

    #[test]
    fn the_oracles_scene_graph_answers_every_question_and_crafted_graphs_no_better_than_chance() {
        let [(right, total), (std_right, std_total)] = accuracy(&oracle_scene_graph);
        eprintln!("oracle's graph: prompt-grounded {right}/{total}, standard {std_right}/{std_total}");
        assert_eq!((right, std_right), (total, std_total), "a perfect map answers every question");
        // Every yes/no and count template is balanced: a graph that says no to everything (the
        // empty one) or yes to everything (one of each class) is right about half the time.
        for (name, graph) in [("empty", &(|_: &str| SceneGraph::default()) as &dyn Fn(&str) -> SceneGraph), ("everything", &everything_graph)] {
            let [(right, total), (std_right, std_total)] = accuracy(graph);
            eprintln!("{name} graph: prompt-grounded {right}/{total}, standard {std_right}/{std_total}");
            assert!((right + std_right) as f64 <= 0.6 * (total + std_total) as f64, "the {name} graph answers {right}/{total} and {std_right}/{std_total}");
        }
    }

    /// Pooled VQA accuracy of a baseline under every lighting.
    fn baseline_vqa(name: &str) -> BTreeMap<String, f64> {
        let dir = tempfile::tempdir().unwrap();
        let out = crate::osmab(&["baseline", name, "--release", crate::path(test_release()), "--out", crate::path(dir.path())]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let index = ReleaseIndex::read(test_release()).unwrap();
        let valid = validate(dir.path(), &index, SubmissionLimits::default()).unwrap();
        let vqa = score_vqa(&valid, &index, OpenBackends::default()).unwrap().expect("baselines carry scene graphs");
        vqa.lightings.iter().map(|(l, v)| (l.to_string(), v.overall.accuracy.unwrap())).collect()
    }

    #[test]
    fn degraded_baselines_answer_worse_than_the_oracle_and_worse_under_harder_lighting() {
        let oracle = baseline_vqa("oracle");
        let scored: BTreeMap<&str, BTreeMap<String, f64>> =
            ["drop-small", "merge", "label-noise", "pose-drift"].iter().map(|n| (*n, baseline_vqa(n))).collect();
        eprintln!("VQA accuracy per lighting: oracle {oracle:?}, {scored:?}");
        for (name, by_lighting) in &scored {
            for (lighting, accuracy) in by_lighting {
                assert!(*accuracy <= oracle[lighting], "{name} under {lighting}: {accuracy} > the oracle's {}", oracle[lighting]);
            }
            // Dropping small classes, mislabelling and drift only grow with the lighting's
            // severity, and so does what they cost. Merging does not: a harder lighting merges
            // more classes, and a further merge can put a question's class back together with
            // what it was merged into (one question of 47 in the dressed test release).
            if *name != "merge" {
                assert!(by_lighting["no_lights"] <= by_lighting["baseline"], "{name}: {by_lighting:?}");
            }
        }
        let mean = |lighting: &str| scored.values().map(|l| l[lighting]).sum::<f64>() / scored.len() as f64;
        assert!(mean("no_lights") < mean("baseline"), "on average no lights costs answers: {scored:?}");
        assert!(scored.values().any(|l| l["baseline"] < oracle["baseline"]), "some degradation costs answers: {scored:?} vs {oracle:?}");
    }
}

mod team_answers {
    //! Answers a team supplies are checked against the release's questions and used as given.

    use osmab_evaluator::scores::Lighting;
    use osmab_evaluator::submission::release::ReleaseIndex;
    use osmab_evaluator::submission::validate::{SubmissionLimits, validate};
    use osmab_evaluator::vqa::answer::AnsweredBy;
    use osmab_evaluator::vqa::score::{OpenBackends, score_vqa};
    use serde_json::{Value, json};

    use crate::service::test_release;

    fn oracle_with_answers(answers: &Value) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        let out = crate::osmab(&["baseline", "oracle", "--release", crate::path(test_release()), "--out", crate::path(dir.path())]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let file = dir.path().join("answers/baseline/scene_000.json");
        std::fs::create_dir_all(file.parent().unwrap()).unwrap();
        std::fs::write(&file, serde_json::to_vec(answers).unwrap()).unwrap();
        dir
    }

    #[test]
    fn an_answer_to_a_question_the_scene_does_not_have_is_refused() {
        let index = ReleaseIndex::read(test_release()).unwrap();
        let [own, other] = ["scene_000", "scene_001"].map(|s| index.answered_questions(s).unwrap().unwrap().questions[0].id.clone());
        let dir = oracle_with_answers(&json!([{"question_id": own, "answer": "2"}, {"question_id": other, "answer": "Yes"}]));
        let index = ReleaseIndex::read(test_release()).unwrap();
        let problems = validate(dir.path(), &index, SubmissionLimits::default()).unwrap_err();
        assert_eq!(problems.len(), 1, "{problems:?}");
        let problem = &problems[0];
        assert_eq!((problem.file.as_str(), problem.field.as_str()), ("answers/baseline/scene_000.json", "[1].question_id"));
        assert!(problem.message.contains("not a question of scene_000") && problem.message.contains("questions/scene_000.json"), "{problem}");
    }

    #[test]
    fn the_team_s_answers_are_used_as_given_and_recorded_as_theirs() {
        let index = ReleaseIndex::read(test_release()).unwrap();
        let questions = index.answered_questions("scene_000").unwrap().unwrap();
        // Right answers to every question but the first, which gets a wrong one.
        let answers: Vec<Value> = questions
            .questions
            .iter()
            .enumerate()
            .map(|(i, q)| json!({"question_id": q.id, "answer": if i == 0 { "no idea".to_string() } else { q.answer.clone().unwrap() }}))
            .collect();
        let dir = oracle_with_answers(&Value::Array(answers));
        let valid = validate(dir.path(), &index, SubmissionLimits::default()).unwrap();
        let vqa = score_vqa(&valid, &index, OpenBackends::default()).unwrap().unwrap();
        let scene = &vqa.scenes[&Lighting::Baseline]["scene_000"];
        let rows = &scene.answers;
        assert_eq!(rows.len(), questions.questions.len());
        assert!(rows.iter().all(|r| r.answered_by == AnsweredBy::Team), "{rows:?}");
        assert!(!rows[0].correct);
        assert_eq!(scene.correct as usize, questions.questions.len() - 1);
        let other = &vqa.scenes[&Lighting::Camera]["scene_000"].answers;
        assert!(other.iter().all(|r| r.answered_by == AnsweredBy::Symbolic), "other lightings are answered from the graph");
    }
}
