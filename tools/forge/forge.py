"""The asset forge: every class of the release's lexicon as real-looking, textured meshes.

For each class of the class table (dataset/classes.toml, read by recipes.py) it spawns
seeded variants from Infinigen's factories (or composes simple parts dressed in Infinigen's
materials where Infinigen has no factory), keeps those that fit the class's plausible size
(scaling uniformly into it, or a thin axis on its own), turns each to the
SceneSmith object frame (up +z, front +y, bottom at z = 0, centred), decimates it to its
triangle budget, bakes its procedural materials to one base-colour texture (every shader's
base colour as emission, so metals and coatings keep their colour), measures the surfaces
other objects can rest on, and writes a GLB with an embedded JPEG. Room shells (floors and
walls) are baked as tileable textures. `assets/catalogue.json` lists everything, with the
SHA-256 of every file. `--sheets` also renders, per class, each variant's original
(Cycles, procedural materials) beside its baked GLB, from the front and from three quarters.
`--occlusion` bakes ambient occlusion into the pack's GLBs (their glTF occlusionTexture)
without forging them again; forging ends with it for the classes forged.

This module is the command line: its arguments, the loop over classes, variants and seeds,
and the catalogue it writes. The steps in Blender are variant.py, occlusion.py, shell.py and
sheets.py (with blender.py and composed.py); nothing imports this module. A class of which
no variant could be made ends the forge with exit status 1, once everything else is written.

Run with the forge's own Python (tools/forge/install.sh):

    tools/forge/.venv-forge/bin/python tools/forge/forge.py --out assets [--classes chair,sofa] [--sheets DIR]
"""

import argparse
import logging
import os
import sys
import time
import zlib
from pathlib import Path
from types import SimpleNamespace

# Infinigen's generated pictures (book covers, TV screens) depend on Python's string hashing:
# the forge always runs with it fixed, so the same seeds give byte-identical files.
if __name__ == "__main__" and os.environ.get("PYTHONHASHSEED") != "0":
    os.execve(sys.executable, [sys.executable, *sys.argv], {**os.environ, "PYTHONHASHSEED": "0"})

import catalogue  # noqa: E402
import recipes  # noqa: E402
from recipes import ComposedRecipe  # noqa: E402
from sizing import UnusableMesh  # noqa: E402

SEEDS_PER_VARIANT = 6  # seeds tried for a variant that fits

log = logging.getLogger("forge")


def class_seed(name, variant, attempt):
    """The factory seed of a class's variant: classes sharing a factory (chair, dining
    chair) get variants of their own."""
    return (zlib.crc32(name.encode()) % 1000) * 100_000 + 1000 * (variant + 1) + attempt


def forge_class(kind, variants, out, make, sheets=None):
    """The catalogue entries of `variants` variants of the class `kind` (recipes.ForgeClass),
    each from the first of SEEDS_PER_VARIANT seeds whose mesh can be used. `make(kind,
    recipe, seed, path, shots)` writes the GLB at `path` and returns its catalogue.Measured,
    or raises UnusableMesh (then the next seed is tried); any other exception is a bug and
    propagates, with a note naming the class, variant and seed."""
    entries = []
    for variant in range(variants):
        recipe = kind.recipe_for(variant)
        path = out / catalogue.mesh_path(kind.name, variant)
        shots = sheets / "shots" / f"{catalogue.slug(kind.name)}-{variant}" if sheets is not None else None
        for attempt in range(SEEDS_PER_VARIANT):
            seed = class_seed(kind.name, variant, attempt)
            clock = time.time()
            try:
                measured = make(kind, recipe, seed, path, shots)
            except UnusableMesh as unusable:
                log.info("%s variant %d seed %d: %s", kind.name, variant, seed, unusable)
                continue
            except Exception as bug:  # not another seed: said where, and raised again
                bug.add_note(f"forging {kind.name} variant {variant} ({recipe.describe()}) with seed {seed}")
                raise
            entries.append(catalogue.object_entry(kind.name, variant, recipe, seed, measured, out))
            log.info("%s variant %d: seed %d, %s, %d triangles, %.1f s", kind.name, variant, seed, measured.size, measured.triangles, time.time() - clock)
            break
        else:
            log.warning("%s variant %d: none of %d seeds gave a usable mesh", kind.name, variant, SEEDS_PER_VARIANT)
    return entries


