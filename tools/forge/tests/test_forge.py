"""forge.py, the command line: the loop over classes, variants and seeds with a stand-in for
the steps in Blender, the catalogue it writes, and its exit status."""

import hashlib
import json
import logging
import sys

import pytest

import forge
import recipes
from catalogue import Measured
from recipes import ComposedRecipe, FactoryRecipe, ForgeClass
from sizing import UnusableMesh

GENERATOR = "infinigen 1.15.5, bpy 4.2.0: "
CHAIR = ForgeClass("chair", "furniture", "floor", ((0.4, 0.55), (0.42, 0.6), (0.8, 1.0)), (FactoryRecipe("seating", "ChairFactory"), ComposedRecipe("bench")))
MUG = ForgeClass("coffee mug", "object", "surface", ((0.07, 0.1), (0.07, 0.1), (0.08, 0.12)), (FactoryRecipe("tableware", "CupFactory"),))


class FakeSteps:
    """The Blender steps' stand-in: a GLB of fake bytes for every seed not in `unusable`."""

    def __init__(self, unusable=(), bug_at=None):
        self.unusable, self.bug_at, self.calls = set(unusable), bug_at, []
        self.builders = {"bench"}
        self.occlusion, self.shells, self.sheets = [], [], []

    def forge_variant(self, kind, recipe, seed, path, shots):
        self.calls.append((kind.name, recipe, seed, path.name, shots))
        if seed == self.bug_at:
            raise KeyError("a recipe bug")
        if seed in self.unusable or kind.name in self.unusable:
            raise UnusableMesh(f"does not fit {kind.size_range}")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(f"{kind.name} {seed}".encode())
        return Measured(size=[0.5, 0.5, 0.9], scale=1.0, triangles=100 + seed % 1000, supports=[], under=None)

    def occlusion_pass(self, out, classes, dump):
        self.occlusion.append(classes)

    def forge_shell(self, out):
        self.shells.append(out)

    def write_sheets(self, out, sheets, classes):
        self.sheets.append(classes)


def test_class_seeds():
    assert forge.class_seed("chair", 0, 0) == 78901000
    assert forge.class_seed("chair", 2, 5) == 78903005
    assert forge.class_seed("bed", 0, 1) == 50301001  # the bed of the README's determinism notes
    assert forge.class_seed("dining chair", 0, 0) != forge.class_seed("chair", 0, 0)


def test_the_catalogue_the_loop_writes(tmp_path):
    steps = FakeSteps(unusable={forge.class_seed("chair", 1, 0), forge.class_seed("chair", 1, 1)})
    # An earlier catalogue: the mug's entries are replaced, the sofa's and the shells stay.
    (tmp_path / "catalogue.json").write_text(json.dumps({"format": "osmab-assets/1", "objects": [{"class": "coffee mug", "variant": 5}, {"class": "sofa", "variant": 0}], "shells": [{"name": "wall-paint"}]}))
    failed = forge.forge_classes([CHAIR, MUG], 3, tmp_path, steps.forge_variant, sheets=tmp_path / "sheets")
    assert failed == []
    written = (tmp_path / "catalogue.json").read_text()
    pack = json.loads(written)
    assert written == json.dumps(pack, indent=1) + "\n"
    assert pack["shells"] == [{"name": "wall-paint"}]
    assert [(e["class"], e["variant"], e.get("seed")) for e in pack["objects"]] == [
        ("chair", 0, 78901000),
        ("chair", 1, 78902002),  # its first two seeds gave no usable mesh
        ("chair", 2, 78903000),
        ("coffee mug", 0, forge.class_seed("coffee mug", 0, 0)),
        ("coffee mug", 1, forge.class_seed("coffee mug", 1, 0)),
        ("coffee mug", 2, forge.class_seed("coffee mug", 2, 0)),
        ("sofa", 0, None),
    ]
    assert pack["objects"][-1] == {"class": "sofa", "variant": 0}
    chair1 = pack["objects"][1]
    assert chair1 == {
        "class": "chair",
        "variant": 1,
        "source": "composed (infinigen materials)",
        "generator": GENERATOR + "tools/forge/composed.py",
        "seed": 78902002,
        "size": [0.5, 0.5, 0.9],
        "scale": 1.0,
        "triangles": 102,
        "supports": [],
        "under": None,
        "path": "meshes/chair-1.glb",
        "sha256": hashlib.sha256(b"chair 78902002").hexdigest(),
        "license": "BSD-3-Clause (Infinigen, Princeton University)",
    }
    assert pack["objects"][3]["path"] == "meshes/coffee-mug-0.glb" and pack["objects"][3]["generator"] == GENERATOR + "tableware.CupFactory"
    # Variant i uses recipe i mod their number; pictures go to the variant's shots folder.
    assert [c[1] for c in steps.calls[:5]] == [CHAIR.recipes[0], CHAIR.recipes[1], CHAIR.recipes[1], CHAIR.recipes[1], CHAIR.recipes[0]]
    assert steps.calls[0][4] == tmp_path / "sheets" / "shots" / "chair-0"
    assert len(steps.calls) == 3 + 2 + 3


