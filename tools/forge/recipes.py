"""What the forge makes of every class of the release's lexicon: the Infinigen factories that
build it (or a composition of simple parts dressed in Infinigen's materials where Infinigen
has none), the plausible size range a variant must fit (width x depth x height in metres, the
object frame: x right, y front, z up), the triangle budget, and where the factory's front
faces before the forge turns it to +y.

Sizes are the ones the built-in synthesizer has always placed (dataset/src/synthesis/library.rs);
a variant outside them is scaled uniformly into them (recorded as `scale` in the catalogue).
"""

FURNITURE_TRIANGLES = 10_000
SMALL_TRIANGLES = 2_000
VARIANTS = 3

# (module, factory) of infinigen.assets.objects
BED = ("seating", "BedFactory")
CHAIR = ("seating", "ChairFactory")
BAR_CHAIR = ("seating", "BarChairFactory")
OFFICE_CHAIR = ("seating", "OfficeChairFactory")
ARMCHAIR = ("seating", "ArmChairFactory")
SOFA = ("seating", "SofaFactory")
PILLOW = ("seating", "PillowFactory")
DINING_TABLE = ("tables", "TableDiningFactory")
COFFEE_TABLE = ("tables", "CoffeeTableFactory")
SIDE_TABLE = ("tables", "SideTableFactory")
COCKTAIL_TABLE = ("tables", "TableCocktailFactory")
SINGLE_CABINET = ("shelves", "SingleCabinetFactory")
KITCHEN_CABINET = ("shelves", "KitchenCabinetFactory")
KITCHEN_ISLAND = ("shelves", "KitchenIslandFactory")
LARGE_SHELF = ("shelves", "LargeShelfFactory")
BOOKCASE = ("shelves", "SimpleBookcaseFactory")
CELL_SHELF = ("shelves", "CellShelfFactory")
SIMPLE_DESK = ("shelves", "SimpleDeskFactory")
SIDETABLE_DESK = ("shelves", "SidetableDeskFactory")
TV_STAND = ("shelves", "TVStandFactory")
MONITOR = ("appliances", "MonitorFactory")
TV = ("appliances", "TVFactory")
CUP = ("tableware", "CupFactory")
PLATE = ("tableware", "PlateFactory")
BOWL = ("tableware", "BowlFactory")
BOTTLE = ("tableware", "BottleFactory")
CAN = ("tableware", "CanFactory")
FOOD_BOX = ("tableware", "FoodBoxFactory")
POT = ("tableware", "PotFactory")
PLANT_CONTAINER = ("tableware", "PlantContainerFactory")
BOOK = ("table_decorations", "BookFactory")
VASE = ("table_decorations", "VaseFactory")
DESK_LAMP = ("lamp", "DeskLampFactory")
FLOOR_LAMP = ("lamp", "FloorLampFactory")
TOWEL = ("clothes", "TowelFactory")
BLANKET = ("clothes", "BlanketFactory")

# The same factories with their dimensions drawn from the class's size range (forge.spawn),
# where the factory's own range misses the class.
SIZED_CABINET = ("shelves", "KitchenCabinetFactory", {"sized": True})
SIZED_DRAWERS = ("shelves", "KitchenCabinetFactory", {"sized": True, "drawer_only": True})
SIZED_TABLE = ("tables", "TableDiningFactory", {"sized": True})
SIZED_ISLAND = ("shelves", "KitchenSpaceFactory", {"sized": True, "island": True})

