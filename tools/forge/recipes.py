"""What the forge makes of every class, read from the release's class table
(dataset/classes.toml, its header documents every field): for each class with a `forge`
list, its recipes in order (an Infinigen factory with its options, or a builder of
composed.py), its plausible size range (width x depth x height in metres, the object frame:
x right, y front, z up), where it rests, and its budget (the room's fixtures and furniture:
10,000 triangles and a 512² texture; small objects: 2,000 and 256²).

Every recipe and class is a named, frozen record that checks its fields when it is made
(InvalidField names the field; read from the table, ClassTableError names the class too).

Pure Python (tomllib): the tests read it without Blender.
"""

import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import ClassVar

TABLE = Path(__file__).resolve().parents[2] / "dataset" / "classes.toml"

FURNITURE_TRIANGLES = 10_000
SMALL_TRIANGLES = 2_000
FURNITURE_TEXTURE = 512
SMALL_TEXTURE = 256
VARIANTS = 3

ROLES = ("shell", "furniture", "object")
RESTS = ("floor", "surface", "wall", "ceiling")
FRONTS = ("+x", "-x", "+y", "-y")
FACTORY_FRONT = "+x"  # Infinigen's factories face +x (a chair's seat opens towards +x)
COMPOSED_FRONT = "+y"  # composed.py builds its parts facing +y
RECIPE_KEYS = {"factory", "composed", "front", "sized", "options"}
# Options the forge itself reads (never passed to the factory): `stretch` lets the forge
# scale the object's thinnest axis on its own when no uniform scale fits the size range (a
# rug's thickness, a picture's depth), the other two stay uniform.
FORGE_OPTIONS = ("stretch",)


class ClassTableError(ValueError):
    """A class-table entry the forge cannot use; the message names the class."""


class InvalidField(ClassTableError):
    """A record made with a field the forge cannot use: `field` names it and `problem` says
    what is wrong. A recipe's problem names its field itself ("front 'up' is not one of …");
    a class's (`record`, its name) is told as "chair.size: expected …"."""

    def __init__(self, field_name, problem, record=None):
        super().__init__(f"{record}.{field_name}: {problem}" if record else problem)
        self.field = field_name
        self.problem = problem
        self.record = record


def _check_front(front):
    if front not in FRONTS:
        raise InvalidField("front", f"front {front!r} is not one of {', '.join(FRONTS)}")


def _check_bool(name, value):
    if not isinstance(value, bool):
        raise InvalidField(name, f"{name} must be true or false, found {value!r}")


@dataclass(frozen=True)
class FactoryRecipe:
    """An Infinigen factory: `factory` of infinigen.assets.objects.`module` (dotted as deep as
    needed), its `options`, facing `front`; `sized` draws its dimensions from the class's size
    range; `stretch` (the forge's own option) lets the thinnest axis scale on its own."""

    module: str
    factory: str
    front: str = FACTORY_FRONT
    sized: bool = False
    stretch: bool = False
    options: Mapping = field(default_factory=lambda: MappingProxyType({}))

    source: ClassVar[str] = "infinigen"  # the catalogue's `source`

    def __post_init__(self):
        if not isinstance(self.module, str) or not all(p.isidentifier() for p in self.module.split(".")):
            raise InvalidField("module", f"module must be a dotted module of infinigen.assets.objects, found {self.module!r}")
        if not isinstance(self.factory, str) or not self.factory.isidentifier() or not self.factory[0].isupper():
            raise InvalidField("factory", f"factory must be a factory class name (Capitalised), found {self.factory!r}")
        _check_front(self.front)
        _check_bool("sized", self.sized)
        _check_bool("stretch", self.stretch)
        if not isinstance(self.options, Mapping):
            raise InvalidField("options", f"options must be a table, found {self.options!r}")
        own = sorted(set(self.options) & set(FORGE_OPTIONS))
        if own or not all(isinstance(k, str) for k in self.options):
            raise InvalidField("options", f"options must name the factory's keyword arguments (not {', '.join(own) or 'a non-string key'})")
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    def describe(self):
        """The recipe as the catalogue's generator names it (unchanged from the hand-written
        recipes: `sized` and the forge's own options sort among the factory's options)."""
        named = dict(self.options)
        if self.sized:
            named["sized"] = True
        if self.stretch:
            named["stretch"] = True
        listed = ", ".join(f"{k}={v}" for k, v in sorted(named.items()))
        return f"{self.module}.{self.factory}" + (f"({listed})" if listed else "")


