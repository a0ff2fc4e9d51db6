#!/usr/bin/env python3
"""Every module of every crate is named in docs/architecture.md, so the map of the code stays
complete as modules are added: a module file `x/y.rs` is named when the document holds `y.rs`
(or `x/y.rs`) in backticks; a folder module (`x/mod.rs`) when it holds `x/`; a crate's root
(`lib.rs`, `main.rs`) is its crate's row. Tests (`tests.rs`, `tests/`) are left out.

    python3 tests/house/modules_named.py           # lists the modules the document does not name
    python3 tests/house/modules_named.py --check   # the same, and exit status 1 when there are any
"""

import argparse
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from import_cycles import CRATES, ROOT  # noqa: E402

DOC = ROOT / "docs" / "architecture.md"


def named_in(doc: str) -> set[str]:
    """Everything the document puts in backticks, and each `a/b/c.rs` path's tails (`b/c.rs`, `c.rs`)."""
    names = set()
    for quoted in re.findall(r"`([^`\n]+)`", doc):
        for word in re.split(r"[\s,()]+", quoted):
            parts = word.strip(".:;").split("/")
            for i in range(len(parts)):
                names.add("/".join(parts[i:]))
    return names


def modules(src: Path):
    """(path relative to the crate's src, the names that would name it) for every module file."""
    for path in sorted(src.rglob("*.rs")):
        rel = path.relative_to(src)
        if rel.name in ("lib.rs", "main.rs") and len(rel.parts) == 1:
            continue
        if rel.name == "tests.rs" or "tests" in rel.parts[:-1]:
            continue
        if rel.name == "mod.rs":
            folder = rel.parent.as_posix()
            yield rel.as_posix(), {folder + "/", folder.split("/")[-1] + "/"}
        else:
            yield rel.as_posix(), {rel.as_posix(), rel.name}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()
    names = named_in(DOC.read_text())
    missing = [f"{crate}/src/{rel}" for crate, src in CRATES.items() for rel, ways in modules(ROOT / src) if not ways & names]
    for m in missing:
        print(f"not named in docs/architecture.md: {m}")
    print(f"{len(missing)} module(s) not named")
    return 1 if args.check and missing else 0


if __name__ == "__main__":
    sys.exit(main())
