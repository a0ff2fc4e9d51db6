//! The axes a score is reported along — metric, aggregate, lighting, subset, question set
//! and question group — each a closed set with its name in files and its label on pages,
//! defined here once. Variants are declared in the order of their file names, so maps
//! keyed by them serialise exactly as maps keyed by the names did.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// Declares a closed set of names: `ALL` in report order, `name()` as written in files,
/// `label()` as the paper prints it, `FromStr` that lists the accepted names.
macro_rules! axis {
    ($(#[$doc:meta])* $ty:ident, $what:literal, [$($variant:ident = $name:literal, $label:literal;)+]) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, schemars::JsonSchema)]
        pub enum $ty {
            $(#[serde(rename = $name)] $variant,)+
        }

        impl $ty {
            /// Every value, in report order.
            pub const ALL: [$ty; [$($name),+].len()] = [$($ty::$variant,)+];

            /// The name as written in files, JSON keys and CSV columns.
            pub const fn name(self) -> &'static str {
                match self { $($ty::$variant => $name,)+ }
            }

            /// The name as the paper prints it.
            pub const fn label(self) -> &'static str {
                match self { $($ty::$variant => $label,)+ }
            }
        }

        impl fmt::Display for $ty {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }

        impl TryFrom<String> for $ty {
            type Error = String;
            fn try_from(s: String) -> Result<Self, String> {
                s.parse()
            }
        }

        impl FromStr for $ty {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                match s {
                    $($name => Ok($ty::$variant),)+
                    other => Err(format!(concat!("unknown ", $what, " '{}' (expected one of {})"), other, [$($name),+].join(", "))),
                }
            }
        }
    };
}

axis!(
    /// A headline segmentation metric.
    Metric, "metric", [
        Fmiou = "fmiou", "f-mIoU";
        Macc = "macc", "mAcc";
        Miou = "miou", "mIoU";
    ]
);

impl Metric {
    /// Metrics in column order (mIoU first, as the paper's tables).
    pub const COLUMNS: [Metric; 3] = [Metric::Miou, Metric::Fmiou, Metric::Macc];
}

axis!(
    /// How scene metrics are combined: the metrics of the pooled confusion matrix, or the
    /// mean of the scene rows.
    Aggregate, "aggregate", [
        Overall = "overall", "Pooled";
        OverallMean = "overall_mean", "Mean over scenes";
    ]
);

axis!(
    /// A lighting of a sequence: the four of an OSMa-Bench++ release, and the two more of
    /// the original OSMa-Bench (ReplicaCAD) whose published figures the scorer reproduces.
    Lighting, "lighting", [
        Baseline = "baseline", "Baseline";
        Camera = "camera", "Camera Light";
        CameraLights = "camera_lights", "Camera Lights";
        DynamicLights = "dynamic_lights", "Dynamic Lights";
        NoLights = "no_lights", "Nominal Lights";
        Velocity = "velocity", "Velocity";
    ]
);

axis!(
    /// A lighting an OSMa-Bench++ release is rendered under: the four the dataset crate
    /// lights a scene for, a subset of [`Lighting`]. Adding one here is guided by the
    /// compiler: [`Lighting`] needs its variant ([`ReleaseLighting::lighting`] stops), the renderer
    /// its light settings (`osmab_dataset::convert::lighting`), the ground-truth
    /// controls their severity (`osmab_dataset::baselines`); docs/architecture.md walks
    /// through it.
    ReleaseLighting, "lighting", [
        Baseline = "baseline", "Baseline";
        Camera = "camera", "Camera Light";
        DynamicLights = "dynamic_lights", "Dynamic Lights";
        NoLights = "no_lights", "Nominal Lights";
    ]
);

impl From<ReleaseLighting> for Lighting {
    fn from(lighting: ReleaseLighting) -> Lighting {
        lighting.lighting()
    }
}

impl ReleaseLighting {
    /// The lighting the others are compared against.
    pub const BASELINE: ReleaseLighting = ReleaseLighting::Baseline;

    /// The same lighting on the score document's axis.
    pub const fn lighting(self) -> Lighting {
        match self {
            ReleaseLighting::Baseline => Lighting::Baseline,
            ReleaseLighting::Camera => Lighting::Camera,
            ReleaseLighting::DynamicLights => Lighting::DynamicLights,
            ReleaseLighting::NoLights => Lighting::NoLights,
        }
    }
}

impl Lighting {
    /// The lighting the others are compared against.
    pub const BASELINE: Lighting = Lighting::Baseline;
    /// The lightings of an OSMa-Bench++ release, in render order: [`ReleaseLighting::ALL`].
    pub const RELEASE: [Lighting; ReleaseLighting::ALL.len()] = {
        let mut all = [Lighting::Baseline; ReleaseLighting::ALL.len()];
        let mut i = 0;
        while i < all.len() {
            all[i] = ReleaseLighting::ALL[i].lighting();
            i += 1;
        }
        all
    };

    /// The lighting as a release renders it, or `None` for the original OSMa-Bench's
    /// lightings that no release holds.
    pub const fn in_release(self) -> Option<ReleaseLighting> {
        match self {
            Lighting::Baseline => Some(ReleaseLighting::Baseline),
            Lighting::Camera => Some(ReleaseLighting::Camera),
            Lighting::DynamicLights => Some(ReleaseLighting::DynamicLights),
            Lighting::NoLights => Some(ReleaseLighting::NoLights),
            Lighting::CameraLights | Lighting::Velocity => None,
        }
    }

