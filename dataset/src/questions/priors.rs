//! The odds of a question's answer before any scene is seen: every prompt of the release's
//! pool placed as the synthesizer places it (no rendering), and each question form's answer
//! read off those layouts with the very test that decides whether it is asked
//! ([`super::facts::SceneFacts::truth`]). The pool follows from the published config, so
//! anyone can compute these odds; the questions are drawn so that they tell nothing
//! ([`super::draw`]): a question whose answer the odds make likely is asked that much less.
//! A prompt-grounded question's odds are read only off the layouts whose prompt settles it
//! ([`super::grounding`]), as it is only asked of such scenes.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::{Arc, Mutex, OnceLock};

use osmab_evaluator::synthetic::Rng;
use osmab_evaluator::vqa::QuestionForm;

use super::calibration::Calibration;
use super::facts::{SceneFacts, oracle_scene_graph};
use super::grounding::{prompt_settles, stated_classes};
use super::objects::{SceneObject, object_id};
use crate::convert::lexicon::{is_shell_class, normalise_name};
use crate::prompts::{PromptPool, ScenePrompt};
use crate::spec::{Regime, SceneSpec};
use crate::synthesis::dressing::furnished;
use crate::synthesis::placement::{Layout, PlacedObject};
use crate::synthesis::source::AssetSource;

/// Layouts of the same room at least, before a room's own odds count fully.
const ROOM_WEIGHT: f64 = 1.0;

/// Which templates ask a question, and so which layouts its odds are read off: the
/// standard ones ask of every scene that settles a form; the prompt-grounded ones only of
/// scenes whose prompt settles it ([`super::grounding::prompt_settles`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AskedAs {
    Standard,
    PromptGrounded,
}

/// One simulated scene: its room, subset, the classes its prompt states, objects and the
/// oracle's graph of them.
struct Simulated {
    room: String,
    regime: Regime,
    stated: BTreeSet<&'static str>,
    objects: Vec<SceneObject>,
    graph: osmab_evaluator::vqa::graph::SceneGraph,
}

/// A prompt placed afresh, held out of the odds: what the odds are calibrated on
/// ([`super::calibration`]).
pub struct HeldOut {
    pub spec: SceneSpec,
    pub objects: Vec<SceneObject>,
}

/// Every prompt of a pool placed as the built-in synthesizer places it: what
/// [`QuestionPriors`] reads its odds from, and placements held out of them.
pub struct PoolLayouts {
    scenes: Vec<Simulated>,
    held_out: Vec<HeldOut>,
    /// The assets the layouts were placed with (their sizes decide size comparisons).
    assets: AssetSource,
}

/// Fresh placements of each prompt beside its own layout: test scenes (and later placements
/// of val scenes) are placed afresh from other seeds, so the odds see those layouts too.
const FRESH_PLACEMENTS: usize = 3;

/// Fresh placements of each prompt held out of the odds, to calibrate them on.
const HELD_OUT_PLACEMENTS: usize = 4;

impl PoolLayouts {
    /// Every accepted prompt of `pools` placed as a val scene is (from its layout seed, when
    /// it has one) and [`FRESH_PLACEMENTS`] times afresh, honouring every relation, as a
    /// test scene is (from seeds derived from `seed`); and [`HELD_OUT_PLACEMENTS`] times
    /// more afresh, held out.
    pub fn place(pools: &[PromptPool], seed: u64, assets: &AssetSource) -> Self {
        let mut rng = Rng::new(seed ^ 0x5052_494f_5253);
        let mut scenes = Vec::new();
        for prompt in pools.iter().flat_map(|pool| pool.accepted.iter()) {
            let fresh = || ScenePrompt { layout_seed: None, ..prompt.clone() };
            let mut layouts = vec![placed(prompt, rng.next_u64(), assets)];
            layouts.extend((0..FRESH_PLACEMENTS).map(|_| placed(&fresh(), rng.next_u64(), assets)));
            for layout in layouts {
                let objects = layout_objects(&layout);
                scenes.push(Simulated {
                    room: prompt.spec.room.clone(),
                    regime: prompt.spec.regime,
                    stated: stated_classes(&prompt.spec),
                    graph: oracle_scene_graph(&objects),
                    objects,
                });
            }
        }
        let mut rng = Rng::new(seed ^ 0x4845_4c44_4f55_54);
        let mut held_out = Vec::new();
        for prompt in pools.iter().flat_map(|pool| pool.accepted.iter()) {
            let fresh = ScenePrompt { layout_seed: None, ..prompt.clone() };
            for _ in 0..HELD_OUT_PLACEMENTS {
                let layout = placed(&fresh, rng.next_u64(), assets);
                held_out.push(HeldOut { spec: prompt.spec.clone(), objects: layout_objects(&layout) });
            }
        }
        PoolLayouts { scenes, held_out, assets: assets.clone() }
    }

