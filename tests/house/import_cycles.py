#!/usr/bin/env python3
"""Circles of imports between the modules of each crate: a module A "imports" B when a
file of A names `crate::B…`, `super::…`, `self::…` or a child module's path resolving to B,
in a `use` or inline (a child named inline, `child::item(…)`, too). Re-exports (`pub use`) do not count: they are a module's interface,
not what its code needs. Prints every strongly connected set of more than one module and
exits 1 when there is one (a parent module using its child's items while the child uses
the parent's is a circle too).

The Python under `tools/` is checked the same way, each folder of modules as a package
(`tools/`, `tools/forge/`, …): a module A imports a sibling B when it has `import B…`,
`from B… import …`, `from . import B`, `from .B import …` or `importlib.import_module("B")`,
anywhere in the file (inside a function too: an import deferred to run time is still one).
A module naming itself is not counted, as for the crates.

    python3 tests/house/import_cycles.py [--crate server] [--verbose]

`--crate` checks only the crates named (no Python). Standard library only. A module is a
file (`a/b.rs` or `a/b/mod.rs` is module `a::b`); `#[cfg(test)] mod tests` blocks inside a
file are skipped (tests may look anywhere).
"""
from __future__ import annotations

import argparse
import ast
import os
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PYTHON_ROOTS = ("tools",)  # folders whose Python modules are checked, each sub-folder too



def workspace_members() -> list[str]:
    """The workspace's crate folders, as the root Cargo.toml lists them: a new crate is checked without a line here."""
    text = (ROOT / "Cargo.toml").read_text()
    members = re.search(r"^members\s*=\s*\[([^\]]*)\]", text, re.M)
    return re.findall(r'"([^"]+)"', members.group(1)) if members else []


CRATES = {member: f"{member}/src" for member in workspace_members()}


def modules_of(src: Path) -> dict[str, Path]:
    mods = {}
    for path in src.rglob("*.rs"):
        rel = path.relative_to(src).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "mod" or (len(parts) == 1 and parts[0] in ("lib", "main")):
            parts = parts[:-1]
        mods["::".join(parts)] = path
    return mods


def strip_tests(text: str) -> str:
    """Drop `#[cfg(test)] mod name { … }` blocks (brace-matched) and comments."""
    text = re.sub(r"//[^\n]*", "", text)
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*(pub\s+)?mod\s+\w+\s*\{", text):
        if m.start() < i:
            continue
        out.append(text[i : m.start()])
        depth, j = 1, m.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    out.append(text[i:])
    return "".join(out)


def resolve(path: list[str], mods: dict[str, Path]) -> str | None:
    """The longest module prefix of `path`."""
    for n in range(len(path), 0, -1):
        name = "::".join(path[:n])
        if name in mods:
            return name
    return None


def expand_use(body: str) -> list[str]:
    """`a::{b, c::{d, e}}` → ["a::b", "a::c::d", "a::c::e"] (roughly; enough for module paths)."""
    body = re.sub(r"\s+", "", body)
    m = re.match(r"^(.*?)\{(.*)\}$", body)
    if not m:
        return [body]
    prefix, inner = m.group(1), m.group(2)
    items, depth, cur = [], 0, ""
    for ch in inner:
        if ch == "," and depth == 0:
            items.append(cur)
            cur = ""
            continue
        depth += {"{": 1, "}": -1}.get(ch, 0)
        cur += ch
    if cur:
        items.append(cur)
    return [p for item in items for p in expand_use(prefix + item)]


def edges_of(name: str, path: Path, mods: dict[str, Path]) -> dict[str, str]:
    text = strip_tests(path.read_text())
    here = name.split("::") if name else []
    found: dict[str, str] = {}
    paths = []
    # A re-export (`pub use`) is the module's interface, not a dependency of its code.
    for m in re.finditer(r"(\bpub(?:\([^)]*\))?\s+)?\buse\s+([^;]+);", text):
        if not m.group(1):
            paths.extend(expand_use(m.group(2)))
    without_uses = re.sub(r"\buse\s+[^;]+;", "", text)
    paths.extend(m.group(0) for m in re.finditer(r"\b(?:crate|super)(?:::\w+)+", without_uses))
    # A child module named inline (`child::item(…)`), as a parent that assembles its children does.
    paths.extend(m.group(0) for m in re.finditer(r"(?<![:\w])(?!crate::|super::|self::)[a-z_]\w*(?:::\w+)+", without_uses))
    for p in paths:
        parts = [x for x in p.split(" as ")[0].split("::") if x]
        if not parts:
            continue
        if parts[0] == "crate":
            target = parts[1:]
        elif parts[0] == "super":
            base = list(here)
            while parts and parts[0] == "super":
                base = base[:-1]
                parts = parts[1:]
            target = base + parts
        elif parts[0] == "self":
            target = here + parts[1:]
        elif "::".join(here + parts[:1]) in mods:
            target = here + parts  # `use child::Item`
        else:
            continue
        to = resolve(target, mods)
        if to is None or to == name:
            continue
        found.setdefault(to, p)
    return found


def python_folders(root: Path) -> list[Path]:
    """Every folder under `root` (itself included) holding Python modules; hidden folders,
    caches and virtual environments (a `pyvenv.cfg`) are left out."""
    found = []
    for top, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith((".", "__")) and not (Path(top) / d / "pyvenv.cfg").exists())
        if any(f.endswith(".py") for f in files):
            found.append(Path(top))
    return found