    /// What the lighting is, in one line (pages show it beside a frame under it).
    pub const fn explanation(self) -> &'static str {
        match self {
            Lighting::Baseline => "Ceiling lights on a grid, calibrated per room: the reference the others are compared against.",
            Lighting::Camera => "Only a lamp riding with the camera: near surfaces bright, the far room dim, as a robot's headlight.",
            Lighting::CameraLights => "The scene's lights plus a lamp on the camera (OSMa-Bench).",
            Lighting::DynamicLights => "The ceiling lights in two zones, switched and dimmed goal by goal: the room brightens and darkens along the way.",
            Lighting::NoLights => {
                "No light sources: every surface shows its own colour at full strength (mesh emission), so the frame is flat and often the brightest, without shading or shadows."
            }
            Lighting::Velocity => "Baseline lighting, the camera moving faster (OSMa-Bench).",
        }
    }

    /// A short label for narrow column headers.
    pub const fn short_label(self) -> &'static str {
        match self {
            Lighting::Camera => "Camera",
            Lighting::DynamicLights => "Dynamic",
            Lighting::NoLights => "Nominal",
            other => other.label(),
        }
    }
}

axis!(
    /// The two prompt regimes of OSMa-Bench++, which are also the subsets scores are
    /// reported over.
    Regime, "subset", [
        Furniture = "furniture", "Furniture";
        Manipuland = "manipuland", "Manipuland";
    ]
);

axis!(
    /// The two splits of a release: `val` scenes are open (their ground truth is public,
    /// so teams score them offline); `test` scenes publish no semantics and no answers,
    /// and are scored by the server only.
    Split, "split", [
        Test = "test", "Test";
        Val = "val", "Validation";
    ]
);

impl Default for Split {
    /// A scene of a release built before splits existed: all its files are public.
    fn default() -> Self {
        Split::Val
    }
}

axis!(
    /// The two sets of VQA questions.
    QuestionSet, "question set", [
        PromptGrounded = "prompt_grounded", "PromptGT";
        Standard = "standard", "Standard";
    ]
);

axis!(
    /// The paper's groups of question categories.
    QuestionGroup, "question group", [
        Measurements = "Measurements", "Measurements";
        Relations = "Relations", "Relations";
    ]
);

impl QuestionSet {
    /// Every (set, group) pair, in the order tables put their columns: each set's groups in turn.
    pub fn with_groups() -> impl Iterator<Item = (QuestionSet, QuestionGroup)> {
        QuestionSet::ALL.iter().flat_map(|&set| QuestionGroup::ALL.iter().map(move |&group| (set, group)))
    }

    /// The set a category belongs to.
    pub fn of_category(category: &str) -> QuestionSet {
        if category.starts_with("PromptGT-") { QuestionSet::PromptGrounded } else { QuestionSet::Standard }
    }
}

impl QuestionGroup {
    /// The group a category is reported under in the paper's tables: `Measurements`
    /// (PromptGT-Measurement, Measurement) or `Relations` (PromptGT-Relations and
    /// -Existence, as OSMa-Bench++ merges them; Object Relations - Spatial and -
    /// Functional); `None` for the categories the tables leave out.
    pub fn of_category(category: &str) -> Option<QuestionGroup> {
        match category {
            "PromptGT-Measurement" | "Measurement" => Some(QuestionGroup::Measurements),
            "PromptGT-Relations" | "PromptGT-Existence" | "Object Relations - Spatial" | "Object Relations - Functional" => Some(QuestionGroup::Relations),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_unknown_names_list_the_choices() {
        for lighting in Lighting::ALL {
            assert_eq!(lighting.name().parse::<Lighting>(), Ok(lighting));
            assert_eq!(serde_json::to_string(&lighting).unwrap(), format!("\"{}\"", lighting.name()));
        }
        assert_eq!(
            "sunset".parse::<Lighting>().unwrap_err(),
            "unknown lighting 'sunset' (expected one of baseline, camera, camera_lights, dynamic_lights, no_lights, velocity)"
        );
        assert_eq!("furniture".parse::<Regime>(), Ok(Regime::Furniture));
    }

    #[test]
    fn a_release_lighting_is_the_score_axis_lighting_of_its_name() {
        for lighting in ReleaseLighting::ALL {
            assert_eq!(lighting.name(), Lighting::from(lighting).name());
            assert_eq!(lighting.label(), lighting.lighting().label());
            assert_eq!(lighting.lighting().in_release(), Some(lighting));
        }
        assert_eq!(Lighting::RELEASE.map(Lighting::name), ReleaseLighting::ALL.map(ReleaseLighting::name));
        assert_eq!(Lighting::ALL.iter().filter(|l| l.in_release().is_some()).count(), ReleaseLighting::ALL.len());
        assert_eq!(
            "velocity".parse::<ReleaseLighting>().unwrap_err(),
            "unknown lighting 'velocity' (expected one of baseline, camera, dynamic_lights, no_lights)"
        );
    }

    #[test]
    fn variants_sort_as_their_names_do() {
        fn sorted<T: Copy + Ord>(all: &[T], name: fn(T) -> &'static str) {
            let mut by_value = all.to_vec();
            by_value.sort();
            let mut by_name = all.to_vec();
            by_name.sort_by_key(|v| name(*v));
            assert!(by_value.iter().zip(&by_name).all(|(a, b)| name(*a) == name(*b)));
        }
        sorted(&Metric::ALL, Metric::name);
        sorted(&Aggregate::ALL, Aggregate::name);
        sorted(&Lighting::ALL, Lighting::name);
        sorted(&ReleaseLighting::ALL, ReleaseLighting::name);
        sorted(&Regime::ALL, Regime::name);
        sorted(&QuestionSet::ALL, QuestionSet::name);
        sorted(&QuestionGroup::ALL, QuestionGroup::name);
    }
}