    /// No layouts at all: every yes/no question is even odds.
    pub fn none() -> Self {
        PoolLayouts { scenes: Vec::new(), held_out: Vec::new(), assets: AssetSource::procedural() }
    }

    /// The placements held out of the odds.
    pub fn held_out(&self) -> &[HeldOut] {
        &self.held_out
    }
}

/// One layout's facts, with its room, subset and stated classes.
struct LayoutFacts<'a> {
    room: &'a str,
    regime: Regime,
    stated: &'a BTreeSet<&'static str>,
    facts: SceneFacts<'a>,
}

impl LayoutFacts<'_> {
    /// Whether questions `asked` so would ask `form` of this layout.
    fn asks(&self, asked: AskedAs, form: &QuestionForm) -> bool {
        asked == AskedAs::Standard || prompt_settles(form, self.stated, &self.facts)
    }
}

/// The odds of every question form, per room, from the layouts of a prompt pool.
pub struct QuestionPriors<'a> {
    layouts: Vec<LayoutFacts<'a>>,
    lexicon: &'a [String],
    assets: &'a AssetSource,
    memo: Mutex<HashMap<(String, Regime, String), f64>>,
    /// Per class, the volumes the asset library makes ([`library_volumes`]).
    volumes: Mutex<HashMap<String, Arc<Vec<f64>>>>,
    /// How the odds bear out, once measured ([`super::calibrated_priors`]).
    calibration: OnceLock<Calibration>,
}

/// The template a calibration tells a form's odds by: the templates that ask it, and the
/// form's kind.
pub fn template_key(asked: AskedAs, form: &QuestionForm) -> String {
    format!("{asked:?} {}", form.kind())
}

/// What an object standing on the floor rests on, as [`super::support`] reads it off a
/// rendered scene's surfaces: at each of its footprint's sample points, the highest surface
/// within [`super::support::BASE_TOLERANCE`] of its base — the top of a rug it stands on, or
/// the floor — and the commonest of those (the floor on a tie).
fn floor_support(layout: &Layout, k: usize, ids: &BTreeMap<&str, String>) -> Option<String> {
    let on_floor = |o: &PlacedObject| o.host.is_none() || o.position[2] <= 0.01;
    let ([x0, y0], [x1, y1]) = layout.objects[k].footprint();
    let mut votes: BTreeMap<usize, usize> = BTreeMap::new();
    let mut floor_votes = 0;
    for [x, y] in super::support::footprint_samples([x0, 0.0, y0], [x1, 0.0, y1]) {
        let (x, y) = (f64::from(x), f64::from(y));
        let under = layout
            .objects
            .iter()
            .enumerate()
            .filter(|(j, o)| *j != k && on_floor(o) && o.asset.size[2] <= f64::from(super::support::BASE_TOLERANCE))
            .filter(|(_, o)| {
                let ([a0, b0], [a1, b1]) = o.footprint();
                (a0..=a1).contains(&x) && (b0..=b1).contains(&y)
            })
            .max_by(|a, b| a.1.asset.size[2].total_cmp(&b.1.asset.size[2]).then(b.0.cmp(&a.0)));
        match under {
            Some((j, _)) => *votes.entry(j).or_default() += 1,
            None => floor_votes += 1,
        }
    }
    match votes.into_iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))) {
        Some((j, n)) if n > floor_votes => ids.get(layout.objects[j].object_id.as_str()).cloned(),
        _ => Some("floor".to_string()),
    }
}

