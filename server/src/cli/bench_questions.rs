//! `osmab bench questions`: how much of a release's hidden answers follows from public text.
//! Text-only predictors, each seeing only what the public release and its published config
//! give (the val scenes' questions with their answers, the subsets, the question texts,
//! and the prompt pool the config rebuilds), answer the test scenes' questions as if they
//! were published; each template's accuracy is set against the accuracy of always giving
//! the template's majority answer. A question design that tells nothing keeps every
//! predictor at that majority (docs/vqa.md, "Questions that tell nothing").

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context;
use osmab_dataset::prompts::PromptPool;
use osmab_dataset::questions::priors::{AskedAs, PoolLayouts, QuestionPriors};
use osmab_evaluator::scores::{Regime, Split};
use osmab_evaluator::submission::release::ReleaseIndex;
use osmab_evaluator::vqa::{Question, QuestionForm, SceneQuestions};
use serde::Serialize;

/// What each predictor got right of one template's questions.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct TemplateTally {
    pub questions: usize,
    /// Always the majority answer of the template's test questions themselves.
    pub majority: usize,
    /// Always the majority answer of the template's val questions.
    pub val_majority: usize,
    /// The val answers of the same form (or the same template and first class), else the val majority.
    pub val_lookup: usize,
    /// The odds of the prompt pool's simulated layouts (the generator's own priors): yes
    /// where they favour yes, zero where a class is more likely absent.
    pub pool_odds: usize,
}

impl TemplateTally {
    fn add(&mut self, other: &TemplateTally) {
        self.questions += other.questions;
        self.majority += other.majority;
        self.val_majority += other.val_majority;
        self.val_lookup += other.val_lookup;
        self.pool_odds += other.pool_odds;
    }
}

/// One test scene's tally per template, over every draw of its questions.
pub type SceneTally = BTreeMap<String, TemplateTally>;

/// A question's template: its category and the kind of its form.
fn template(q: &Question) -> String {
    format!("{} / {}", q.category, q.form.as_ref().map_or("free", QuestionForm::kind))
}

/// The first class a form names (what a lookup by class keys on).
fn first_class(form: &QuestionForm) -> String {
    let value = serde_json::to_value(form).expect("serialisable");
    ["class", "subject", "more", "a"].iter().find_map(|k| value.get(k).and_then(|v| v.as_str()).map(str::to_string)).unwrap_or_default()
}

/// The room a question's text names (`… in the dining room?`), if any.
fn room_of(text: &str) -> Option<String> {
    let rest = text.rsplit_once(" in the ")?.1.trim_end_matches('?');
    (rest != "scene").then(|| rest.to_string())
}

/// The most frequent value of `values`, the first on ties.
fn mode<'a>(values: impl Iterator<Item = &'a str>) -> Option<String> {
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for v in values {
        *counts.entry(v).or_default() += 1;
    }
    counts.into_iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(a.0))).map(|(v, _)| v.to_string())
}

fn read_questions(release: &Path, scene: &str) -> anyhow::Result<SceneQuestions> {
    let path = release.join("ground_truth/questions").join(format!("{scene}.json"));
    SceneQuestions::read(&path).with_context(|| format!("{}: the answered questions (run on an operator's build, which keeps them)", path.display()))
}

/// The questions the current generator draws for `scene` (the `index`-th) of the build in
/// `release`, from the scene's objects and prompt as the build kept them.
fn regenerate(release: &Path, scene: &str, index: usize, seed: u64, lexicon: &[String], priors: &QuestionPriors) -> anyhow::Result<SceneQuestions> {
    let objects_path = release.join("ground_truth/objects").join(format!("{scene}.json"));
    let objects: serde_json::Value = serde_json::from_slice(&std::fs::read(&objects_path).with_context(|| objects_path.display().to_string())?)?;
    let objects: Vec<osmab_dataset::questions::SceneObject> = serde_json::from_value(objects["objects"].clone())?;
    let prompt_path = [release.join("scenes").join(scene).join("prompt.json"), release.join("ground_truth/scenes").join(scene).join("prompt.json")]
        .into_iter()
        .find(|p| p.is_file())
        .with_context(|| format!("{scene}: no prompt.json in the build"))?;
    let prompt: serde_json::Value = serde_json::from_slice(&std::fs::read(&prompt_path)?)?;
    let spec: osmab_dataset::spec::SceneSpec = serde_json::from_value(prompt["spec"].clone())?;
    Ok(osmab_dataset::questions::scene_questions(scene, &spec, &objects, lexicon, priors, seed.wrapping_add(index as u64)))
}

