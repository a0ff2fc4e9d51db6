"""The forge's pure modules (forge.py's command line and loop, recipes.py, catalogue.py,
sizing.py, glb.py) import without Blender: put tools/forge on the path for the tests."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
