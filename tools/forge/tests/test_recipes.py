"""recipes.py: the forge's classes and recipes read from dataset/classes.toml."""

import json
from pathlib import Path

import pytest

import recipes
from recipes import ClassTableError, ComposedRecipe, FactoryRecipe, ForgeClass, InvalidField, ShellTexture, parse

ROOT = Path(__file__).resolve().parents[3]
GENERATOR = "infinigen 1.15.5, bpy 4.2.0: "


def table(*classes):
    return {"class": [{"name": "other", "role": "shell"}, *classes]}


def chair(**changes):
    entry = {"name": "chair", "role": "furniture", "size": [[0.4, 0.55], [0.42, 0.6], [0.8, 1.0]], "forge": [{"factory": "seating.ChairFactory"}]}
    entry.update(changes)
    return entry


def test_the_table_gives_every_forged_class_in_order():
    forged = recipes.load()
    assert list(forged) == list(recipes.RECIPES)
    for name in ("chair", "bench", "dresser", "door", "window", "rug", "picture"):
        assert name in forged
    assert "curtain" not in forged  # in the table, without a recipe
    assert "other" not in forged


def test_recipes_are_named_records():
    forged = recipes.RECIPES
    dresser = forged["dresser"].recipes[0]
    assert dresser == FactoryRecipe(module="shelves", factory="KitchenCabinetFactory", sized=True, options={"drawer_only": True})
    assert dresser.sized and dict(dresser.options) == {"drawer_only": True} and dresser.front == "+x"
    door = forged["door"].recipes[0]
    assert (door.module, door.factory, door.front) == ("elements.doors", "DoorFactory", "+y")
    bench = forged["bench"].recipes[0]
    assert bench == ComposedRecipe(builder="bench") and bench.front == "+y" and not bench.stretch
    bucket = forged["bucket"].recipes
    assert [r.describe() for r in bucket] == ["tableware.PotFactory", "tools/forge/composed.py"]
    window = forged["window"].recipes[0]
    assert window.sized and dict(window.options) == {"curtain": False, "shutter": False, "open": False}
    assert forged["rug"].recipes[0].stretch and "stretch" not in forged["rug"].recipes[0].options


def test_budgets_follow_the_role():
    forged = recipes.RECIPES
    for name in ("door", "window", "sofa", "printer"):  # the room's fixtures and furniture
        assert forged[name].furniture and forged[name].triangles == 10_000 and forged[name].texture == 512
    for name in ("rug", "picture", "mug"):
        assert not forged[name].furniture and forged[name].triangles == 2_000 and forged[name].texture == 256
    assert forged["rug"].size_range == ((1.2, 2.4), (1.6, 3.0), (0.01, 0.02))
    assert forged["picture"].rests == "wall"


def test_describe_keeps_the_catalogue_generators():
    """Every catalogued variant's generator is what describe() gives for its recipe."""
    catalogue = json.loads((ROOT / "assets" / "catalogue.json").read_text())
    assert catalogue["objects"]
    for entry in catalogue["objects"]:
        kind = recipes.RECIPES[entry["class"]]
        recipe = kind.recipes[entry["variant"] % len(kind.recipes)]
        assert entry["generator"] == GENERATOR + recipe.describe(), entry["path"]
        assert entry["source"] == ("composed (infinigen materials)" if isinstance(recipe, ComposedRecipe) else "infinigen")
        assert entry["source"] == recipe.source