/// Run the predictors over the build in `release` (an operator's build folder: its
/// `ground_truth/` and `.work/prompts/`); returns the tally per template. With
/// `regenerate`, the questions are drawn anew by this binary's generator from the scenes'
/// objects and prompts (to measure a change of the generator without rendering again), as
/// `draws` independent draws of the test scenes' questions (the first is the build's own).
/// One tally per test scene, so that how far the answers of a few scenes decide a
/// template's figure can be measured ([`interval`]).
pub fn measure(release: &Path, regenerate_questions: bool, draws: u64) -> anyhow::Result<Vec<SceneTally>> {
    let index = ReleaseIndex::read(release)?;
    let generator = osmab_evaluator::formats::manifest::ReleaseManifest::read(&release.join("manifest.json"))?.generator;
    let seed = generator.seed;
    let pools: Vec<PromptPool> = ["furniture", "manipuland"]
        .iter()
        .map(|r| -> anyhow::Result<PromptPool> {
            let path = release.join(format!(".work/prompts/{r}.json"));
            Ok(serde_json::from_slice(&std::fs::read(&path).with_context(|| format!("{}: the prompt pool the config rebuilds", path.display()))?)?)
        })
        .collect::<anyhow::Result<_>>()?;
    let lexicon: Vec<String> = osmab_dataset::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
    let (config, _) = osmab_dataset::release::config::ReleaseConfig::parse(&generator.config, &release.join("manifest.json"))?;
    let assets =
        osmab_dataset::synthesis::source::AssetSource::for_config(config.synthesis.assets.as_deref(), &osmab_dataset::synthesis::source::assets_root())?;
    let layouts = PoolLayouts::place(&pools, seed, &assets);
    let priors = osmab_dataset::questions::calibrated_priors(&layouts, &lexicon);
    let stated = stated_counts(&pools);

    let questions_of = |scene: &str, draw: u64| -> anyhow::Result<SceneQuestions> {
        if regenerate_questions {
            let position = index.scenes.iter().position(|s| s.id == scene).expect("a scene of the index");
            regenerate(release, scene, position, seed.wrapping_add(draw << 32), &lexicon, &priors)
        } else {
            read_questions(release, scene)
        }
    };
    let (val, test): (Vec<_>, Vec<_>) = index.scenes.iter().partition(|s| s.split == Split::Val);
    anyhow::ensure!(!test.is_empty(), "{}: the release has no test scenes to measure", release.display());
    let val_questions: Vec<Question> =
        val.iter().map(|s| questions_of(&s.id, 0)).collect::<anyhow::Result<Vec<_>>>()?.into_iter().flat_map(|q| q.questions).collect();
    let mut test_questions: Vec<(usize, Regime, Question)> = Vec::new();
    for draw in 0..draws.max(1) {
        for (k, scene) in test.iter().enumerate() {
            test_questions.extend(questions_of(&scene.id, draw)?.questions.into_iter().map(|q| (k, scene.subset, q)));
        }
    }
    let predictors = Predictors { val: &val_questions, priors: &priors, stated: &stated };
    Ok(predictors.tally(&test_questions, test.len()))
}

/// How many of a class a prompt of each room states, when it states the class (by room
/// and class; the empty room for any room).
fn stated_counts(pools: &[PromptPool]) -> BTreeMap<(String, String), Vec<String>> {
    let mut stated: BTreeMap<(String, String), Vec<String>> = BTreeMap::new();
    for prompt in pools.iter().flat_map(|p| &p.accepted) {
        let mut per_class: BTreeMap<&str, u32> = BTreeMap::new();
        for o in &prompt.spec.objects {
            if let Some(class) = osmab_dataset::questions::grounding::class_of(&o.category) {
                *per_class.entry(class).or_default() += o.count;
            }
        }
        for (class, n) in per_class {
            stated.entry((prompt.spec.room.clone(), class.to_string())).or_default().push(n.to_string());
            stated.entry((String::new(), class.to_string())).or_default().push(n.to_string());
        }
    }
    stated
}