@dataclass(frozen=True)
class ComposedRecipe:
    """A builder of composed.py (simple parts in Infinigen's materials), facing `front`."""

    builder: str
    front: str = COMPOSED_FRONT

    source: ClassVar[str] = "composed (infinigen materials)"  # the catalogue's `source`
    stretch: ClassVar[bool] = False  # a builder draws its sizes within the class's range

    def __post_init__(self):
        if not isinstance(self.builder, str) or not self.builder.isidentifier():
            raise InvalidField("builder", f"composed must name a builder of composed.py, found {self.builder!r}")
        _check_front(self.front)

    def describe(self):
        return "tools/forge/composed.py"


Recipe = FactoryRecipe | ComposedRecipe


def _check_size(size_range):
    """((wmin, wmax), (dmin, dmax), (hmin, hmax)) of positive metres, each min <= max."""
    problem = f"expected [[wmin, wmax], [dmin, dmax], [hmin, hmax]] of positive metres, found {size_range!r}"
    try:
        pairs = [tuple(pair) for pair in size_range]
    except TypeError:
        raise InvalidField("size", problem) from None
    if len(pairs) != 3 or any(len(p) != 2 for p in pairs):
        raise InvalidField("size", problem)
    values = [v for p in pairs for v in p]
    if any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in values):
        raise InvalidField("size", problem)
    if any(not (0 < lo <= hi) for lo, hi in pairs):
        raise InvalidField("size", problem)
    return tuple((float(lo), float(hi)) for lo, hi in pairs)


@dataclass(frozen=True)
class ForgeClass:
    """A forged class: its role (the budget), where it rests, its size range and its recipes
    (variant i uses recipe i mod their number)."""

    name: str
    role: str
    rests: str | None
    size_range: tuple  # ((wmin, wmax), (dmin, dmax), (hmin, hmax)), floats
    recipes: tuple  # of FactoryRecipe and ComposedRecipe, in the table's order

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise InvalidField("name", f"a class's name must be a non-empty string, found {self.name!r}")
        try:
            if self.role not in ROLES:
                raise InvalidField("role", f"expected one of {', '.join(ROLES)}, found {self.role!r}")
            if self.rests is not None and self.rests not in RESTS:
                raise InvalidField("rests", f"expected one of {', '.join(RESTS)}, found {self.rests!r}")
            object.__setattr__(self, "size_range", _check_size(self.size_range))
            recipes = tuple(self.recipes) if isinstance(self.recipes, (list, tuple)) else ()
            if not recipes or not all(isinstance(r, (FactoryRecipe, ComposedRecipe)) for r in recipes):
                raise InvalidField("recipes", f"expected one or more FactoryRecipe or ComposedRecipe, found {self.recipes!r}")
            object.__setattr__(self, "recipes", recipes)
        except InvalidField as e:
            raise InvalidField(e.field, e.problem, record=self.name) from None

    def recipe_for(self, variant):
        """The recipe of variant `variant`: the recipes in turn."""
        return self.recipes[variant % len(self.recipes)]

    @property
    def furniture(self):
        """Furniture and the room's fixtures (doors, windows) get the large budget."""
        return self.role in ("furniture", "shell")

    @property
    def triangles(self):
        return FURNITURE_TRIANGLES if self.furniture else SMALL_TRIANGLES

    @property
    def texture(self):
        return FURNITURE_TEXTURE if self.furniture else SMALL_TEXTURE


def recipe_from_table(raw):
    """The recipe of one `forge` entry of the class table (a dict as tomllib gives it);
    raises InvalidField (the message names the field) for a bad one."""
    if not isinstance(raw, dict):
        raise InvalidField("forge", f"expected a table {{ factory = ... }} or {{ composed = ... }}, found {raw!r}")
    unknown = sorted(set(raw) - RECIPE_KEYS)
    if unknown:
        raise InvalidField("forge", f"unknown key(s) {', '.join(unknown)} (expected {', '.join(sorted(RECIPE_KEYS))})")
    factory, composed = raw.get("factory"), raw.get("composed")
    if (factory is None) == (composed is None):
        raise InvalidField("forge", f"a recipe names either a factory or a composed builder, found {raw!r}")
    if composed is not None:
        if "sized" in raw or "options" in raw:
            raise InvalidField("forge", "a composed recipe takes no sized or options")
        return ComposedRecipe(builder=composed, front=raw.get("front", COMPOSED_FRONT))
    parts = factory.split(".") if isinstance(factory, str) else []
    if len(parts) < 2 or not all(p.isidentifier() for p in parts) or not parts[-1][0].isupper():
        raise InvalidField("factory", f"factory must be \"module.Factory\" of infinigen.assets.objects, found {factory!r}")
    options = raw.get("options", {})
    if not isinstance(options, dict):
        raise InvalidField("options", f"options must be a table, found {options!r}")
    options = dict(options)
    stretch = options.pop("stretch", False)
    if not isinstance(stretch, bool):
        raise InvalidField("options.stretch", f"options.stretch must be true or false, found {stretch!r}")
    return FactoryRecipe(
        module=".".join(parts[:-1]),
        factory=parts[-1],
        front=raw.get("front", FACTORY_FRONT),
        sized=raw.get("sized", False),
        stretch=stretch,
        options=options,
    )


