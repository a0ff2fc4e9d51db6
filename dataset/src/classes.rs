//! The release's class table (`dataset/classes.toml`): every class a scene can hold with its
//! id, names, role, plausible size, where it rests, the finishes its instances are drawn in
//! and how the asset forge makes it. The lexicon, the prompt filters' object hints, the
//! procedural library's sizes, the synthesizer's finishes and the dressing all read it, and
//! so does the forge (`tools/forge/recipes.py`): adding a class is one entry there.

use std::collections::BTreeMap;
use std::sync::LazyLock;

use serde::Deserialize;

/// The table as the repository ships it.
const TABLE_TOML: &str = include_str!("../classes.toml");

static TABLE: LazyLock<ClassTable> = LazyLock::new(|| ClassTable::parse(TABLE_TOML).unwrap_or_else(|e| panic!("dataset/classes.toml: {e}")));

/// The class table the pipeline uses.
pub fn table() -> &'static ClassTable {
    &TABLE
}

/// What a class is to a scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// The room and its fixtures: never a target of the trajectory or asked about.
    Shell,
    /// Stands on the floor; furniture prompts name these.
    Furniture,
    /// A small thing on, in or under furniture; manipuland prompts name these.
    Object,
}

/// Where an instance of a class stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Rests {
    Floor,
    Surface,
    Wall,
    Ceiling,
}

/// What a finish is made of: how much of a texture's own pattern a recoloured texel keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MaterialKind {
    Wood,
    Lacquer,
    Paint,
    Fabric,
    Leather,
    Metal,
    Plastic,
    Ceramic,
    Glass,
    Paper,
}

impl MaterialKind {
    /// The share of a texel's brightness that follows the texture's own pattern (grain,
    /// weave, print) when it is recoloured in a finish of this material.
    pub fn pattern(self) -> f32 {
        match self {
            MaterialKind::Wood => 0.7,
            MaterialKind::Fabric | MaterialKind::Leather | MaterialKind::Paper => 0.5,
            MaterialKind::Metal | MaterialKind::Ceramic | MaterialKind::Glass => 0.35,
            MaterialKind::Lacquer | MaterialKind::Paint | MaterialKind::Plastic => 0.25,
        }
    }
}

/// A finish an instance can be drawn in.
#[derive(Debug, Clone, PartialEq)]
pub struct Finish {
    pub name: String,
    /// sRGB albedo, 0–1.
    pub colour: [f32; 3],
    pub material: MaterialKind,
}

impl Finish {
    /// The colour name the questions give this finish's albedo.
    pub fn colour_name(&self) -> Option<&'static str> {
        crate::colour::colour_name(self.colour.map(|c| c as f64 * 255.0))
    }
}

/// A tone a picture's print is drawn in (the table's `[print]`): its brightness mapped from
/// `ink` to `paper`, plus `chroma` of its own colour.
#[derive(Debug, Clone, PartialEq)]
pub struct PrintTone {
    pub name: String,
    /// sRGB, 0–1: what the print's black becomes.
    pub ink: [f32; 3],
    /// sRGB, 0–1: what the print's white becomes.
    pub paper: [f32; 3],
    /// The share of a texel's own colour (its difference from its grey) that stays, 0–1.
    pub chroma: f32,
}

/// How a class's instances are coloured.
#[derive(Debug, Clone, PartialEq)]
pub enum Colouring {
    /// They keep their texture's colours (a screen, leaves, a clock's face); no colour is asked.
    Own,
    /// Their own print toned in one of the table's print tones (a picture); no colour is asked.
    Print,
    /// Their own cover art toned in one of the table's cover tones (a book); no colour is asked.
    Cover,
    /// Drawn in one of these finishes (names in the table's `[finish]`).
    Drawn(Vec<String>),
}

/// One recipe of the asset forge (read by `tools/forge/recipes.py`; kept here so the table
/// is checked whole).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForgeRecipe {
    /// `module.Factory` of `infinigen.assets.objects`.
    #[serde(default)]
    pub factory: Option<String>,
    /// A builder of `tools/forge/composed.py`.
    #[serde(default)]
    pub composed: Option<String>,
    /// Where the factory's front faces (`+x` unless said).
    #[serde(default)]
    pub front: Option<String>,
    /// Whether the factory takes its dimensions from the class's size range.
    #[serde(default)]
    pub sized: bool,
    #[serde(default)]
    pub options: BTreeMap<String, toml::Value>,
}