/// What a participant could guess a test answer from without the test scenes: the open
/// (val) questions and answers, and the public prompt pools (their priors and stated counts).
struct Predictors<'a> {
    val: &'a [Question],
    priors: &'a QuestionPriors<'a>,
    stated: &'a BTreeMap<(String, String), Vec<String>>,
}

impl Predictors<'_> {
    /// The commonest val answer of template `t`.
    fn val_majority(&self, t: &str) -> Option<String> {
        mode(self.val.iter().filter(|q| template(q) == t).map(|q| q.answer.as_deref().unwrap_or("")))
    }

    /// The commonest val answer of the same form, else of the same template and class,
    /// else of the template.
    fn val_lookup(&self, q: &Question) -> Option<String> {
        let same_form = mode(self.val.iter().filter(|v| v.form == q.form && v.category == q.category).map(|v| v.answer.as_deref().unwrap_or("")));
        let form = q.form.as_ref();
        let same_class = || {
            mode(
                self.val
                    .iter()
                    .filter(|v| template(v) == template(q) && v.form.as_ref().map(first_class) == form.map(first_class))
                    .map(|v| v.answer.as_deref().unwrap_or("")),
            )
        };
        same_form.or_else(same_class).or_else(|| self.val_majority(&template(q)))
    }

    /// The answer the pool's odds favour (none for colours), read as the generator reads
    /// them: a prompt-grounded question's off the layouts whose prompt settles it.
    fn pool_odds(&self, regime: Regime, q: &Question) -> Option<String> {
        let form = q.form.as_ref()?;
        let room = room_of(&q.question).unwrap_or_default();
        let asked = if osmab_evaluator::vqa::is_prompt_grounded(&q.category) { AskedAs::PromptGrounded } else { AskedAs::Standard };
        match form {
            QuestionForm::Count { class } => {
                if self.priors.odds(asked, &room, regime, form) < 0.5 {
                    return Some("0".into());
                }
                let key = (room.clone(), class.clone());
                let counts = self.stated.get(&key).or_else(|| self.stated.get(&(String::new(), class.clone())))?;
                mode(counts.iter().map(String::as_str))
            }
            QuestionForm::Colour { .. } => None,
            other => Some(if self.priors.odds(asked, &room, regime, other) > 0.5 { "Yes".into() } else { "No".into() }),
        }
    }

    /// How often each predictor hits the test answers, per template, for each of the
    /// `scenes` test scenes (the first of each of `test_questions` is its scene's index).
    fn tally(&self, test_questions: &[(usize, Regime, Question)], scenes: usize) -> Vec<SceneTally> {
        let mut tallies: Vec<SceneTally> = vec![SceneTally::new(); scenes];
        let majorities: BTreeMap<String, Option<String>> = test_questions
            .iter()
            .map(|(_, _, q)| template(q))
            .map(|t| {
                let majority = mode(test_questions.iter().filter(|(_, _, q)| template(q) == t).map(|(_, _, q)| q.answer.as_deref().unwrap_or("")));
                (t, majority)
            })
            .collect();
        for (scene, regime, q) in test_questions {
            let t = template(q);
            let truth = q.answer.clone().unwrap_or_default();
            let hit = |guess: Option<String>| usize::from(guess.is_some_and(|g| g.eq_ignore_ascii_case(&truth)));
            let tally = tallies[*scene].entry(t.clone()).or_default();
            tally.questions += 1;
            tally.majority += hit(majorities[&t].clone());
            tally.val_majority += hit(self.val_majority(&t));
            tally.val_lookup += hit(self.val_lookup(q));
            tally.pool_odds += hit(self.pool_odds(*regime, q).or_else(|| self.val_majority(&t)));
        }
        tallies
    }
}