/// The objects of a layout as the question generator sees a rendered scene's (every one
/// seen, y up, resting on its host, a rug it stands on, or the floor; no colour: colours are
/// drawn evenly).
pub fn layout_objects(layout: &Layout) -> Vec<SceneObject> {
    let ids: BTreeMap<&str, String> = layout.objects.iter().enumerate().map(|(k, o)| (o.object_id.as_str(), object_id(k as i64 + 1))).collect();
    layout
        .objects
        .iter()
        .enumerate()
        .filter_map(|(k, o)| {
            let label = normalise_name(&o.category).filter(|c| !is_shell_class(c))?.to_string();
            let ([x0, y0], [x1, y1]) = o.footprint();
            let height = o.asset.size[2];
            // Drake (x, y, z) is Habitat's (x, z, −y).
            let center = [(x0 + x1) / 2.0, o.position[2] + height / 2.0, -(y0 + y1) / 2.0];
            let extent = [x1 - x0, height, y1 - y0];
            let rests_on = match &o.host {
                Some(host) if o.position[2] > 0.01 => ids.get(host.as_str()).cloned(),
                _ => floor_support(layout, k, &ids),
            };
            Some(SceneObject {
                id: object_id(k as i64 + 1),
                caption: format!("a {label}"),
                label,
                bbox_center: center,
                bbox_extent: extent,
                points: 1000,
                colour: None,
                rests_on,
            })
        })
        .collect()
}

/// A prompt placed as the built-in synthesizer places it.
fn placed(prompt: &ScenePrompt, seed: u64, assets: &AssetSource) -> Layout {
    match prompt.layout_seed {
        Some(layout_seed) => furnished(&prompt.spec.primary_only(), layout_seed, assets),
        None => furnished(&prompt.spec, seed, assets),
    }
}

impl<'a> QuestionPriors<'a> {
    /// The odds read off `layouts`.
    pub fn new(layouts: &'a PoolLayouts, lexicon: &'a [String]) -> Self {
        let facts = layouts
            .scenes
            .iter()
            .map(|s| LayoutFacts { room: &s.room, regime: s.regime, stated: &s.stated, facts: SceneFacts::new(&s.objects, &s.graph, lexicon) })
            .collect();
        QuestionPriors {
            layouts: facts,
            lexicon,
            assets: &layouts.assets,
            memo: Mutex::new(HashMap::new()),
            volumes: Mutex::new(HashMap::new()),
            calibration: OnceLock::new(),
        }
    }

    /// Use `calibration` from now on ([`QuestionPriors::odds`]); a second one is ignored.
    pub fn calibrate(&self, calibration: Calibration) {
        let _ = self.calibration.set(calibration);
    }

    /// The odds of `form`'s positive answer (yes; a count above zero) in a scene of `room`,
    /// as questions `asked` so ask it: the layouts' tally, calibrated once a calibration is
    /// set. What the draw keeps each candidate against.
    pub fn odds(&self, asked: AskedAs, room: &str, regime: Regime, form: &QuestionForm) -> f64 {
        let tally = match form {
            QuestionForm::Count { class } => self.presence_odds(asked, room, regime, class),
            other => self.yes_odds(asked, room, regime, other),
        };
        match self.calibration.get() {
            Some(calibration) => calibration.calibrated(&template_key(asked, form), tally),
            None => tally,
        }
    }

    /// How many layouts the odds come from.
    pub fn layouts(&self) -> usize {
        self.layouts.len()
    }

    /// (answered yes, settled) over the layouts `which` admits, each asked what `forms`
    /// makes of it (one form, or every form of a family) where questions `asked` so ask it.
    fn tally(&self, asked: AskedAs, which: impl Fn(&LayoutFacts) -> bool, forms: impl Fn(&SceneFacts) -> Vec<QuestionForm>) -> (f64, f64) {
        let (mut yes, mut settled) = (0.0, 0.0);
        for layout in self.layouts.iter().filter(|s| which(s)) {
            let facts = &layout.facts;
            for form in forms(facts).into_iter().filter(|f| layout.asks(asked, f)) {
                if let Some(answer) = facts.truth(&form) {
                    settled += 1.0;
                    yes += f64::from(u8::from(answer == "Yes" || (matches!(form, QuestionForm::Count { .. }) && answer != "0")));
                }
            }
        }
        (yes, settled)
    }