# class: (factories, size range ((wmin, wmax), (dmin, dmax), (hmin, hmax)), furniture?)
RECIPES = {
    "bed": ([BED], ((1.4, 1.9), (2.0, 2.2), (0.6, 1.2)), True),
    "nightstand": ([SIDE_TABLE, SINGLE_CABINET], ((0.4, 0.6), (0.35, 0.5), (0.45, 0.65)), True),
    "wardrobe": ([SIZED_CABINET], ((0.9, 1.5), (0.5, 0.65), (1.8, 2.2)), True),
    "dresser": ([SIZED_DRAWERS], ((0.9, 1.4), (0.45, 0.6), (0.75, 1.05)), True),
    "desk": ([SIMPLE_DESK, SIDETABLE_DESK], ((1.1, 1.6), (0.55, 0.8), (0.72, 0.78)), True),
    "chair": ([CHAIR, BAR_CHAIR], ((0.4, 0.55), (0.42, 0.6), (0.8, 1.0)), True),
    "dining chair": ([CHAIR], ((0.4, 0.55), (0.42, 0.6), (0.82, 1.0)), True),
    "office chair": ([OFFICE_CHAIR], ((0.55, 0.7), (0.55, 0.7), (0.9, 1.15)), True),
    "armchair": ([ARMCHAIR], ((0.7, 1.0), (0.75, 0.95), (0.75, 1.0)), True),
    "sofa": ([SOFA], ((1.7, 2.4), (0.8, 1.0), (0.75, 0.95)), True),
    "bench": (["composed"], ((1.0, 1.5), (0.35, 0.45), (0.42, 0.48)), True),
    "table": ([DINING_TABLE, SIDE_TABLE], ((0.9, 1.4), (0.7, 0.9), (0.72, 0.78)), True),
    "dining table": ([DINING_TABLE], ((1.4, 2.0), (0.85, 1.05), (0.72, 0.8)), True),
    "coffee table": ([COFFEE_TABLE], ((0.9, 1.25), (0.5, 0.75), (0.38, 0.48)), True),
    "console table": ([SIZED_TABLE], ((1.0, 1.4), (0.32, 0.42), (0.75, 0.85)), True),
    "conference table": ([SIZED_TABLE], ((2.2, 3.0), (1.0, 1.3), (0.72, 0.78)), True),
    "cabinet": ([SIZED_CABINET], ((0.8, 1.2), (0.4, 0.55), (0.9, 1.8)), True),
    "filing cabinet": ([SIZED_DRAWERS], ((0.4, 0.55), (0.5, 0.65), (0.7, 1.3)), True),
    "storage cabinet": ([SIZED_CABINET], ((0.8, 1.2), (0.4, 0.55), (0.9, 1.8)), True),
    "bookshelf": ([LARGE_SHELF, BOOKCASE], ((0.8, 1.2), (0.3, 0.4), (1.6, 2.0)), True),
    "shelf": ([CELL_SHELF, BOOKCASE], ((0.8, 1.2), (0.3, 0.4), (1.6, 2.0)), True),
    "storage rack": ([LARGE_SHELF, CELL_SHELF], ((1.0, 1.5), (0.45, 0.55), (1.7, 2.0)), True),
    "sideboard": ([SIZED_CABINET, TV_STAND], ((1.4, 1.9), (0.4, 0.5), (0.75, 0.85)), True),
    "credenza": ([TV_STAND, SIZED_DRAWERS], ((1.4, 1.9), (0.4, 0.5), (0.75, 0.85)), True),
    "counter": ([SIZED_CABINET], ((1.5, 2.4), (0.6, 0.7), (0.88, 0.94)), True),
    "kitchen island": ([SIZED_ISLAND, SIZED_CABINET], ((1.5, 2.4), (0.8, 1.05), (0.88, 0.94)), True),
    "workbench": ([SIMPLE_DESK, DINING_TABLE], ((1.6, 2.2), (0.7, 0.85), (0.86, 0.94)), True),
    "tv stand": ([TV_STAND], ((1.4, 1.8), (0.4, 0.5), (0.45, 0.6)), True),
    "mug": ([CUP], ((0.08, 0.13), (0.08, 0.11), (0.08, 0.12)), False),
    "book": ([BOOK], ((0.15, 0.24), (0.2, 0.3), (0.02, 0.06)), False),
    "laptop": (["composed"], ((0.32, 0.36), (0.23, 0.26), (0.22, 0.25)), False),
    "plate": ([PLATE], ((0.2, 0.28), (0.2, 0.28), (0.015, 0.04)), False),
    "bowl": ([BOWL], ((0.12, 0.2), (0.12, 0.2), (0.05, 0.1)), False),
    "bottle": ([BOTTLE], ((0.06, 0.09), (0.06, 0.09), (0.22, 0.32)), False),
    "can": ([CAN], ((0.06, 0.08), (0.06, 0.08), (0.1, 0.14)), False),
    "box": ([FOOD_BOX], ((0.2, 0.45), (0.15, 0.35), (0.1, 0.3)), False),
    "bucket": ([POT, "composed"], ((0.24, 0.32), (0.24, 0.32), (0.26, 0.36)), False),
    "towel": ([TOWEL], ((0.25, 0.4), (0.18, 0.3), (0.03, 0.08)), False),
    "pillow": ([PILLOW], ((0.4, 0.6), (0.3, 0.45), (0.1, 0.18)), False),
    "blanket": ([BLANKET], ((0.5, 0.7), (0.35, 0.5), (0.05, 0.1)), False),
    "backpack": (["composed"], ((0.28, 0.34), (0.18, 0.24), (0.4, 0.48)), False),
    "suitcase": (["composed"], ((0.38, 0.46), (0.22, 0.28), (0.65, 0.75)), False),
    "helmet": (["composed"], ((0.22, 0.27), (0.22, 0.3), (0.16, 0.2)), False),
    "clock": (["composed"], ((0.18, 0.24), (0.05, 0.08), (0.18, 0.24)), False),
    "printer": (["composed"], ((0.4, 0.5), (0.35, 0.45), (0.2, 0.3)), True),
    "monitor": ([MONITOR], ((0.5, 0.7), (0.15, 0.25), (0.35, 0.5)), False),
    "lamp": ([DESK_LAMP, FLOOR_LAMP], ((0.2, 0.5), (0.2, 0.5), (0.35, 1.7)), False),
    "plant": ([PLANT_CONTAINER], ((0.2, 0.45), (0.2, 0.45), (0.3, 0.9)), False),
    "vase": ([VASE], ((0.1, 0.2), (0.1, 0.2), (0.2, 0.4)), False),
    "television": ([TV], ((0.9, 1.3), (0.08, 0.25), (0.55, 0.8)), False),
}

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

# Where each factory's front faces in Infinigen's own frame (the forge turns it to +y);
# checked on the front views of the contact sheets. Infinigen's factories face +x (a
# chair's seat opens towards +x); the composed parts are built facing +y.
FRONT = {
    "composed": "+y",
    # Tables have no front: their long side stays along x as the factory makes it.
    "TableDiningFactory": "+y",
    "CoffeeTableFactory": "+y",
    "SideTableFactory": "+y",
    "TableCocktailFactory": "+y",
}
INFINIGEN_FRONT = "+x"


def front_of(recipe):
    """Where a recipe's asset faces before the forge turns it (FRONT, INFINIGEN_FRONT)."""
    return FRONT.get(recipe if recipe == "composed" else recipe[1], INFINIGEN_FRONT)


def describe(recipe):
    """The recipe as the catalogue's generator names it."""
    if recipe == "composed":
        return "tools/forge/composed.py"
    options = recipe[2] if len(recipe) > 2 else {}
    named = ", ".join(f"{k}={v}" for k, v in sorted(options.items()))
    return f"{recipe[0]}.{recipe[1]}" + (f"({named})" if named else "")