/// How far a predictor's lead over the majority answer (in points) could be the luck of
/// which scenes were built: the 2.5th and 97.5th percentiles of that lead over
/// [`RESAMPLES`] resamplings of the test scenes with replacement (a scene's questions stay
/// together: its answers, not its questions, are what a build draws). `hits` picks the
/// predictor's hits from a tally.
fn interval(scenes: &[TemplateTally], hits: impl Fn(&TemplateTally) -> usize) -> Option<(f64, f64)> {
    if scenes.is_empty() {
        return None;
    }
    let mut rng = osmab_evaluator::synthetic::Rng::new(0x0b00_7574_7261_7021);
    let mut leads: Vec<f64> = (0..RESAMPLES)
        .filter_map(|_| {
            let (mut lead, mut questions) = (0.0, 0usize);
            for _ in 0..scenes.len() {
                let x = &scenes[rng.below(scenes.len())];
                lead += hits(x) as f64 - x.majority as f64;
                questions += x.questions;
            }
            (questions > 0).then(|| 100.0 * lead / questions as f64)
        })
        .collect();
    leads.sort_by(f64::total_cmp);
    let at = |q: f64| leads[((leads.len() - 1) as f64 * q).round() as usize];
    (!leads.is_empty()).then(|| (at(0.025), at(0.975)))
}

/// Resamplings of the test scenes behind each interval.
const RESAMPLES: usize = 2000;

/// `osmab bench questions --release DIR…`: the table over every build given, summed, with
/// how far the scenes' luck could move each predictor's lead ([`interval`]).
pub fn run(releases: &[PathBuf], regenerate: bool, draws: u64, json: Option<&Path>) -> anyhow::Result<()> {
    let mut scenes: Vec<SceneTally> = Vec::new();
    for release in releases {
        scenes.extend(measure(release, regenerate, draws)?);
    }
    let mut total: BTreeMap<String, TemplateTally> = BTreeMap::new();
    for scene in &scenes {
        for (t, tally) in scene {
            total.entry(t.clone()).or_default().add(tally);
        }
    }
    let pct = |k: usize, n: usize| if n == 0 { "—".to_string() } else { format!("{:.1}", 100.0 * k as f64 / n as f64) };
    let span = |i: Option<(f64, f64)>| i.map_or("—".to_string(), |(lo, hi)| format!("{lo:+.1} … {hi:+.1}"));
    println!(
        "| template (category / form) | test questions | majority % | val majority % | val lookup % | pool odds % | val lookup − majority, 95 % of scene resamplings | pool odds − majority, the same |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    let row = |label: &str, x: &TemplateTally, of_scenes: &[TemplateTally]| {
        let cells = [x.majority, x.val_majority, x.val_lookup, x.pool_odds].map(|k| pct(k, x.questions));
        let leads = [span(interval(of_scenes, |t| t.val_lookup)), span(interval(of_scenes, |t| t.pool_odds))];
        println!("| {label} | {} | {} | {} |", x.questions, cells.join(" | "), leads.join(" | "));
    };
    for (t, x) in &total {
        let of_scenes: Vec<TemplateTally> = scenes.iter().map(|s| s.get(t).copied().unwrap_or_default()).collect();
        row(t, x, &of_scenes);
    }
    // Every template of a scene together, and their sum.
    let whole: Vec<TemplateTally> = scenes
        .iter()
        .map(|s| {
            let mut sum = TemplateTally::default();
            s.values().for_each(|x| sum.add(x));
            sum
        })
        .collect();
    let mut all = TemplateTally::default();
    whole.iter().for_each(|x| all.add(x));
    row("**all**", &all, &whole);
    if let Some(path) = json {
        std::fs::write(path, serde_json::to_vec_pretty(&total)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(questions: usize, majority: usize, pool_odds: usize) -> TemplateTally {
        TemplateTally { questions, majority, pool_odds, ..TemplateTally::default() }
    }

    #[test]
    fn scenes_that_all_lead_alike_leave_no_doubt_about_the_lead() {
        let scenes = vec![scene(10, 5, 6); 20];
        assert_eq!(interval(&scenes, |t| t.pool_odds), Some((10.0, 10.0)));
    }

    #[test]
    fn a_lead_that_a_few_scenes_make_is_uncertain_and_scenes_that_ask_nothing_still_count() {
        // Two scenes of twenty carry the whole lead (+10 points overall); most ask nothing.
        let mut scenes = vec![scene(0, 0, 0); 14];
        scenes.extend([scene(10, 5, 5); 4]);
        scenes.extend([scene(10, 5, 10); 2]);
        let (lo, hi) = interval(&scenes, |t| t.pool_odds).expect("some resampling asks questions");
        assert!(lo <= 0.0 && hi >= 30.0, "a lead resting on two scenes: {lo} … {hi}");
        assert_eq!(interval(&[], |t| t.pool_odds), None);
    }
}
