"""Contact sheets of the forge: per class, one row per variant — the original (Cycles, its
procedural materials), the baked GLB from the same three-quarter view, and the baked GLB
from the front (front +y must face the camera) — and one overview of every class."""

import json
from pathlib import Path

from PIL import Image, ImageDraw

CELL = 256


def write(out: Path, sheets: Path, classes):
    catalogue = json.loads((out / "catalogue.json").read_text())["objects"]
    rows_of_all = []
    for name in classes:
        slug = name.replace(" ", "-")
        variants = [e for e in catalogue if e["class"] == name]
        if not variants:
            continue
        sheet = Image.new("RGB", (3 * CELL, len(variants) * CELL + 24), (32, 32, 32))
        draw = ImageDraw.Draw(sheet)
        draw.text((6, 4), f"{name}: original | baked | baked, front", fill=(230, 230, 230))
        for row, entry in enumerate(variants):
            shots = sheets / "shots" / f"{slug}-{entry['variant']}"
            for col, shot in enumerate(("original.png", "baked.png", "front.png")):
                if (shots / shot).exists():
                    sheet.paste(Image.open(shots / shot).convert("RGB"), (col * CELL, 24 + row * CELL))
            draw.text((6, 28 + row * CELL), f"{entry['variant']}: {entry['generator'].split(': ')[-1]} seed {entry['seed']}", fill=(255, 255, 0))
        sheet.save(sheets / f"{slug}.png")
        rows_of_all.append((name, variants))
    # The overview: every class's variants (baked, three quarters), one row a class.
    width = max((len(v) for _, v in rows_of_all), default=1)
    overview = Image.new("RGB", (width * CELL // 2, len(rows_of_all) * CELL // 2), (32, 32, 32))
    draw = ImageDraw.Draw(overview)
    for row, (name, variants) in enumerate(rows_of_all):
        for col, entry in enumerate(variants):
            shot = sheets / "shots" / f"{name.replace(' ', '-')}-{entry['variant']}" / "baked.png"
            if shot.exists():
                overview.paste(Image.open(shot).convert("RGB").resize((CELL // 2, CELL // 2)), (col * CELL // 2, row * CELL // 2))
        draw.text((4, row * CELL // 2 + 2), name, fill=(255, 255, 0))
    overview.save(sheets / "overview.png")
