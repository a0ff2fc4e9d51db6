//! The built-in prompt writer: a seeded grammar over room plans. Each plan names an
//! anchor piece of furniture, the furniture that may accompany it and where, and (for
//! the manipuland regime) the small objects that may rest on, under or inside it. A
//! prompt is drawn by choosing a plan, a subset of companions, counts, relations and
//! sentence templates; the spec is built alongside the text, so they always agree.

use osmab_evaluator::synthetic::Rng;

use crate::spec::{ObjectKind, ObjectSpec, Regime, Relation, RelationKind, SceneSpec};
use crate::synthesis::placement::{Layout, place};
use crate::synthesis::relations::satisfied_by;
use crate::synthesis::source::AssetSource;

/// Where a companion goes, relative to the anchor or the room.
#[derive(Clone, Copy)]
enum Place {
    /// A relation to the anchor.
    Anchor(RelationKind),
    /// A relation to the room (against a wall, in a corner, ...).
    Room(RelationKind),
}

struct Companion {
    category: &'static str,
    counts: (u32, u32),
    places: &'static [Place],
}

struct RoomPlan {
    room: &'static str,
    anchor: &'static str,
    anchor_counts: (u32, u32),
    anchor_place: RelationKind,
    companions: &'static [Companion],
    /// Small objects for the manipuland regime: (category, relations to the anchor).
    smalls: &'static [(&'static str, &'static [RelationKind])],
}

use Place::{Anchor as A, Room as R};
use RelationKind::*;

const ON_TOP: &[RelationKind] = &[On];
const ON_OR_UNDER: &[RelationKind] = &[On, Under];
const UNDER_ONLY: &[RelationKind] = &[Under];
const INSIDE_OR_ON: &[RelationKind] = &[Inside, On];

