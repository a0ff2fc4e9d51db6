"""catalogue.py: the entries the forge writes into assets/catalogue.json, and how it writes it."""

import hashlib
import json
from pathlib import Path

import catalogue
from catalogue import Measured
from recipes import ComposedRecipe, FactoryRecipe, ShellTexture

ROOT = Path(__file__).resolve().parents[3]


def test_writing_the_committed_catalogue_gives_its_bytes(tmp_path):
    committed = ROOT / "assets" / "catalogue.json"
    pack = catalogue.read(committed)
    catalogue.write(tmp_path / "assets" / "catalogue.json", pack)
    assert (tmp_path / "assets" / "catalogue.json").read_bytes() == committed.read_bytes()


def test_an_empty_catalogue(tmp_path):
    assert catalogue.read(tmp_path / "none.json") == {"format": "osmab-assets/1", "objects": [], "shells": []}


def test_an_object_entry(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "dining-chair-1.glb").write_bytes(b"glTF fake")
    measured = Measured(size=[0.5, 0.52, 0.9], scale=1.02, triangles=9800, supports=[{"height": 0.45}], under=None)
    recipe = FactoryRecipe(module="shelves", factory="KitchenCabinetFactory", sized=True, options={"drawer_only": True})
    entry = catalogue.object_entry("dining chair", 1, recipe, 12345, measured, tmp_path)
    assert entry == {
        "class": "dining chair",
        "variant": 1,
        "source": "infinigen",
        "generator": "infinigen 1.15.5, bpy 4.2.0: shelves.KitchenCabinetFactory(drawer_only=True, sized=True)",
        "seed": 12345,
        "size": [0.5, 0.52, 0.9],
        "scale": 1.02,
        "triangles": 9800,
        "supports": [{"height": 0.45}],
        "under": None,
        "path": "meshes/dining-chair-1.glb",
        "sha256": hashlib.sha256(b"glTF fake").hexdigest(),
        "license": "BSD-3-Clause (Infinigen, Princeton University)",
    }
    # The committed pack's entries have the same keys in the same order.
    committed = catalogue.read(ROOT / "assets" / "catalogue.json")["objects"][0]
    assert list(entry) == list(committed)
    composed = catalogue.object_entry("dining chair", 1, ComposedRecipe("bench"), 1, measured, tmp_path)
    assert (composed["source"], composed["generator"]) == ("composed (infinigen materials)", "infinigen 1.15.5, bpy 4.2.0: tools/forge/composed.py")


def test_with_class_replaces_one_class_and_sorts():
    pack = {"format": "osmab-assets/1", "objects": [{"class": "sofa", "variant": 0}, {"class": "chair", "variant": 0}, {"class": "chair", "variant": 1}], "shells": [{"name": "wall-paint"}]}
    updated = catalogue.with_class(pack, "chair", [{"class": "chair", "variant": 2, "new": True}])
    assert updated["objects"] == [{"class": "chair", "variant": 2, "new": True}, {"class": "sofa", "variant": 0}]
    assert updated["shells"] == [{"name": "wall-paint"}] and updated["format"] == "osmab-assets/1"
    assert len(pack["objects"]) == 3  # the pack given is left as it was
    assert catalogue.with_class(pack, "bed", [{"class": "bed", "variant": 0}])["objects"][0] == {"class": "bed", "variant": 0}


def test_a_shell_entry(tmp_path):
    (tmp_path / "shell").mkdir()
    (tmp_path / "shell" / "floor-tile.jpg").write_bytes(b"jpeg")
    entry = catalogue.shell_entry(ShellTexture("floor-tile", "floor", "ceramic", "Tile", 2.0), 9, tmp_path)
    assert entry == {
        "name": "floor-tile",
        "kind": "floor",
        "source": "infinigen material",
        "generator": "infinigen 1.15.5, bpy 4.2.0: materials.ceramic.Tile",
        "seed": 9,
        "tile": 2.0,
        "path": "shell/floor-tile.jpg",
        "sha256": hashlib.sha256(b"jpeg").hexdigest(),
        "license": "BSD-3-Clause (Infinigen, Princeton University)",
    }
    committed = json.loads((ROOT / "assets" / "catalogue.json").read_text())["shells"]
    assert [list(e) for e in committed] == [list(entry)] * len(committed)