/// A class of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct ClassDef {
    pub name: String,
    /// Its position in the table: the id in `classes.json` and semantic frames.
    pub id: i64,
    pub synonyms: Vec<String>,
    pub role: Role,
    /// More words that count as naming it in a prompt.
    pub hints: Vec<String>,
    /// Plausible width, depth, height ranges (metres).
    pub size: Option<[[f64; 2]; 3]>,
    pub rests: Option<Rests>,
    pub colouring: Colouring,
    pub forge: Vec<ForgeRecipe>,
    /// Deliberately drawn by the procedural library.
    pub procedural: bool,
    /// Its pack texture's print is dropped: the whole main material takes the finish.
    pub plain: bool,
}

impl ClassDef {
    /// The finishes its instances are drawn in (none for own colours).
    pub fn finishes(&self) -> Vec<&'static Finish> {
        match &self.colouring {
            Colouring::Own | Colouring::Print | Colouring::Cover => Vec::new(),
            Colouring::Drawn(names) => names.iter().map(|n| table().finish(n).expect("checked when the table was read")).collect(),
        }
    }

    /// The distinct colour names of its finishes, in the order they first appear.
    pub fn colour_names(&self) -> Vec<&'static str> {
        let mut names: Vec<&'static str> = Vec::new();
        for f in self.finishes() {
            if let Some(n) = f.colour_name().filter(|n| !names.contains(n)) {
                names.push(n);
            }
        }
        names
    }
}