    /// The odds of `key`, counted once: scenes assembled at once share the memo, and the
    /// odds of a key are the same whoever counts them first.
    fn memoised(&self, key: (String, Regime, String), odds: impl FnOnce() -> f64) -> f64 {
        if let Some(&p) = self.memo.lock().expect("no panic while holding the memo").get(&key) {
            return p;
        }
        let p = odds();
        self.memo.lock().expect("no panic while holding the memo").insert(key, p);
        p
    }

    /// The volumes the asset library makes of `class`, drawn once.
    fn volumes(&self, class: &str) -> Arc<Vec<f64>> {
        if let Some(v) = self.volumes.lock().expect("no panic while holding the volumes").get(class) {
            return Arc::clone(v);
        }
        let v = Arc::new(library_volumes(self.assets, class));
        self.volumes.lock().expect("no panic while holding the volumes").insert(class.to_string(), Arc::clone(&v));
        v
    }

    /// The odds that `form`'s answer is "Yes" (a count's is not zero) in a scene of `room`
    /// (of `regime`), among the layouts where questions `asked` so ask it: the room's own
    /// layouts, drawn towards the odds over the whole subset where it has few, and those
    /// towards the odds of the form's family ([`QuestionPriors::family_odds`]).
    ///
    /// A size comparison's odds are the asset library's alone: two objects' sizes follow from
    /// their variants and size jitter, whatever the room, and a tally of layouts would give
    /// odds of zero to an outcome they happen not to show (a credenza clearly larger than a
    /// cabinet), which a scene then asks with certainty.
    pub fn yes_odds(&self, asked: AskedAs, room: &str, regime: Regime, form: &QuestionForm) -> f64 {
        if matches!(form, QuestionForm::LargerThan { .. }) {
            return self.family_odds(asked, regime, form);
        }
        let key = (room.to_string(), regime, format!("{asked:?} {}", serde_json::to_string(form).expect("serialisable")));
        self.memoised(key, || {
            let family = self.family_odds(asked, regime, form);
            let (yes_subset, n_subset) = self.tally(asked, |s| s.regime == regime, |_| vec![form.clone()]);
            let subset = (yes_subset + ROOM_WEIGHT * family) / (n_subset + ROOM_WEIGHT);
            let (yes_room, n_room) = self.tally(asked, |s| s.regime == regime && s.room == room, |_| vec![form.clone()]);
            (yes_room + ROOM_WEIGHT * subset) / (n_room + ROOM_WEIGHT)
        })
    }

    /// The odds of the family a form belongs to, over the subset's layouts: what is known of
    /// a form the layouts never settle (two classes that never meet in a pool's room) —
    /// resting on the same support, being the nearest of the same class, the same relation
    /// to the same class, any pair's sizes as the asset library makes them, two classes'
    /// presence taken apart.
    fn family_odds(&self, asked: AskedAs, regime: Regime, form: &QuestionForm) -> f64 {
        let key = (String::from("(family)"), regime, format!("{asked:?} {}", family_key(form)));
        self.memoised(key, || {
            let subset = |s: &LayoutFacts| s.regime == regime;
            let (yes, n) = match form {
                QuestionForm::Exists { .. } | QuestionForm::Count { .. } => {
                    self.tally(asked, subset, |_| self.lexicon.iter().map(|c| QuestionForm::Exists { class: c.clone() }).collect())
                }
                QuestionForm::ExistsAll { classes } | QuestionForm::ExistsAny { classes } => {
                    let each: Vec<f64> = classes.iter().map(|c| self.family_free_presence(asked, regime, c)).collect();
                    let p = match form {
                        QuestionForm::ExistsAll { .. } => each.iter().product(),
                        _ => 1.0 - each.iter().map(|p| 1.0 - p).product::<f64>(),
                    };
                    return p;
                }
                QuestionForm::LargerThan { a, b } => return larger_odds(&self.volumes(a), &self.volumes(b)),
                QuestionForm::RestsOn { support, .. } => self.tally(asked, subset, |facts| {
                    facts.singles().into_iter().map(|x| QuestionForm::RestsOn { class: x.label.clone(), support: support.clone() }).collect()
                }),
                QuestionForm::NearestIs { nearest, .. } => self.tally(asked, subset, |facts| {
                    facts.singles().into_iter().map(|x| QuestionForm::NearestIs { class: x.label.clone(), nearest: nearest.clone() }).collect()
                }),
                QuestionForm::Related { relation, object, .. } => self.tally(asked, subset, |facts| {
                    facts.classes().map(|s| QuestionForm::Related { subject: s.to_string(), relation: *relation, object: object.clone() }).collect()
                }),
                QuestionForm::MoreThan { .. } => self.tally(asked, subset, |facts| {
                    let classes: Vec<&str> = facts.classes().collect();
                    classes
                        .iter()
                        .flat_map(|a| {
                            classes.iter().filter(move |b| *b != a).map(move |b| QuestionForm::MoreThan { more: a.to_string(), fewer: b.to_string() })
                        })
                        .collect()
                }),
                _ => (0.0, 0.0),
            };
            (yes + 1.0) / (n + 2.0)
        })
    }