def forge_classes(kinds, variants, out, make, sheets=None):
    """Forge every class of `kinds` (forge_class()), writing the catalogue in `out` after each
    (a class's entries replaced by what was made of it); the names of the classes of which no
    variant was made."""
    path = out / catalogue.FILE
    pack = catalogue.read(path)
    failed = []
    for kind in kinds:
        entries = forge_class(kind, variants, out, make, sheets)
        if not entries:
            log.error("%s: no variant could be made; the class keeps the synthesizer's procedural asset", kind.name)
            failed.append(kind.name)
        pack = catalogue.with_class(pack, kind.name, entries)
        catalogue.write(path, pack)
    return failed


def blender_steps():
    """The forge's steps in Blender (bpy, Infinigen, Pillow). Imported here, when the forge
    runs, not at the top: the tests import this module (its loop and the catalogue it
    writes) with a plain Python. No circle: none of these imports this module."""
    import blender  # noqa: F401, PLC0415 (first: bpy is loaded before numpy, as it always was)
    import composed  # noqa: PLC0415
    import occlusion  # noqa: PLC0415
    import sheets  # noqa: PLC0415
    import shell  # noqa: PLC0415
    import variant  # noqa: PLC0415

    return SimpleNamespace(
        builders=set(composed.BUILDERS),
        forge_variant=variant.forge_variant,
        occlusion_pass=occlusion.occlusion_pass,
        forge_shell=shell.forge_shell,
        write_sheets=sheets.write,
    )


def arguments():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="the asset pack folder (assets/)")
    parser.add_argument("--classes", help="comma-separated classes (default: every class of the recipes)")
    parser.add_argument("--variants", type=int, default=recipes.VARIANTS)
    parser.add_argument("--sheets", help="write a contact sheet per class here")
    parser.add_argument("--no-shell", action="store_true", help="skip the room-shell textures")
    parser.add_argument("--occlusion", action="store_true", help="only bake ambient occlusion into the pack's meshes (no forging)")
    parser.add_argument("--no-occlusion", action="store_true", help="forge without baking the occlusion of what was forged")
    parser.add_argument("--dump-occlusion", help="also write each occlusion image here as PNG")
    return parser


def main(argv=None, steps=None):
    """The forge's command line; its exit status (1 when a class got no variant). `steps`
    stands in for blender_steps() (the tests')."""
    parser = arguments()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    for noisy in ("infinigen", "bpy"):
        logging.getLogger(noisy).setLevel(logging.WARNING)
    wanted = args.classes.split(",") if args.classes else list(recipes.RECIPES)
    unknown = [name for name in wanted if name not in recipes.RECIPES]
    if unknown:
        parser.error(f"no forge recipe for {', '.join(unknown)} in {recipes.TABLE}")
    if args.variants < 1:
        parser.error("--variants must be at least 1")
    steps = steps or blender_steps()
    out = Path(args.out)
    dump = Path(args.dump_occlusion) if args.dump_occlusion else None
    started = time.time()
    if args.occlusion:
        steps.occlusion_pass(out, set(wanted) if args.classes else None, dump)
        log.info("occlusion baked in %.0f s", time.time() - started)
        return 0
    kinds = [recipes.RECIPES[name] for name in wanted]
    missing = sorted({r.builder for kind in kinds for r in kind.recipes if isinstance(r, ComposedRecipe)} - steps.builders)
    if missing:
        parser.error(f"composed.py has no builder {', '.join(missing)}")
    sheets = Path(args.sheets) if args.sheets else None
    failed = forge_classes(kinds, args.variants, out, steps.forge_variant, sheets)
    if not args.no_occlusion:
        steps.occlusion_pass(out, set(wanted), dump)
    if not args.no_shell:
        steps.forge_shell(out)
    if sheets is not None:
        steps.write_sheets(out, sheets, wanted)
    log.info("forged %s in %.0f s", ", ".join(wanted), time.time() - started)
    if failed:
        log.error("forge: no variant of %s (%d seeds tried a variant)", ", ".join(failed), SEEDS_PER_VARIANT)
        return 1
    return 0


if __name__ == "__main__":
    status = main()
    logging.shutdown()
    os._exit(status)  # bpy can crash while the interpreter tears it down; everything is written