/// The whole table.
#[derive(Debug, Clone)]
pub struct ClassTable {
    classes: Vec<ClassDef>,
    finishes: BTreeMap<String, Finish>,
    print_tones: Vec<PrintTone>,
    cover_tones: Vec<PrintTone>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTable {
    finish: BTreeMap<String, RawFinish>,
    #[serde(default)]
    print: BTreeMap<String, RawPrintTone>,
    #[serde(default)]
    cover: BTreeMap<String, RawPrintTone>,
    #[serde(default)]
    palette: BTreeMap<String, Vec<String>>,
    class: Vec<RawClass>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFinish {
    colour: [f32; 3],
    material: MaterialKind,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPrintTone {
    ink: [f32; 3],
    paper: [f32; 3],
    chroma: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawClass {
    name: String,
    #[serde(default)]
    synonyms: Vec<String>,
    role: Role,
    #[serde(default)]
    hint: Vec<String>,
    #[serde(default)]
    size: Option<[[f64; 2]; 3]>,
    #[serde(default)]
    rests: Option<Rests>,
    #[serde(default)]
    finishes: Option<RawFinishes>,
    #[serde(default)]
    forge: Vec<ForgeRecipe>,
    #[serde(default)]
    procedural: bool,
    #[serde(default)]
    plain: bool,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum RawFinishes {
    /// `"own"`, `"print"` or `"@palette"`.
    Word(String),
    List(Vec<String>),
}

impl ClassTable {
    /// Read and check a table: every finish named exists, every name is unique, sizes are
    /// ranges, non-shell classes have a size, a place to rest and a colouring, recipes name
    /// a factory or a composed builder.
    pub fn parse(text: &str) -> Result<ClassTable, String> {
        let raw: RawTable = toml::from_str(text).map_err(|e| e.to_string())?;
        let finishes: BTreeMap<String, Finish> = raw
            .finish
            .into_iter()
            .map(|(name, f)| {
                if f.colour.iter().any(|c| !(0.0..=1.0).contains(c)) {
                    return Err(format!("finish.{name}.colour: expected three values in [0, 1]"));
                }
                Ok((name.clone(), Finish { name, colour: f.colour, material: f.material }))
            })
            .collect::<Result<_, String>>()?;
        let print_tones = tones_of("print", raw.print)?;
        let cover_tones = tones_of("cover", raw.cover)?;
        let mut classes = Vec::with_capacity(raw.class.len());
        let mut names: Vec<String> = Vec::new();
        for (id, c) in raw.class.into_iter().enumerate() {
            let field = |f: &str| format!("class[{id}] ({}).{f}", c.name);
            for n in std::iter::once(&c.name).chain(&c.synonyms) {
                if names.contains(n) {
                    return Err(format!("{}: '{n}' names two classes", field("synonyms")));
                }
                names.push(n.clone());
            }
            let colouring = colouring_of(c.finishes, &field("finishes"), (&print_tones, &cover_tones), &raw.palette, &finishes)?;
            if let Some(size) = c.size {
                if size.iter().any(|[lo, hi]| !(lo.is_finite() && hi.is_finite() && *lo > 0.0 && lo <= hi)) {
                    return Err(format!("{}: expected [min, max] ranges of positive metres", field("size")));
                }
            }
            if c.role != Role::Shell && (c.size.is_none() || c.rests.is_none()) {
                return Err(format!("{}: a furniture or object class needs a size and where it rests", field("size")));
            }
            if c.plain && !matches!(colouring, Colouring::Drawn(_)) {
                return Err(format!("{}: a plain class is drawn in finishes (a list or \"@palette\")", field("plain")));
            }
            if let Some(r) = c.forge.iter().find(|r| r.factory.is_some() == r.composed.is_some()) {
                return Err(format!("{}: a recipe names a factory or a composed builder, not {r:?}", field("forge")));
            }
            classes.push(ClassDef {
                name: c.name,
                id: id as i64,
                synonyms: c.synonyms,
                role: c.role,
                hints: c.hint,
                size: c.size,
                rests: c.rests,
                colouring,
                forge: c.forge,
                procedural: c.procedural,
                plain: c.plain,
            });
        }
        if classes.first().is_none_or(|c| c.name != "other") {
            return Err("class[0]: expected \"other\" (id 0 is excluded from scoring)".into());
        }
        Ok(ClassTable { classes, finishes, print_tones, cover_tones })
    }

    /// Every class, in id order.
    pub fn classes(&self) -> &[ClassDef] {
        &self.classes
    }

    /// The class named `name` (its canonical name).
    pub fn class(&self, name: &str) -> Option<&ClassDef> {
        self.classes.iter().find(|c| c.name == name)
    }

    pub fn finish(&self, name: &str) -> Option<&Finish> {
        self.finishes.get(name)
    }

    /// The tones a picture's print is drawn in, in name order.
    pub fn print_tones(&self) -> &[PrintTone] {
        &self.print_tones
    }

    /// The tones a book's cover art is drawn in, in name order.
    pub fn cover_tones(&self) -> &[PrintTone] {
        &self.cover_tones
    }

    /// Whether `name` is a class of the room's shell (or "other").
    pub fn is_shell(&self, name: &str) -> bool {
        self.class(name).is_some_and(|c| c.role == Role::Shell)
    }

    /// The words that name a class of `role` in a prompt: names, synonyms and hints.
    pub fn prompt_words(&self, role: Role) -> Vec<&str> {
        self.classes.iter().filter(|c| c.role == role).flat_map(|c| std::iter::once(&c.name).chain(&c.synonyms).chain(&c.hints)).map(String::as_str).collect()
    }
}

/// A class's `finishes` (`field`, for messages), read and checked against the table's print
/// and cover `tones`, its `palettes` and its `finishes`.
fn colouring_of(
    raw: Option<RawFinishes>,
    field: &str,
    tones: (&[PrintTone], &[PrintTone]),
    palettes: &BTreeMap<String, Vec<String>>,
    finishes: &BTreeMap<String, Finish>,
) -> Result<Colouring, String> {
    let (print, cover) = tones;
    let colouring = match raw {
        None => Colouring::Own,
        Some(RawFinishes::Word(w)) if w == "own" => Colouring::Own,
        Some(RawFinishes::Word(w)) if w == "print" && print.is_empty() => return Err(format!("{field}: \"print\" needs at least one [print] tone")),
        Some(RawFinishes::Word(w)) if w == "print" => Colouring::Print,
        Some(RawFinishes::Word(w)) if w == "cover" && cover.is_empty() => return Err(format!("{field}: \"cover\" needs at least one [cover] tone")),
        Some(RawFinishes::Word(w)) if w == "cover" => Colouring::Cover,
        Some(RawFinishes::Word(w)) => {
            let palette = w
                .strip_prefix('@')
                .and_then(|p| palettes.get(p))
                .ok_or_else(|| format!("{field}: expected \"own\", \"print\", \"cover\", \"@palette\" or a list, found '{w}'"))?;
            Colouring::Drawn(palette.clone())
        }
        Some(RawFinishes::List(list)) => Colouring::Drawn(list),
    };
    if let Colouring::Drawn(list) = &colouring {
        if list.is_empty() {
            return Err(format!("{field}: no finish"));
        }
        if let Some(missing) = list.iter().find(|f| !finishes.contains_key(*f)) {
            return Err(format!("{field}: no finish '{missing}'"));
        }
    }
    Ok(colouring)
}

/// The table's `[print]` or `[cover]` tones (`section`), checked: colours in [0, 1] and a
/// chroma share in [0, 1].
fn tones_of(section: &str, raw: BTreeMap<String, RawPrintTone>) -> Result<Vec<PrintTone>, String> {
    raw.into_iter()
        .map(|(name, t)| {
            if t.ink.iter().chain(&t.paper).any(|c| !(0.0..=1.0).contains(c)) {
                return Err(format!("{section}.{name}: expected ink and paper as three values in [0, 1]"));
            }
            if !(0.0..=1.0).contains(&t.chroma) {
                return Err(format!("{section}.{name}.chroma: expected a share in [0, 1], found {}", t.chroma));
            }
            Ok(PrintTone { name, ink: t.ink, paper: t.paper, chroma: t.chroma })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_table_reads_with_other_first_and_every_class_placed() {
        let t = table();
        assert_eq!(t.classes()[0].name, "other");
        assert_eq!(t.class("sofa").map(|c| c.role), Some(Role::Furniture));
        assert!(t.is_shell("floor") && t.is_shell("window") && t.is_shell("other") && !t.is_shell("rug"));
        for c in t.classes().iter().filter(|c| c.role != Role::Shell) {
            assert!(c.size.is_some() && c.rests.is_some(), "{}", c.name);
        }
    }

    #[test]
    fn every_drawn_class_asked_about_offers_at_least_four_colour_names() {
        // A shell class's finishes paint the room; its colour is never asked.
        for c in table().classes().iter().filter(|c| c.role != Role::Shell && matches!(c.colouring, Colouring::Drawn(_))) {
            let names = c.colour_names();
            assert!(names.len() >= 4, "{}: {names:?}", c.name);
        }
    }

    #[test]
    fn every_finish_is_muted_and_named_clearly_within_eight_percent_of_its_brightness() {
        for (name, f) in &table().finishes {
            let [r, g, b] = f.colour;
            let (max, min) = (r.max(g).max(b), r.min(g).min(b));
            let saturation = if max > 0.0 { (max - min) / max } else { 0.0 };
            assert!(saturation <= 0.46, "{name}: saturation {saturation:.2} (real rooms are muted)");
            let own = f.colour_name();
            assert!(own.is_some(), "{name}: its colour has no clear name");
            for gain in [0.92, 1.08] {
                let albedo = f.colour.map(|c| (c as f64 * gain * 255.0).min(255.0));
                assert_eq!(crate::colour::colour_name(albedo), own, "{name} at {gain}× its brightness");
            }
        }
    }

    #[test]
    fn pictures_are_toned_as_prints_whose_ink_and_paper_are_muted() {
        assert_eq!(table().class("picture").map(|c| &c.colouring), Some(&Colouring::Print));
        assert!(table().print_tones().len() >= 4, "a print's tone should say little of the room");
        for t in table().print_tones() {
            for (end, [r, g, b]) in [("ink", t.ink), ("paper", t.paper)] {
                let (max, min) = (r.max(g).max(b), r.min(g).min(b));
                assert!((max - min) / max <= 0.46, "{}: its {end} is saturated", t.name);
            }
            assert!(t.paper.iter().zip(&t.ink).all(|(p, i)| p > i), "{}: paper lighter than ink", t.name);
        }
    }

    #[test]
    fn books_are_toned_in_cover_tones_of_dark_cloth_and_light_card() {
        assert_eq!(table().class("book").map(|c| &c.colouring), Some(&Colouring::Cover));
        let brightness = |c: [f32; 3]| (c[0] + c[1] + c[2]) / 3.0;
        let (cloth, card): (Vec<&PrintTone>, Vec<&PrintTone>) = table().cover_tones().iter().partition(|t| brightness(t.paper) < brightness(t.ink));
        assert!(cloth.len() >= 3 && card.len() >= 2, "books dark and light: {cloth:?} {card:?}");
        let base = "[finish]\nwhite = { colour = [0.9, 0.9, 0.9], material = \"paint\" }\n";
        let classes = "[[class]]\nname = \"other\"\nrole = \"shell\"\n[[class]]\nname = \"book\"\nrole = \"object\"\nsize = [[0.15, 0.24], [0.2, 0.3], [0.02, 0.06]]\nrests = \"surface\"\nfinishes = \"cover\"\n";
        let e = ClassTable::parse(&format!("{base}{classes}")).unwrap_err();
        assert!(e.contains("(book).finishes") && e.contains("[cover]"), "{e}");
        let bright = format!("{base}[cover]\nnavy = {{ ink = [0.8, 0.7, 0.5], paper = [0.1, 0.1, 1.3], chroma = 0.0 }}\n{classes}");
        assert!(ClassTable::parse(&bright).unwrap_err().contains("cover.navy"));
        let fine = format!("{base}[cover]\nnavy = {{ ink = [0.8, 0.7, 0.5], paper = [0.1, 0.1, 0.3], chroma = 0.0 }}\n{classes}");
        assert_eq!(ClassTable::parse(&fine).map(|t| (t.cover_tones().len(), t.print_tones().len())), Ok((1, 0)));
    }

    #[test]
    fn boxes_drop_their_print_and_only_a_class_drawn_in_finishes_can() {
        assert!(table().class("box").is_some_and(|c| c.plain && matches!(c.colouring, Colouring::Drawn(_))));
        assert!(table().class("sofa").is_some_and(|c| !c.plain), "fabrics keep their weave");
        let base = "[finish]\nwhite = { colour = [0.9, 0.9, 0.9], material = \"paint\" }\n";
        let class = |finishes: &str| {
            format!(
                "{base}[[class]]\nname = \"other\"\nrole = \"shell\"\n[[class]]\nname = \"box\"\nrole = \"object\"\nsize = [[0.2, 0.4], [0.2, 0.4], [0.1, 0.3]]\nrests = \"surface\"\n{finishes}plain = true\n"
            )
        };
        assert!(ClassTable::parse(&class("finishes = [\"white\"]\n")).is_ok_and(|t| t.class("box").is_some_and(|c| c.plain)));
        let e = ClassTable::parse(&class("finishes = \"own\"\n")).unwrap_err();
        assert!(e.contains("(box).plain") && e.contains("finishes"), "{e}");
    }

    #[test]
    fn a_print_tone_out_of_range_or_a_print_class_without_tones_is_refused_by_name() {
        let base = "[finish]\nwhite = { colour = [0.9, 0.9, 0.9], material = \"paint\" }\n";
        let classes = "[[class]]\nname = \"other\"\nrole = \"shell\"\n[[class]]\nname = \"picture\"\nrole = \"object\"\nsize = [[0.4, 1.2], [0.02, 0.06], [0.3, 0.9]]\nrests = \"wall\"\nfinishes = \"print\"\n";
        let e = ClassTable::parse(&format!("{base}{classes}")).unwrap_err();
        assert!(e.contains("(picture).finishes") && e.contains("[print]"), "{e}");
        let bright = format!("{base}[print]\nsepia = {{ ink = [0.1, 0.1, 0.1], paper = [0.9, 0.8, 1.5], chroma = 0.0 }}\n{classes}");
        assert!(ClassTable::parse(&bright).unwrap_err().contains("print.sepia"));
        let chroma = format!("{base}[print]\nsepia = {{ ink = [0.1, 0.1, 0.1], paper = [0.9, 0.8, 0.7], chroma = 2.0 }}\n{classes}");
        assert!(ClassTable::parse(&chroma).unwrap_err().contains("print.sepia.chroma"));
        let fine = format!("{base}[print]\nsepia = {{ ink = [0.1, 0.1, 0.1], paper = [0.9, 0.8, 0.7], chroma = 0.0 }}\n{classes}");
        assert_eq!(ClassTable::parse(&fine).map(|t| t.print_tones().len()), Ok(1));
    }

    #[test]
    fn a_table_with_an_unknown_finish_or_a_reused_name_is_refused_naming_the_class() {
        let base = "[finish]\nwhite = { colour = [0.9, 0.9, 0.9], material = \"paint\" }\n[[class]]\nname = \"other\"\nrole = \"shell\"\n";
        let unknown = format!(
            "{base}[[class]]\nname = \"vase\"\nrole = \"object\"\nsize = [[0.1, 0.2], [0.1, 0.2], [0.2, 0.4]]\nrests = \"surface\"\nfinishes = [\"gold\"]\n"
        );
        let e = ClassTable::parse(&unknown).unwrap_err();
        assert!(e.contains("(vase).finishes") && e.contains("gold"), "{e}");
        let twice = format!("{base}[[class]]\nname = \"floor\"\nsynonyms = [\"other\"]\nrole = \"shell\"\n");
        assert!(ClassTable::parse(&twice).unwrap_err().contains("'other' names two classes"));
        let no_size = format!("{base}[[class]]\nname = \"vase\"\nrole = \"object\"\n");
        assert!(ClassTable::parse(&no_size).unwrap_err().contains("needs a size"));
    }
}