    /// The odds of `class` being in a scene of the subset (no room, no family).
    fn family_free_presence(&self, asked: AskedAs, regime: Regime, class: &str) -> f64 {
        let (yes, n) = self.tally(asked, |s| s.regime == regime, |_| vec![QuestionForm::Exists { class: class.to_string() }]);
        (yes + 0.5) / (n + 1.0)
    }

    /// The odds that a scene of `room` has `class` (a count question's answer is not zero),
    /// among the layouts where questions `asked` so ask it.
    pub fn presence_odds(&self, asked: AskedAs, room: &str, regime: Regime, class: &str) -> f64 {
        self.yes_odds(asked, room, regime, &QuestionForm::Exists { class: class.to_string() })
    }
}

/// What identifies a form's family (see [`QuestionPriors::family_odds`]).
fn family_key(form: &QuestionForm) -> String {
    match form {
        QuestionForm::Exists { .. } | QuestionForm::Count { .. } => "presence".into(),
        QuestionForm::RestsOn { support, .. } => format!("rests on {support}"),
        QuestionForm::NearestIs { nearest, .. } => format!("nearest is {nearest}"),
        QuestionForm::Related { relation, object, .. } => format!("{} {object}", relation.words()),
        other => serde_json::to_string(other).expect("serialisable"),
    }
}

/// Draws of each class that the odds of a size comparison are counted over: enough that an
/// outcome the variants and their size jitter allow, however rare, gets odds above zero.
const SIZE_DRAWS: usize = 512;

/// The volumes of [`SIZE_DRAWS`] `class` objects as `assets` makes them (variant and
/// size jitter), sorted; a stream of draws of the class's own, so that two classes'
/// draws are independent.
fn library_volumes(assets: &AssetSource, class: &str) -> Vec<f64> {
    let mut rng = Rng::new(0x5a5a_0001 ^ crate::embedding::fnv1a(class));
    let mut volumes: Vec<f64> = (0..SIZE_DRAWS).filter_map(|_| assets.make(class, &mut rng)).map(|asset| asset.size.iter().product()).collect();
    volumes.sort_by(f64::total_cmp);
    volumes
}

