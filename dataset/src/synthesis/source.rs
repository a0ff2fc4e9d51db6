//! Where the built-in synthesizer takes each object from: a variant of an asset pack
//! ([`crate::assets`]: real-looking, textured meshes forged from Infinigen, or an operator's
//! own) when the pack has the class, else the procedural library ([`super::library`]).
//! Either way an instance gets a finish of its class's palette ([`super::finishes`]), so a
//! class says nothing of an instance's colour: a pack mesh's texture is recoloured in it when
//! the scene is written ([`super::textured`]), keeping its grain, weave and print.

use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The setting that names the folder a release config's relative asset pack path is read
/// under (the Docker image sets it to `/app`, where its `assets/` is).
pub const ASSETS_ROOT_VARIABLE: &str = "OSMAB_ASSETS_ROOT";

/// The folder a release config's relative asset pack path is read under: the setting
/// [`ASSETS_ROOT_VARIABLE`] when set, else the working folder.
pub fn assets_root() -> PathBuf {
    std::env::var_os(ASSETS_ROOT_VARIABLE).filter(|v| !v.is_empty()).map(PathBuf::from).unwrap_or_else(|| PathBuf::from("."))
}

use osmab_evaluator::Result;
use osmab_evaluator::synthetic::Rng;

use super::finishes::{Look, finish_drawn, look_drawn};
use super::library::{Asset, PackMesh, SupportSurface, make_asset};
use crate::assets::{AssetPack, ObjectEntry, ShellKind};
use crate::classes::Finish;

/// The largest uniform change of a pack variant's size, either way: the forge brought it
/// into its class's plausible range already; this only keeps two instances of one variant
/// from being twins.
const SIZE_JITTER: f64 = 0.06;

/// A room-shell texture: the image and the side of the square it covers.
#[derive(Debug, Clone, PartialEq)]
pub struct ShellTexture {
    pub name: String,
    pub file: PathBuf,
    pub tile: f64,
}

/// The floor and wall textures of one room, the paint its walls are drawn in and the dye
/// of its carpet.
#[derive(Debug, Clone, PartialEq)]
pub struct RoomShell {
    pub floor: ShellTexture,
    pub wall: ShellTexture,
    /// A finish of the wall class's palette (the class table); `None` keeps the wall
    /// texture's own colour.
    pub wall_paint: Option<&'static Finish>,
    /// For a carpeted floor, a finish of the floor class's palette; `None` keeps the floor
    /// texture's own colour (wood and tile, and the carpet without a palette).
    pub floor_dye: Option<&'static Finish>,
}

/// Whether a floor texture of the pack is a carpet, which is dyed (its shell's name says so:
/// the pack's carpet is a single flat colour, where wood and tile show their own).
fn is_carpet(floor: &ShellTexture) -> bool {
    floor.name.contains("carpet")
}

/// The synthesizer's asset source: the procedural library, or a pack in front of it.
#[derive(Debug, Clone, Default)]
pub struct AssetSource {
    pack: Option<Arc<AssetPack>>,
}

impl AssetSource {
    /// Only the procedural library.
    pub fn procedural() -> Self {
        Self::default()
    }

    /// The pack at `root` (opened and checked), with the procedural library for the
    /// classes it lacks.
    pub fn open(root: &Path) -> Result<Self> {
        Ok(Self { pack: Some(Arc::new(AssetPack::open(root)?)) })
    }

    /// The pack a release config names (`synthesis.assets`), else only the procedural
    /// library. A relative path is read under `root` ([`assets_root`]: the setting
    /// [`ASSETS_ROOT_VARIABLE`], else the working folder), never from where the program was
    /// built; the pack's digest, not its path, is what a build records.
    pub fn for_config(assets: Option<&str>, root: &Path) -> Result<Self> {
        let Some(assets) = assets else { return Ok(Self::procedural()) };
        let pack = root.join(assets);
        Self::open(&pack).map_err(|mut e| {
            if Path::new(assets).is_relative() {
                let root = std::path::absolute(root).unwrap_or_else(|_| root.to_path_buf());
                e.message.push_str(&format!(
                    " (the config's relative '{assets}' is read under {}: set {ASSETS_ROOT_VARIABLE} to the folder that holds it)",
                    root.display()
                ));
            }
            e
        })
    }

    /// The pack's digest, when there is a pack: a build input of every scene drawn from it.
    pub fn digest(&self) -> Option<&str> {
        self.pack.as_deref().map(AssetPack::digest)
    }

    /// The asset of `category` drawn from the state of `rng`: a pack variant when the pack
    /// has the class, else the procedural asset. Its finish is drawn without advancing
    /// `rng`, as the procedural library draws it.
    pub fn make(&self, category: &str, rng: &mut Rng) -> Option<Asset> {
        let variants: Vec<&ObjectEntry> = self.pack.as_deref().map(|p| p.catalogue().variants(category).collect()).unwrap_or_default();
        let Some(pack) = self.pack.as_deref().filter(|_| !variants.is_empty()) else {
            return make_asset(category, rng);
        };
        let look = look_drawn(category, rng);
        let entry = variants[rng.below(variants.len())];
        let scale = ((1.0 + rng.range(-SIZE_JITTER, SIZE_JITTER)) * 1000.0).round() / 1000.0;
        Some(pack_asset(pack, entry, scale, look))
    }

    /// The floor and wall textures of a room, its walls' paint and its carpet's dye, drawn
    /// from `seed`; `None` without a pack or when it has no floor or no wall texture.
    pub fn room_shell(&self, seed: u64) -> Option<RoomShell> {
        let pack = self.pack.as_deref()?;
        let mut rng = Rng::new(seed ^ 0x5BE1_1);
        let mut pick = |kind: ShellKind| {
            let shells: Vec<_> = pack.catalogue().shells_of(kind).collect();
            (!shells.is_empty()).then(|| {
                let s = shells[rng.below(shells.len())];
                ShellTexture { name: s.name.clone(), file: pack.path(&s.path), tile: s.tile }
            })
        };
        let (floor, wall) = (pick(ShellKind::Floor)?, pick(ShellKind::Wall)?);
        let wall_paint = finish_drawn("wall", &rng);
        rng.next_u64();
        let floor_dye = if is_carpet(&floor) { finish_drawn("floor", &rng) } else { None };
        Some(RoomShell { floor, wall, wall_paint, floor_dye })
    }
}

/// `entry` of `pack` as an asset at `scale`: its size, surfaces and free floor from the
/// catalogue, scaled.
fn pack_asset(pack: &AssetPack, entry: &ObjectEntry, scale: f64, look: Look) -> Asset {
    let s2 = |v: [f64; 2]| v.map(|x| x * scale);
    let supports = entry
        .supports
        .iter()
        .map(|s| SupportSurface {
            height: s.height * scale,
            min: s2(s.min),
            max: s2(s.max),
            inside: s.inside,
            open: s.open,
            clear_height: s.clear_height.map_or(f64::INFINITY, |c| c * scale),
        })
        .collect();
    let (clearance, under) = match &entry.under {
        Some(u) => (u.clearance * scale, Some((s2(u.min), s2(u.max)))),
        None => (0.0, None),
    };
    Asset {
        category: entry.class.clone(),
        parts: Vec::new(),
        size: entry.size.map(|v| v * scale),
        supports,
        clearance,
        under,
        description: format!("A {}{} ({} variant {}).", entry.class, look.described(), entry.source, entry.variant),
        mesh: Some(PackMesh { file: pack.path(&entry.path), scale, look, source: entry.source.clone(), generator: entry.generator.clone() }),
    }
}