const PLANS: &[RoomPlan] = &[
    RoomPlan {
        room: "dining room",
        anchor: "dining table",
        anchor_counts: (1, 1),
        anchor_place: CenterOfRoom,
        companions: &[
            Companion { category: "dining chair", counts: (4, 8), places: &[A(Around)] },
            Companion { category: "sideboard", counts: (1, 1), places: &[R(AgainstWall), A(Behind)] },
            Companion { category: "bench", counts: (1, 2), places: &[R(AlongWall), A(NextTo)] },
            Companion { category: "cabinet", counts: (1, 2), places: &[R(InCorner), R(AgainstWall)] },
            Companion { category: "console table", counts: (1, 1), places: &[R(AlongWall), A(Opposite)] },
        ],
        smalls: &[("plate", ON_TOP), ("bowl", ON_TOP), ("bottle", ON_TOP), ("mug", ON_TOP), ("box", UNDER_ONLY)],
    },
    RoomPlan {
        room: "living room",
        anchor: "coffee table",
        anchor_counts: (1, 1),
        anchor_place: CenterOfRoom,
        companions: &[
            Companion { category: "sofa", counts: (1, 2), places: &[A(Facing), A(Behind)] },
            Companion { category: "armchair", counts: (1, 2), places: &[A(NextTo), A(Facing), A(Around)] },
            Companion { category: "tv stand", counts: (1, 1), places: &[R(AgainstWall), A(Opposite)] },
            Companion { category: "bookshelf", counts: (1, 2), places: &[R(AlongWall), R(InCorner)] },
            Companion { category: "console table", counts: (1, 1), places: &[R(AgainstWall), A(ParallelTo)] },
        ],
        smalls: &[("book", ON_OR_UNDER), ("mug", ON_TOP), ("bowl", ON_TOP), ("clock", ON_TOP), ("box", UNDER_ONLY)],
    },
    RoomPlan {
        room: "bedroom",
        anchor: "bed",
        anchor_counts: (1, 1),
        anchor_place: AgainstWall,
        companions: &[
            Companion { category: "nightstand", counts: (1, 2), places: &[A(NextTo)] },
            Companion { category: "wardrobe", counts: (1, 1), places: &[R(InCorner), A(Opposite)] },
            Companion { category: "dresser", counts: (1, 1), places: &[A(Opposite), R(AlongWall)] },
            Companion { category: "desk", counts: (1, 1), places: &[R(AgainstWall), A(Facing)] },
            Companion { category: "bench", counts: (1, 1), places: &[A(InFrontOf)] },
            Companion { category: "armchair", counts: (1, 1), places: &[R(InCorner), A(Near)] },
        ],
        smalls: &[("pillow", ON_TOP), ("blanket", ON_TOP), ("book", ON_TOP), ("towel", ON_TOP)],
    },
    RoomPlan {
        room: "office",
        anchor: "desk",
        anchor_counts: (1, 2),
        anchor_place: CenterOfRoom,
        companions: &[
            Companion { category: "office chair", counts: (1, 2), places: &[A(InFrontOf)] },
            Companion { category: "filing cabinet", counts: (1, 2), places: &[A(NextTo), R(AgainstWall)] },
            Companion { category: "bookshelf", counts: (1, 2), places: &[R(AlongWall), A(Behind)] },
            Companion { category: "storage cabinet", counts: (1, 1), places: &[R(InCorner)] },
            Companion { category: "armchair", counts: (1, 1), places: &[A(Opposite), R(InCorner)] },
        ],
        smalls: &[("laptop", ON_TOP), ("book", ON_TOP), ("mug", ON_TOP), ("box", ON_OR_UNDER), ("backpack", UNDER_ONLY), ("clock", ON_TOP)],
    },
    RoomPlan {
        room: "meeting room",
        anchor: "conference table",
        anchor_counts: (1, 1),
        anchor_place: CenterOfRoom,
        companions: &[
            Companion { category: "chair", counts: (4, 10), places: &[A(Around)] },
            Companion { category: "credenza", counts: (1, 1), places: &[R(AgainstWall), A(Behind)] },
            Companion { category: "cabinet", counts: (1, 2), places: &[R(InCorner)] },
            Companion { category: "bench", counts: (1, 1), places: &[R(AlongWall), A(Opposite)] },
        ],
        smalls: &[("laptop", ON_TOP), ("bottle", ON_TOP), ("book", ON_TOP), ("box", UNDER_ONLY)],
    },
    RoomPlan {
        room: "kitchen",
        anchor: "kitchen island",
        anchor_counts: (1, 1),
        anchor_place: CenterOfRoom,
        companions: &[
            Companion { category: "counter", counts: (1, 3), places: &[R(AlongWall), A(ParallelTo)] },
            Companion { category: "chair", counts: (2, 4), places: &[A(NextTo), A(Around)] },
            Companion { category: "cabinet", counts: (1, 2), places: &[R(AgainstWall), R(InCorner)] },
            Companion { category: "dining table", counts: (1, 1), places: &[A(Near), A(Behind)] },
        ],
        smalls: &[("bowl", ON_TOP), ("plate", ON_TOP), ("mug", ON_TOP), ("bottle", ON_TOP), ("can", ON_TOP)],
    },
    RoomPlan {
        room: "workshop",
        anchor: "workbench",
        anchor_counts: (1, 2),
        anchor_place: AgainstWall,
        companions: &[
            Companion { category: "storage rack", counts: (1, 3), places: &[R(AlongWall), A(NextTo)] },
            Companion { category: "cabinet", counts: (1, 2), places: &[A(NextTo), R(InCorner)] },
            Companion { category: "table", counts: (1, 1), places: &[R(CenterOfRoom), A(Opposite)] },
            Companion { category: "chair", counts: (1, 2), places: &[A(InFrontOf)] },
        ],
        smalls: &[("bucket", UNDER_ONLY), ("box", INSIDE_OR_ON), ("can", ON_TOP), ("helmet", ON_TOP), ("bottle", ON_TOP)],
    },
    RoomPlan {
        room: "reception area",
        anchor: "coffee table",
        anchor_counts: (1, 1),
        anchor_place: CenterOfRoom,
        companions: &[
            Companion { category: "sofa", counts: (2, 2), places: &[A(Around), A(Facing)] },
            Companion { category: "armchair", counts: (2, 4), places: &[A(Around), A(NextTo)] },
            Companion { category: "reception desk", counts: (1, 1), places: &[R(AgainstWall), A(Opposite)] },
            Companion { category: "bookshelf", counts: (1, 1), places: &[R(AlongWall)] },
        ],
        smalls: &[("book", ON_OR_UNDER), ("bowl", ON_TOP), ("clock", ON_TOP), ("box", UNDER_ONLY)],
    },
    RoomPlan {
        room: "study",
        anchor: "bookshelf",
        anchor_counts: (2, 4),
        anchor_place: AlongWall,
        companions: &[
            Companion { category: "desk", counts: (1, 1), places: &[R(CenterOfRoom), A(Opposite)] },
            Companion { category: "chair", counts: (1, 2), places: &[A(InFrontOf), A(Near)] },
            Companion { category: "armchair", counts: (1, 2), places: &[A(Facing), R(InCorner)] },
            Companion { category: "coffee table", counts: (1, 1), places: &[A(Near), R(CenterOfRoom)] },
        ],
        smalls: &[("book", INSIDE_OR_ON), ("box", INSIDE_OR_ON), ("clock", ON_TOP)],
    },
    RoomPlan {
        room: "laundry room",
        anchor: "counter",
        anchor_counts: (1, 2),
        anchor_place: AlongWall,
        companions: &[
            Companion { category: "storage cabinet", counts: (1, 2), places: &[A(NextTo), R(InCorner)] },
            Companion { category: "shelf", counts: (1, 2), places: &[R(AgainstWall), A(Opposite)] },
            Companion { category: "bench", counts: (1, 1), places: &[R(CenterOfRoom), A(InFrontOf)] },
            Companion { category: "table", counts: (1, 1), places: &[A(Near)] },
        ],
        smalls: &[("towel", INSIDE_OR_ON), ("bottle", ON_TOP), ("box", INSIDE_OR_ON), ("bucket", ON_TOP)],
    },
];