/// The odds that an `a` (of `va`, its sorted volumes) is clearly larger than a `b` (of `vb`,
/// sorted), among the pairs of them that differ clearly, as
/// [`super::facts::SceneFacts::truth`] decides it.
fn larger_odds(va: &[f64], vb: &[f64]) -> f64 {
    let (mut larger, mut smaller) = (0usize, 0usize);
    for &x in va {
        larger += vb.partition_point(|&y| x / y >= super::facts::CLEARLY_LARGER);
        smaller += vb.len() - vb.partition_point(|&y| x / y > 1.0 / super::facts::CLEARLY_LARGER);
    }
    (larger as f64 + 0.5) / ((larger + smaller) as f64 + 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A placed object of the procedural library's `category`, its footprint centred at `at`.
    fn placed_at(category: &str, at: [f64; 2]) -> PlacedObject {
        let asset = AssetSource::procedural().make(category, &mut Rng::new(1)).expect("a procedural asset");
        PlacedObject {
            object_id: format!("{category}_0"),
            category: category.into(),
            kind: crate::spec::ObjectKind::Furniture,
            asset,
            position: [at[0], at[1], 0.0],
            yaw_deg: 0.0,
            host: None,
            dressing: false,
        }
    }

    #[test]
    fn a_chair_standing_on_a_rug_rests_on_the_rug_as_a_rendered_scene_reads_it() {
        let rug = placed_at("rug", [0.0, 0.0]);
        assert!(rug.asset.size[2] <= 0.03, "a rug is thin: {:?}", rug.asset.size);
        let on_rug = PlacedObject { object_id: "chair_0".into(), ..placed_at("chair", [0.1, 0.1]) };
        let off_rug = PlacedObject { object_id: "chair_1".into(), ..placed_at("chair", [5.0, 5.0]) };
        let layout = Layout { width: 12.0, depth: 12.0, wall_height: 2.5, objects: vec![rug, on_rug, off_rug], notes: Vec::new() };
        let objects = layout_objects(&layout);
        let rests: Vec<Option<&str>> = objects.iter().map(|o| o.rests_on.as_deref()).collect();
        assert_eq!(rests, [Some("floor"), Some(objects[0].id.as_str()), Some("floor")]);
    }

    #[test]
    fn a_size_comparison_s_odds_count_the_pairs_that_differ_clearly_as_a_scene_decides_them() {
        // 3 is clearly larger than 2 (1.5 times, the bound counts); 1.2 and 1 are clearly neither.
        assert_eq!(larger_odds(&[3.0], &[2.0]), 1.5 / 2.0);
        assert_eq!(larger_odds(&[2.0], &[3.0]), 0.5 / 2.0);
        assert_eq!(larger_odds(&[1.2], &[1.0]), 0.5, "no clear pair: even odds");
        // Of the six pairs of [1, 2, 3] and [1.2, 2.5]: 3 over 1.2 and 2 over 1.2 larger;
        // 1 under 2.5 smaller; the rest unclear.
        assert_eq!(larger_odds(&[1.0, 2.0, 3.0], &[1.2, 2.5]), 2.5 / 4.0);
    }

    #[test]
    fn a_size_comparison_the_pack_rarely_decides_one_way_still_has_odds_above_zero() {
        let pack = AssetSource::open(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets")).expect("the shipped pack");
        let (credenza, cabinet) = (library_volumes(&pack, "credenza"), library_volumes(&pack, "cabinet"));
        assert_eq!((credenza.len(), cabinet.len()), (SIZE_DRAWS, SIZE_DRAWS));
        // Only the pack's smallest cabinet is ever clearly smaller than a credenza, and only
        // when the size jitter widens the gap (scene builds saw it happen).
        let odds = larger_odds(&credenza, &cabinet);
        assert!(odds > 0.005 && odds < 0.2, "credenza over cabinet: {odds}");
        assert!((odds + larger_odds(&cabinet, &credenza) - 1.0).abs() < 1e-3, "the two ways of asking add up to one");
    }

    #[test]
    fn odds_follow_the_pool_s_rooms() {
        let lexicon: Vec<String> = crate::convert::lexicon::classes().into_iter().map(|c| c.name).collect();
        let pools = [crate::prompts::grammar_pool(Regime::Furniture, 120, 3)];
        let layouts = PoolLayouts::place(&pools, 1, &AssetSource::procedural());
        let priors = QuestionPriors::new(&layouts, &lexicon);
        assert_eq!(priors.layouts(), 120 * 4);
        let dining = pools[0].accepted.iter().find(|p| p.spec.room == "dining room").map(|p| p.spec.room.clone()).expect("a dining room in 120");
        let table = priors.presence_odds(AskedAs::Standard, &dining, Regime::Furniture, "dining table");
        let bed = priors.presence_odds(AskedAs::Standard, &dining, Regime::Furniture, "bed");
        assert!(table > 0.8 && bed < 0.2, "a dining room has its table ({table}) and no bed ({bed})");
        let no_layouts = PoolLayouts::none();
        let none = QuestionPriors::new(&no_layouts, &lexicon);
        assert_eq!(none.presence_odds(AskedAs::Standard, &dining, Regime::Furniture, "bed"), 0.5, "without layouts, even odds");
    }
}
