"""What the forge makes of every class, read from the release's class table
(dataset/classes.toml, its header documents every field): for each class with a `forge`
list, its recipes in order (an Infinigen factory with its options, or a builder of
composed.py), its plausible size range (width x depth x height in metres, the object frame:
x right, y front, z up), where it rests, and its budget (the room's fixtures and furniture:
10,000 triangles and a 512² texture; small objects: 2,000 and 256²).

Pure Python (tomllib): the tests read it without Blender.
"""

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

TABLE = Path(__file__).resolve().parents[2] / "dataset" / "classes.toml"

FURNITURE_TRIANGLES = 10_000
SMALL_TRIANGLES = 2_000
FURNITURE_TEXTURE = 512
SMALL_TEXTURE = 256
VARIANTS = 3

ROLES = ("shell", "furniture", "object")
FRONTS = ("+x", "-x", "+y", "-y")
FACTORY_FRONT = "+x"  # Infinigen's factories face +x (a chair's seat opens towards +x)
COMPOSED_FRONT = "+y"  # composed.py builds its parts facing +y
RECIPE_KEYS = {"factory", "composed", "front", "sized", "options"}
# Options the forge itself reads (never passed to the factory): `stretch` lets normalise()
# scale the object's thinnest axis on its own when no uniform scale fits the size range (a
# rug's thickness, a picture's depth), the other two stay uniform.
FORGE_OPTIONS = ("stretch",)


class ClassTableError(ValueError):
    """A class-table entry the forge cannot use; the message names the class."""


@dataclass(frozen=True)
class Recipe:
    """One way to make a class: an Infinigen factory (`factory_module` under
    infinigen.assets.objects, `factory_class`) or a builder of composed.py (`composed`)."""

    factory_module: str | None = None
    factory_class: str | None = None
    composed: str | None = None
    front: str = FACTORY_FRONT
    sized: bool = False  # the factory's dimensions are drawn from the class's size range
    stretch: bool = False  # see FORGE_OPTIONS
    options: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))

    @property
    def is_composed(self):
        return self.composed is not None

    def describe(self):
        """The recipe as the catalogue's generator names it (unchanged from the hand-written
        recipes: `sized` and the forge's own options sort among the factory's options)."""
        if self.is_composed:
            return "tools/forge/composed.py"
        named = dict(self.options)
        if self.sized:
            named["sized"] = True
        if self.stretch:
            named["stretch"] = True
        listed = ", ".join(f"{k}={v}" for k, v in sorted(named.items()))
        return f"{self.factory_module}.{self.factory_class}" + (f"({listed})" if listed else "")


@dataclass(frozen=True)
class ForgeClass:
    name: str
    role: str
    rests: str | None
    size_range: tuple  # ((wmin, wmax), (dmin, dmax), (hmin, hmax))
    recipes: tuple  # of Recipe, in the table's order

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


def _recipe(where, raw):
    if not isinstance(raw, dict):
        raise ClassTableError(f"{where}: expected a table {{ factory = ... }} or {{ composed = ... }}, found {raw!r}")
    unknown = sorted(set(raw) - RECIPE_KEYS)
    if unknown:
        raise ClassTableError(f"{where}: unknown key(s) {', '.join(unknown)} (expected {', '.join(sorted(RECIPE_KEYS))})")
    factory, composed = raw.get("factory"), raw.get("composed")
    if (factory is None) == (composed is None):
        raise ClassTableError(f"{where}: a recipe names either a factory or a composed builder, found {raw!r}")
    front = raw.get("front", FACTORY_FRONT if factory is not None else COMPOSED_FRONT)
    if front not in FRONTS:
        raise ClassTableError(f"{where}: front {front!r} is not one of {', '.join(FRONTS)}")
    sized = raw.get("sized", False)
    if not isinstance(sized, bool):
        raise ClassTableError(f"{where}: sized must be true or false, found {sized!r}")
    options = raw.get("options", {})
    if not isinstance(options, dict):
        raise ClassTableError(f"{where}: options must be a table, found {options!r}")
    options = dict(options)
    stretch = options.pop("stretch", False)
    if not isinstance(stretch, bool):
        raise ClassTableError(f"{where}: options.stretch must be true or false, found {stretch!r}")
    if composed is not None:
        if not isinstance(composed, str) or not composed.isidentifier():
            raise ClassTableError(f"{where}: composed must name a builder of composed.py, found {composed!r}")
        if sized or options or stretch:
            raise ClassTableError(f"{where}: a composed recipe takes no sized or options")
        return Recipe(composed=composed, front=front)
    parts = factory.split(".") if isinstance(factory, str) else []
    if len(parts) < 2 or not all(p.isidentifier() for p in parts) or not parts[-1][0].isupper():
        raise ClassTableError(f"{where}: factory must be \"module.Factory\" of infinigen.assets.objects, found {factory!r}")
    return Recipe(
        factory_module=".".join(parts[:-1]),
        factory_class=parts[-1],
        front=front,
        sized=sized,
        stretch=stretch,
        options=MappingProxyType(options),
    )


def _size(where, size):
    try:
        ranges = tuple((float(lo), float(hi)) for lo, hi in size)
    except (TypeError, ValueError):
        ranges = ()
    if len(ranges) != 3 or any(not (0 < lo <= hi) for lo, hi in ranges) or any(isinstance(v, bool) for r in size for v in r):
        raise ClassTableError(f"{where}: size must be [[wmin, wmax], [dmin, dmax], [hmin, hmax]] of positive metres, found {size!r}")
    return ranges


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
        role = raw.get("role")
        if role not in ROLES:
            raise ClassTableError(f"{where}.role: expected one of {', '.join(ROLES)}, found {role!r}")
        recipes = raw.get("forge", [])
        if not isinstance(recipes, list):
            raise ClassTableError(f"{where}.forge: expected a list of recipes, found {recipes!r}")
        if not recipes:
            continue
        if name in forged:
            raise ClassTableError(f"{where}: a second class named {name!r}")
        if "size" not in raw:
            raise ClassTableError(f"{where}.size: a forged class needs its size range")
        forged[name] = ForgeClass(
            name=name,
            role=role,
            rests=raw.get("rests"),
            size_range=_size(f"{where}.size", raw["size"]),
            recipes=tuple(_recipe(f"{where}.forge[{i}]", r) for i, r in enumerate(recipes)),
        )
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

# Room shells: (name, kind, material module and class of infinigen.assets.materials, tile size
# in metres); baked to tileable textures the synthesizer dresses floors and walls in.
SHELL = [
    ("floor-hardwood", "floor", ("wood", "HardwoodFloor"), 2.0),
    ("floor-wood-tile", "floor", ("wood", "StaggeredWoodTile"), 2.0),
    ("floor-tile", "floor", ("ceramic", "Tile"), 2.0),
    ("floor-carpet", "floor", ("fabric", "Rug"), 2.0),
    ("wall-plaster", "wall", ("ceramic", "Plaster"), 2.0),
    ("wall-paint", "wall", ("ceramic", "Plaster"), 2.0),
]