/// English plural of a category (`shelf` → `shelves`, `bench` → `benches`).
pub fn plural(category: &str) -> String {
    let (head, last) = match category.rsplit_once(' ') {
        Some((h, l)) => (format!("{h} "), l),
        None => (String::new(), category),
    };
    let last = if let Some(stem) = last.strip_suffix("shelf") {
        format!("{stem}shelves")
    } else if last.ends_with("ch") || last.ends_with("sh") || last.ends_with('x') || last.ends_with('s') {
        format!("{last}es")
    } else {
        format!("{last}s")
    };
    format!("{head}{last}")
}

/// `n category` with the right number.
fn counted(n: u32, category: &str) -> String {
    if n == 1 { format!("1 {category}") } else { format!("{n} {}", plural(category)) }
}

fn pick<'a, T>(rng: &mut Rng, items: &'a [T]) -> &'a T {
    &items[rng.below(items.len())]
}

fn count_in(rng: &mut Rng, (lo, hi): (u32, u32)) -> u32 {
    lo + rng.below((hi - lo + 1) as usize) as u32
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next().map(|f| f.to_uppercase().collect::<String>() + c.as_str()).unwrap_or_default()
}

/// The phrase placing something relative to `targets` (`around the dining table`);
/// a target with several members is named in the plural.
fn relation_phrase(kind: RelationKind, targets: &[String], count_of: impl Fn(&str) -> u32) -> String {
    let the = |t: &String| if count_of(t) > 1 { format!("the {}", plural(t)) } else { format!("the {t}") };
    match targets {
        [] => kind.phrase().to_string(),
        [t] => format!("{} {}", kind.phrase(), the(t)),
        [a, b] => format!("{} {} and {}", kind.phrase(), the(a), the(b)),
        _ => unreachable!("relations take at most two targets"),
    }
}

/// "The sofas are facing ..." or "The sofa is facing ...".
fn subject_is(category: &str, count: u32) -> String {
    if count == 1 { format!("The {category} is") } else { format!("The {} are", plural(category)) }
}

/// Relations of `subject` to other furniture that hold in `layout` for every instance.
fn true_relations(layout: &Layout, spec: &SceneSpec, subject: &str, kinds: &[RelationKind], furniture: &[ObjectSpec]) -> Vec<Relation> {
    let room = [layout.width, layout.depth];
    let mut found = Vec::new();
    for target in furniture.iter().filter(|f| f.category != subject) {
        for &kind in kinds {
            let r = Relation { subject: subject.into(), kind, targets: vec![target.category.clone()] };
            let instances: Vec<_> = layout.objects.iter().filter(|o| o.category == subject).collect();
            if !spec.relations.contains(&r) && !instances.is_empty() && instances.iter().all(|s| satisfied_by(&r, s, &layout.objects, room, true)) {
                found.push(r);
            }
        }
    }
    found
}

