#!/usr/bin/env bash
# The asset forge's environment: Python 3.11 (infinigen 1.15.5 requires it), Blender as a
# Python module (bpy 4.2.0) and infinigen without its own pins (its scikit-image<0.20 has no
# wheel for Python 3.11 and builds from source for a long time; 0.22 works). Every version
# the pack was forged with is pinned here, so the forge rebuilds it (tools/forge/README.md).
set -euo pipefail
cd "$(dirname "$0")"
VENV="${1:-.venv-forge}"
command -v python3.11 >/dev/null || { echo "forge: python3.11 is needed (infinigen 1.15.5 supports it only)" >&2; exit 1; }
python3.11 -m venv "$VENV"
"$VENV/bin/pip" install -q --upgrade pip==24.0
"$VENV/bin/pip" install -q --only-binary=:all: \
    bpy==4.2.0 "numpy==1.26.4" gin_config==0.5.0 "imageio==2.31.6" matplotlib==3.8.4 networkx==3.3 \
    "opencv-python==4.8.1.78" pandas==2.2.2 psutil==5.9.8 "scikit-image==0.22.0" "scikit-learn==1.3.2" scipy==1.13.1 \
    "shapely==2.0.5" tqdm==4.66.4 "trimesh==3.22.5" OpenEXR==3.2.4 submitit==1.5.1 geomdl==5.3.1 python-fcl==0.7.0.6 \
    rtree==1.3.0 coacd==1.0.5
"$VENV/bin/pip" install -q --no-deps infinigen==1.15.5
"$VENV/bin/python" -c "import bpy, infinigen; print('forge environment ready: Blender', bpy.app.version_string, 'infinigen', infinigen.__version__)"
