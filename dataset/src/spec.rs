//! The machine-readable side of a scene prompt: the room, every object category with
//! its exact count, and the spatial relations the prompt states. Prompt-grounded
//! questions, synthesis and the quality report all read this, never the prose.

use serde::{Deserialize, Serialize};

/// The two prompt regimes of OSMa-Bench++ (also the subsets scores are reported over).
pub use osmab_evaluator::scores::Regime;

/// Whether an object stands on the floor or is a small object resting on furniture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectKind {
    /// Floor-supported furniture.
    Furniture,
    /// A small object that rests on, under or inside furniture.
    Manipuland,
}

/// One object category of a scene with its exact count.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ObjectSpec {
    /// Category name, lower case, singular (`dining chair`).
    pub category: String,
    /// How many the prompt states.
    pub count: u32,
    /// Furniture or manipuland.
    pub kind: ObjectKind,
}

/// A spatial relation the prompt states.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RelationKind {
    /// Resting on top of the target.
    On,
    /// Below the target (under a table, under a desk).
    Under,
    /// Within the target (inside a cabinet).
    Inside,
    /// Beside the target, touching distance.
    NextTo,
    /// Close to the target.
    Near,
    /// Between two targets.
    Between,
    /// Behind the target.
    Behind,
    /// In front of the target.
    InFrontOf,
    /// Arranged around the target.
    Around,
    /// Facing the target.
    Facing,
    /// On the opposite side of the room from the target.
    Opposite,
    /// Parallel to the target.
    ParallelTo,
    /// Against a wall (no target).
    AgainstWall,
    /// Along a wall (no target).
    AlongWall,
    /// In a corner of the room (no target).
    InCorner,
    /// In the centre of the room (no target).
    CenterOfRoom,
}

impl RelationKind {
    /// How many target categories the relation takes.
    pub fn arity(self) -> usize {
        match self {
            RelationKind::Between => 2,
            RelationKind::AgainstWall | RelationKind::AlongWall | RelationKind::InCorner | RelationKind::CenterOfRoom => 0,
            _ => 1,
        }
    }

    /// The phrase the prompts use for it.
    pub fn phrase(self) -> &'static str {
        match self {
            RelationKind::On => "on",
            RelationKind::Under => "under",
            RelationKind::Inside => "inside",
            RelationKind::NextTo => "next to",
            RelationKind::Near => "near",
            RelationKind::Between => "between",
            RelationKind::Behind => "behind",
            RelationKind::InFrontOf => "in front of",
            RelationKind::Around => "around",
            RelationKind::Facing => "facing",
            RelationKind::Opposite => "opposite",
            RelationKind::ParallelTo => "parallel to",
            RelationKind::AgainstWall => "against the wall",
            RelationKind::AlongWall => "along the wall",
            RelationKind::InCorner => "in the corner of the room",
            RelationKind::CenterOfRoom => "in the center of the room",
        }
    }

    /// Whether the relation means the subject is supported by the target.
    pub fn is_support(self) -> bool {
        matches!(self, RelationKind::On | RelationKind::Inside)
    }
}

/// "`subject` is `kind` `targets`" (e.g. chair around table, box under desk).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Relation {
    /// Category of the object the relation is about.
    pub subject: String,
    /// The relation.
    pub kind: RelationKind,
    /// Categories it relates to (none, one, or two for `between`).
    #[serde(default)]
    pub targets: Vec<String>,
}

/// Longest category name accepted.
pub const MAX_CATEGORY_LEN: usize = 40;
/// Most objects of one category in a scene.
pub const MAX_COUNT: u32 = 30;

/// The structured specification of one scene.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SceneSpec {
    /// Regime the scene belongs to.
    pub regime: Regime,
    /// Room type (`dining room`).
    pub room: String,
    /// Object categories with counts, each category once.
    pub objects: Vec<ObjectSpec>,
    /// Stated relations between categories.
    pub relations: Vec<Relation>,
}

impl SceneSpec {
    /// The spec of category `category`.
    pub fn object(&self, category: &str) -> Option<&ObjectSpec> {
        self.objects.iter().find(|o| o.category == category)
    }

    /// The spec with only each subject's first (primary) relation: what placement
    /// follows when the other relations are already known to hold.
    pub fn primary_only(&self) -> SceneSpec {
        let mut relations: Vec<Relation> = Vec::new();
        for r in &self.relations {
            if !relations.iter().any(|p| p.subject == r.subject) {
                relations.push(r.clone());
            }
        }
        SceneSpec { relations, ..self.clone() }
    }

    /// All objects together.
    pub fn total_objects(&self) -> u32 {
        self.objects.iter().map(|o| o.count).sum()
    }

    /// Problems that make the spec unusable: repeated or empty categories, zero counts,
    /// relations about unknown categories or with the wrong number of targets.
    pub fn problems(&self) -> Vec<String> {
        let mut problems = Vec::new();
        if self.room.trim().is_empty() {
            problems.push("room is empty".to_string());
        }
        if self.objects.is_empty() || self.objects.len() > 40 {
            problems.push(format!("{} object categories; expected 1..=40", self.objects.len()));
        }
        if self.relations.len() > 100 {
            problems.push(format!("{} relations; expected at most 100", self.relations.len()));
        }
        for (i, o) in self.objects.iter().enumerate() {
            // Categories become file names, XML and YAML: keep them plain.
            let plain = o.category.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == ' ' || c == '-');
            if o.category.trim().is_empty() || o.category.len() > MAX_CATEGORY_LEN || !plain || o.category.contains("  ") || o.category != o.category.trim() {
                problems.push(format!(
                    "objects[{i}].category '{}' must be 1..={MAX_CATEGORY_LEN} lower-case letters, digits, single spaces or hyphens",
                    o.category
                ));
            }
            if o.count == 0 || o.count > MAX_COUNT {
                problems.push(format!("objects[{i}] ({}) has count {}; expected 1..={MAX_COUNT}", o.category, o.count));
            }
            if self.objects[..i].iter().any(|p| p.category == o.category) {
                problems.push(format!("category '{}' is listed twice", o.category));
            }
        }
        for (i, r) in self.relations.iter().enumerate() {
            for name in std::iter::once(&r.subject).chain(&r.targets) {
                if self.object(name).is_none() {
                    problems.push(format!("relations[{i}] names '{name}', which is not one of the objects"));
                }
            }
            if r.targets.len() != r.kind.arity() {
                problems.push(format!("relations[{i}] ({}) needs {} target(s), has {}", r.kind.phrase(), r.kind.arity(), r.targets.len()));
            }
        }
        problems
    }
}