/// Write one prompt of `regime` from `rng`: its text, its spec, the seed of the layout
/// it describes, and the relations that layout fails (a prompt with any is not used).
pub fn write_prompt(regime: Regime, rng: &mut Rng, assets: &AssetSource) -> (String, SceneSpec, u64, Vec<String>) {
    let plan = pick(rng, PLANS);
    let mut draft = Draft::opening(regime, plan, rng);
    let furniture: Vec<ObjectSpec> = draft.objects.clone();
    if regime == Regime::Manipuland {
        draft.add_small_objects(plan, &furniture, rng);
    }

    // Place what the first sentences say, then describe relations that hold in that
    // layout: the prompt states only what its scene will show.
    let layout_seed = rng.next_u64();
    let primary = SceneSpec { regime, room: plan.room.into(), objects: draft.objects, relations: draft.relations };
    let layout = place(&primary, layout_seed, assets);
    let mut described = Described { layout: &layout, furniture: &furniture, spec: primary, sentences: draft.sentences };
    if regime == Regime::Manipuland {
        described.target_relation(rng);
    }
    described.furniture_relations(regime, plan.anchor, rng);
    let unmet = crate::synthesis::relations::unmet_relations(&described.spec, &layout);
    (described.sentences.join(" "), described.spec, layout_seed, unmet)
}

/// A prompt's first sentences as they are drawn: the objects they name, how those are
/// placed, the sentences.
struct Draft {
    objects: Vec<ObjectSpec>,
    relations: Vec<Relation>,
    sentences: Vec<String>,
    anchor_count: u32,
}

impl Draft {
    /// The opening sentence: `plan`'s anchor and, in a random order, as many of its
    /// companions as `regime` needs, each placed relative to the anchor or the room.
    fn opening(regime: Regime, plan: &RoomPlan, rng: &mut Rng) -> Draft {
        let anchor_count = count_in(rng, plan.anchor_counts);
        let mut objects = vec![ObjectSpec { category: plan.anchor.into(), count: anchor_count, kind: ObjectKind::Furniture }];
        let mut relations = vec![Relation { subject: plan.anchor.into(), kind: plan.anchor_place, targets: vec![] }];
        let mut order: Vec<usize> = (0..plan.companions.len()).collect();
        for i in (1..order.len()).rev() {
            order.swap(i, rng.below(i + 1));
        }
        let wanted = match regime {
            Regime::Furniture => 3 + rng.below(plan.companions.len().min(5) - 2),
            Regime::Manipuland => 1 + rng.below(2),
        };
        let mut clauses = vec![format!("{} {}", counted(anchor_count, plan.anchor), plan.anchor_place.phrase())];
        for &c in order.iter().take(wanted.min(plan.companions.len())) {
            let companion = &plan.companions[c];
            let mut count = count_in(rng, companion.counts);
            if regime == Regime::Manipuland {
                count = count.min(2);
            }
            let (kind, targets) = match *pick(rng, companion.places) {
                Place::Anchor(k) => (k, vec![plan.anchor.to_string()]),
                Place::Room(k) => (k, vec![]),
            };
            clauses.push(format!("{} {}", counted(count, companion.category), relation_phrase(kind, &targets, |_| anchor_count)));
            objects.push(ObjectSpec { category: companion.category.into(), count, kind: ObjectKind::Furniture });
            relations.push(Relation { subject: companion.category.into(), kind, targets });
        }
        let openers = ["A {room} with", "The {room} contains", "This {room} has", "A furnished {room} holds", "The layout of the {room} has"];
        let opener = pick(rng, &openers).replace("{room}", plan.room);
        let (last, rest) = clauses.split_last().expect("anchor clause");
        let list = if rest.len() == 1 { format!("{} and {last}", rest[0]) } else { format!("{}, and {last}", rest.join(", ")) };
        Draft { objects, relations, sentences: vec![format!("{opener} {list}.")], anchor_count }
    }