def python_imports(tree: ast.AST, siblings: set[str]) -> dict[str, str]:
    """The sibling modules a parsed module imports (anywhere in it), each with the first
    statement that does ("line 12: from blender import bake")."""
    found: dict[str, str] = {}

    def add(name: str | None, node: ast.AST) -> None:
        top = (name or "").split(".")[0]
        if top in siblings and top not in found:
            found[top] = f"line {node.lineno}: {ast.unparse(node)}"

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                add(alias.name, node)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            add(node.module, node)
        elif isinstance(node, ast.ImportFrom) and node.level == 1:
            if node.module:
                add(node.module, node)
            else:  # from . import a, b
                for alias in node.names:
                    add(alias.name, node)
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else ""
            if called in ("import_module", "__import__"):
                add(node.args[0].value, node)
    return found


def python_edges(folder: Path) -> dict[str, dict[str, str]]:
    """module -> {imported sibling: the import} for the Python modules of `folder`."""
    files = {path.stem: path for path in sorted(folder.glob("*.py"))}
    siblings = set(files) - {"__init__"}
    edges = {}
    for name, path in files.items():
        imports = python_imports(ast.parse(path.read_text(), filename=str(path)), siblings)
        imports.pop(name, None)  # itself: not an edge, as for the crates
        edges[name] = imports
    return edges


def sccs(graph: dict[str, set[str]]) -> list[list[str]]:
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    sys.setrecursionlimit(10000)

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in list(graph):
        if v not in index:
            visit(v)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--crate", choices=sorted(CRATES), action="append")
    ap.add_argument("--verbose", action="store_true", help="print the import behind each edge of a circle")
    args = ap.parse_args()
    units = {}  # what is checked (a crate, a folder of Python) -> module -> {imported: how}
    for crate in args.crate or sorted(CRATES):
        mods = modules_of(ROOT / CRATES[crate])
        units[crate] = {name: edges_of(name, path, mods) for name, path in mods.items()}
    if not args.crate:
        for root in PYTHON_ROOTS:
            for folder in python_folders(ROOT / root):
                units[folder.relative_to(ROOT).as_posix()] = python_edges(folder)
    bad = sum(report_circles(unit, edges, args.verbose) for unit, edges in units.items())
    if not bad:
        print("no circle of imports in " + ", ".join(units))
    return 1 if bad else 0


def report_circles(unit: str, edges: dict[str, dict[str, str]], verbose: bool) -> int:
    """Print every circle among `unit`'s modules (with each step when `verbose`); how many."""
    circles = sccs({name: set(e) for name, e in edges.items()})
    for comp in circles:
        print(f"{unit}: a circle of {len(comp)} modules: {', '.join(m or '(root)' for m in comp)}")
        if verbose:
            for a in comp:
                for b in comp:
                    if b in edges[a]:
                        print(f"    {a or '(root)'} -> {b or '(root)'}   ({edges[a][b]})")
    return len(circles)


if __name__ == "__main__":
    sys.exit(main())