def _forge_class(where, name, raw):
    """The ForgeClass of one [[class]] entry with a `forge` list; errors name `where`."""
    recipes = []
    for i, entry in enumerate(raw["forge"]):
        try:
            recipes.append(recipe_from_table(entry))
        except InvalidField as e:
            raise ClassTableError(f"{where}.forge[{i}]: {e.problem}") from None
    if "size" not in raw:
        raise ClassTableError(f"{where}.size: a forged class needs its size range")
    try:
        return ForgeClass(name=name, role=raw.get("role"), rests=raw.get("rests"), size_range=raw["size"], recipes=tuple(recipes))
    except InvalidField as e:
        raise ClassTableError(f"{where}.{e.field}: {e.problem}") from None


def parse(table):
    """The forged classes of a parsed class table (a dict as tomllib gives it), by name in the
    table's order; raises ClassTableError naming the class of a bad entry."""
    classes = table.get("class")
    if not isinstance(classes, list):
        raise ClassTableError("the class table has no [[class]] entries")
    forged = {}
    for index, raw in enumerate(classes):
        name = raw.get("name") if isinstance(raw, dict) else None
        if not isinstance(name, str) or not name:
            raise ClassTableError(f"class[{index}]: no name")
        where = f"class[{index}] ({name})"
        if raw.get("role") not in ROLES:
            raise ClassTableError(f"{where}.role: expected one of {', '.join(ROLES)}, found {raw.get('role')!r}")
        recipes = raw.get("forge", [])
        if not isinstance(recipes, list):
            raise ClassTableError(f"{where}.forge: expected a list of recipes, found {recipes!r}")
        if not recipes:
            continue
        if name in forged:
            raise ClassTableError(f"{where}: a second class named {name!r}")
        forged[name] = _forge_class(where, name, raw)
    return forged


def load(path=TABLE):
    """The forged classes of the class table at `path`."""
    with open(path, "rb") as f:
        try:
            table = tomllib.load(f)
        except tomllib.TOMLDecodeError as e:
            raise ClassTableError(f"{path}: {e}") from e
    return parse(table)


RECIPES = load()


@dataclass(frozen=True)
class ShellTexture:
    """A room shell's texture: Infinigen's `materials.<module>.<material>` baked to a seamless
    texture of a `tile`-metre square, for a `kind` of surface (floor or wall)."""

    name: str
    kind: str
    module: str
    material: str
    tile: float

    def __post_init__(self):
        if self.kind not in ("floor", "wall"):
            raise InvalidField("kind", f"expected floor or wall, found {self.kind!r}", record=self.name)
        if not (self.module.isidentifier() and self.material.isidentifier()):
            raise InvalidField("material", f"expected a module and a class of infinigen.assets.materials, found {self.module!r}, {self.material!r}", record=self.name)
        if isinstance(self.tile, bool) or not isinstance(self.tile, (int, float)) or self.tile <= 0:
            raise InvalidField("tile", f"expected positive metres, found {self.tile!r}", record=self.name)


# Room shells, baked to tileable textures the synthesizer dresses floors and walls in.
SHELL = (
    ShellTexture("floor-hardwood", "floor", "wood", "HardwoodFloor", 2.0),
    ShellTexture("floor-wood-tile", "floor", "wood", "StaggeredWoodTile", 2.0),
    ShellTexture("floor-tile", "floor", "ceramic", "Tile", 2.0),
    ShellTexture("floor-carpet", "floor", "fabric", "Rug", 2.0),
    ShellTexture("wall-plaster", "wall", "ceramic", "Plaster", 2.0),
    ShellTexture("wall-paint", "wall", "ceramic", "Plaster", 2.0),
)