    /// A manipuland prompt's small objects: the main target and at most one secondary group
    /// resting on a surface among the `furniture`.
    fn add_small_objects(&mut self, plan: &RoomPlan, furniture: &[ObjectSpec], rng: &mut Rng) {
        let anchor_count = self.anchor_count;
        let (target, target_relations) = *pick(rng, plan.smalls);
        let target_count = 1 + rng.below(2) as u32;
        let target_relation = *pick(rng, target_relations);
        let anchor_phrase = relation_phrase(target_relation, &[plan.anchor.to_string()], |_| anchor_count);
        self.sentences.push(format!(
            "{}, there {} {}.",
            capitalise(&anchor_phrase),
            if target_count == 1 { "is" } else { "are" },
            counted(target_count, target)
        ));
        self.objects.push(ObjectSpec { category: target.into(), count: target_count, kind: ObjectKind::Manipuland });
        self.relations.push(Relation { subject: target.into(), kind: target_relation, targets: vec![plan.anchor.into()] });
        let others: Vec<&(&str, &[RelationKind])> = plan.smalls.iter().filter(|(c, r)| *c != target && r.contains(&On)).collect();
        if !others.is_empty() && rng.unit() < 0.7 {
            let (group, _) = **pick(rng, &others);
            let n = 2 + rng.below(3) as u32;
            let host = pick(rng, furniture).category.clone();
            let host_is_surface = plan.anchor == host || !matches!(host.as_str(), "dining chair" | "chair" | "office chair" | "armchair");
            let host = if host_is_surface { host } else { plan.anchor.to_string() };
            let host_count = furniture.iter().find(|o| o.category == host).map_or(1, |o| o.count);
            self.sentences.push(format!(
                "{} {} {}.",
                capitalise(&counted(n, group)),
                if n == 1 { "rests" } else { "rest" },
                relation_phrase(On, &[host.clone()], |_| host_count)
            ));
            self.objects.push(ObjectSpec { category: group.into(), count: n, kind: ObjectKind::Manipuland });
            self.relations.push(Relation { subject: group.into(), kind: On, targets: vec![host] });
        }
    }
}

/// A prompt's spec and sentences growing by relations that hold in its placed `layout`.
struct Described<'a> {
    layout: &'a Layout,
    furniture: &'a [ObjectSpec],
    spec: SceneSpec,
    sentences: Vec<String>,
}

impl Described<'_> {
    /// A manipuland prompt's target placed relative to furniture, preferring the strong
    /// relations the filter asks for (in front of, behind).
    fn target_relation(&mut self, rng: &mut Rng) {
        let target = self.spec.objects.iter().find(|o| o.kind == ObjectKind::Manipuland).map(|o| (o.category.clone(), o.count));
        if let Some((target, target_count)) = target {
            let found = true_relations(self.layout, &self.spec, &target, &[InFrontOf, Behind, NextTo, Near], self.furniture);
            let strong: Vec<&Relation> = found.iter().filter(|r| matches!(r.kind, InFrontOf | Behind)).collect();
            let choice = if strong.is_empty() { found.first() } else { Some(*pick(rng, &strong)) };
            if let Some(r) = choice.cloned() {
                let count = self.furniture.iter().find(|f| f.category == r.targets[0]).map_or(1, |f| f.count);
                self.sentences.push(format!("{} {}.", subject_is(&target, target_count), relation_phrase(r.kind, &r.targets, |_| count)));
                self.spec.relations.push(r);
            }
        }
    }

    /// A few more relations between the furniture (but the `anchor`), drawn from those
    /// that hold: two to four for a furniture prompt, one for a manipuland prompt still
    /// short of three sentences.
    fn furniture_relations(&mut self, regime: Regime, anchor: &str, rng: &mut Rng) {
        let extra = match regime {
            Regime::Furniture => 2 + rng.below(3),
            Regime::Manipuland => usize::from(self.sentences.len() < 3),
        };
        let furniture = self.furniture;
        let mut candidates: Vec<Relation> = Vec::new();
        for f in furniture.iter().filter(|f| f.category != anchor) {
            candidates.extend(true_relations(self.layout, &self.spec, &f.category, &[Behind, InFrontOf, NextTo, Opposite, Facing, ParallelTo], furniture));
        }
        for _ in 0..extra {
            if candidates.is_empty() {
                break;
            }
            let r = candidates.swap_remove(rng.below(candidates.len()));
            candidates.retain(|c| c.subject != r.subject || c.kind != r.kind);
            let count_of = |c: &str| furniture.iter().find(|o| o.category == c).map_or(1, |o| o.count);
            let subject_count = count_of(&r.subject);
            self.sentences.push(format!("{} {}.", subject_is(&r.subject, subject_count), relation_phrase(r.kind, &r.targets, count_of)));
            self.spec.relations.push(r);
        }
    }
}