def test_describe_formats():
    forged = parse(table(chair(forge=[{"factory": "shelves.KitchenCabinetFactory", "sized": True, "options": {"drawer_only": True, "stretch": True}}])))
    assert forged["chair"].recipes[0].describe() == "shelves.KitchenCabinetFactory(drawer_only=True, sized=True, stretch=True)"
    forged = parse(table(chair()))
    assert forged["chair"].recipes[0].describe() == "seating.ChairFactory"


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"size": None}, r"chair\)\.size: a forged class needs its size range"),
        ({"size": [[0.4, 0.55], [0.42, 0.6]]}, r"chair\)\.size"),
        ({"size": [[0.55, 0.4], [0.42, 0.6], [0.8, 1.0]]}, r"chair\)\.size"),
        ({"size": [[0.0, 0.4], [0.42, 0.6], [0.8, 1.0]]}, r"chair\)\.size"),
        ({"role": "thing"}, r"chair\)\.role"),
        ({"forge": {"factory": "seating.ChairFactory"}}, r"chair\)\.forge: expected a list"),
        ({"forge": [{"factory": "seating.ChairFactory", "composed": "bench"}]}, r"chair\)\.forge\[0\]: a recipe names either"),
        ({"forge": [{"front": "+y"}]}, r"chair\)\.forge\[0\]: a recipe names either"),
        ({"forge": [{"factory": "ChairFactory"}]}, r"chair\)\.forge\[0\]: factory must be"),
        ({"forge": [{"factory": "seating.chair factory"}]}, r"chair\)\.forge\[0\]: factory must be"),
        ({"forge": [{"factory": "seating.ChairFactory", "front": "up"}]}, r"chair\)\.forge\[0\]: front 'up'"),
        ({"forge": [{"factory": "seating.ChairFactory", "sized": "yes"}]}, r"chair\)\.forge\[0\]: sized"),
        ({"forge": [{"factory": "seating.ChairFactory", "options": {"stretch": 1}}]}, r"chair\)\.forge\[0\]: options\.stretch"),
        ({"forge": [{"factory": "seating.ChairFactory", "options": [1]}]}, r"chair\)\.forge\[0\]: options must be"),
        ({"forge": [{"factory": "seating.ChairFactory", "dims": [1, 2, 3]}]}, r"chair\)\.forge\[0\]: unknown key\(s\) dims"),
        ({"forge": [{"composed": "bench", "sized": True}]}, r"chair\)\.forge\[0\]: a composed recipe"),
        ({"forge": ["seating.ChairFactory"]}, r"chair\)\.forge\[0\]: expected a table"),
    ],
)
def test_a_bad_entry_names_its_class(changes, message):
    entry = chair(**changes)
    if entry.get("size") is None:
        entry.pop("size")
    with pytest.raises(ClassTableError, match=r"class\[1\] \(chair\)") as caught:
        parse(table(entry))
    assert caught.match(message)


def test_a_class_without_recipes_needs_no_size():
    forged = parse(table({"name": "wall", "role": "shell"}, {"name": "curtain", "role": "object", "forge": []}))
    assert forged == {}


def test_two_classes_of_one_name():
    with pytest.raises(ClassTableError, match=r"class\[2\] \(chair\): a second class"):
        parse(table(chair(), chair()))


def test_a_broken_file(tmp_path):
    path = tmp_path / "classes.toml"
    path.write_text('[[class]]\nname = "other"\nrole = \n')
    with pytest.raises(ClassTableError, match="classes.toml"):
        recipes.load(path)
    path.write_text('[[class]]\nname = "other"\nrole = "shell"\n\n[[class]]\nname = "lamp"\nrole = "object"\nsize = [[0.2, 0.5], [0.2, 0.5], [0.35, 1.7]]\nforge = [{ factory = "lamp.DeskLampFactory", front = "-y" }]\n')
    forged = recipes.load(path)
    assert forged["lamp"].recipes[0].front == "-y" and forged["lamp"].rests is None


def test_a_recipe_checks_its_fields_when_made():
    good = FactoryRecipe(module="elements.doors", factory="DoorFactory", front="+y", stretch=True, options={"door_type": "panel"})
    assert good.describe() == "elements.doors.DoorFactory(door_type=panel, stretch=True)"
    with pytest.raises(TypeError):
        good.options["door_type"] = "louver"  # frozen: the options too
    cases = [
        (dict(module="seating", factory="chairFactory"), "factory", "factory must be a factory class name"),
        (dict(module="seating.", factory="ChairFactory"), "module", "module must be a dotted module"),
        (dict(module="seating", factory="ChairFactory", front="up"), "front", "front 'up' is not one of +x, -x, +y, -y"),
        (dict(module="seating", factory="ChairFactory", sized=1), "sized", "sized must be true or false, found 1"),
        (dict(module="seating", factory="ChairFactory", options={"stretch": True}), "options", "not stretch"),
        (dict(module="seating", factory="ChairFactory", options=[("a", 1)]), "options", "options must be a table"),
    ]
    for fields, field, message in cases:
        with pytest.raises(InvalidField) as caught:
            FactoryRecipe(**fields)
        assert caught.value.field == field
        assert message in str(caught.value)
    with pytest.raises(InvalidField, match="composed must name a builder of composed.py, found 'two words'") as caught:
        ComposedRecipe(builder="two words")
    assert caught.value.field == "builder"
    with pytest.raises(InvalidField, match="front '-z'"):
        ComposedRecipe(builder="bench", front="-z")