def test_a_class_that_yields_nothing(tmp_path, caplog):
    steps = FakeSteps(unusable={"chair"})
    (tmp_path / "catalogue.json").write_text(json.dumps({"format": "osmab-assets/1", "objects": [{"class": "chair", "variant": 0}], "shells": []}))
    with caplog.at_level(logging.INFO, logger="forge"):
        failed = forge.forge_classes([CHAIR, MUG], 2, tmp_path, steps.forge_variant)
    assert failed == ["chair"]
    assert len([c for c in steps.calls if c[0] == "chair"]) == 2 * forge.SEEDS_PER_VARIANT
    pack = json.loads((tmp_path / "catalogue.json").read_text())
    assert [(e["class"], e["variant"]) for e in pack["objects"]] == [("coffee mug", 0), ("coffee mug", 1)]
    assert "chair: no variant could be made" in caplog.text
    assert "chair variant 0 seed 78901005: does not fit" in caplog.text


def test_a_class_that_yields_nothing_ends_the_forge_with_status_1(tmp_path, caplog):
    steps = FakeSteps(unusable={"coffee table"})
    with caplog.at_level(logging.INFO, logger="forge"):
        status = forge.main(["--out", str(tmp_path), "--classes", "chair,coffee table", "--variants", "1"], steps=steps)
    assert status == 1
    assert "forge: no variant of coffee table (6 seeds tried a variant)" in caplog.text
    # Everything else is still done: the chair's variant, the occlusion, the shells.
    assert [e["class"] for e in json.loads((tmp_path / "catalogue.json").read_text())["objects"]] == ["chair"]
    assert steps.occlusion == [{"chair", "coffee table"}] and steps.shells == [tmp_path] and steps.sheets == []


def test_the_forge_succeeds(tmp_path):
    steps = FakeSteps()
    assert forge.main(["--out", str(tmp_path), "--classes", "chair", "--variants", "2", "--no-shell", "--no-occlusion", "--sheets", str(tmp_path / "s")], steps=steps) == 0
    assert steps.occlusion == [] and steps.shells == [] and steps.sheets == [["chair"]]
    assert forge.main(["--out", str(tmp_path), "--occlusion", "--classes", "chair"], steps=steps) == 0
    assert steps.occlusion == [{"chair"}] and len(steps.calls) == 2  # --occlusion forges nothing


def test_a_bug_is_not_another_seed(tmp_path):
    steps = FakeSteps(bug_at=forge.class_seed("chair", 0, 0))
    with pytest.raises(KeyError, match="a recipe bug") as caught:
        forge.forge_classes([CHAIR], 3, tmp_path, steps.forge_variant)
    assert len(steps.calls) == 1  # no second seed
    assert caught.value.__notes__ == ["forging chair variant 0 (seating.ChairFactory) with seed 78901000"]
    assert not (tmp_path / "catalogue.json").exists()


def test_the_command_line_refuses(tmp_path, capsys):
    steps = FakeSteps()
    with pytest.raises(SystemExit) as caught:
        forge.main(["--out", str(tmp_path), "--classes", "chair,unicorn"], steps=steps)
    assert caught.value.code == 2 and "no forge recipe for unicorn" in capsys.readouterr().err
    steps.builders = set()  # composed.py without the bench builder
    with pytest.raises(SystemExit):
        forge.main(["--out", str(tmp_path), "--classes", "bench"], steps=steps)
    assert "composed.py has no builder bench" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        forge.main(["--out", str(tmp_path), "--variants", "0"], steps=steps)
    assert steps.calls == []


def test_every_composed_builder_of_the_table_is_a_name():
    builders = {r.builder for kind in recipes.RECIPES.values() for r in kind.recipes if isinstance(r, ComposedRecipe)}
    assert builders == {"bench", "laptop", "backpack", "suitcase", "helmet", "clock", "printer", "bucket"}


def test_the_command_line_loads_no_blender_until_it_forges():
    """forge.py, recipes.py, catalogue.py and sizing.py import without Blender (not installed
    here); the steps in Blender are imported by blender_steps() alone."""
    assert "bpy" not in sys.modules and "variant" not in sys.modules
    args = forge.arguments().parse_args(["--out", "x"])
    assert (args.variants, args.classes, args.no_shell) == (recipes.VARIANTS, None, False)