def test_a_class_checks_its_fields_when_made():
    chair_recipe = FactoryRecipe(module="seating", factory="ChairFactory")
    made = ForgeClass(name="chair", role="furniture", rests="floor", size_range=[[0.4, 0.55], [0.42, 0.6], [0.8, 1]], recipes=[chair_recipe, ComposedRecipe("bench")])
    assert made.size_range == ((0.4, 0.55), (0.42, 0.6), (0.8, 1.0))
    assert [made.recipe_for(v) for v in range(3)] == [chair_recipe, ComposedRecipe("bench"), chair_recipe]
    good = dict(name="chair", role="furniture", rests="floor", size_range=made.size_range, recipes=(chair_recipe,))
    cases = [
        ({"role": "thing"}, "role", "chair.role: expected one of shell, furniture, object, found 'thing'"),
        ({"rests": "roof"}, "rests", "chair.rests: expected one of floor, surface, wall, ceiling, found 'roof'"),
        ({"size_range": ((0.4, 0.55), (0.42, 0.6))}, "size", "chair.size: expected [[wmin, wmax]"),
        ({"size_range": ((0.55, 0.4), (0.42, 0.6), (0.8, 1.0))}, "size", "chair.size: expected"),
        ({"size_range": ((True, 1), (0.42, 0.6), (0.8, 1.0))}, "size", "chair.size: expected"),
        ({"recipes": ()}, "recipes", "chair.recipes: expected one or more FactoryRecipe or ComposedRecipe"),
        ({"recipes": ("seating.ChairFactory",)}, "recipes", "chair.recipes: expected one or more"),
    ]
    for change, field, message in cases:
        with pytest.raises(InvalidField) as caught:
            ForgeClass(**{**good, **change})
        assert (caught.value.field, caught.value.record) == (field, "chair")
        assert str(caught.value).startswith(message), str(caught.value)
    with pytest.raises(InvalidField, match="a class's name must be a non-empty string"):
        ForgeClass(**{**good, "name": ""})


def test_shell_textures_are_named_records():
    assert [(t.name, t.kind, t.module, t.material, t.tile) for t in recipes.SHELL][:2] == [
        ("floor-hardwood", "floor", "wood", "HardwoodFloor", 2.0),
        ("floor-wood-tile", "floor", "wood", "StaggeredWoodTile", 2.0),
    ]
    assert [t.kind for t in recipes.SHELL] == ["floor"] * 4 + ["wall"] * 2
    with pytest.raises(InvalidField, match=r"wall-x\.kind: expected floor or wall, found 'ceiling'"):
        ShellTexture("wall-x", "ceiling", "ceramic", "Plaster", 2.0)
    with pytest.raises(InvalidField, match=r"wall-x\.tile: expected positive metres, found 0"):
        ShellTexture("wall-x", "wall", "ceramic", "Plaster", 0)


def test_a_composed_recipe_takes_no_factory_fields():
    with pytest.raises(ClassTableError, match=r"chair\)\.forge\[0\]: a composed recipe takes no sized or options"):
        parse(table(chair(forge=[{"composed": "bench", "options": {}}])))
    with pytest.raises(ClassTableError, match=r"chair\)\.forge\[0\]: composed must name a builder"):
        parse(table(chair(forge=[{"composed": 3}])))
    with pytest.raises(ClassTableError, match=r"chair\)\.rests: expected one of"):
        parse(table(chair(rests="roof")))
