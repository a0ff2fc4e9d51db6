#!/usr/bin/env python3
"""Functions longer than a reader can hold in their head: every `fn` whose body spans more
than `--limit` lines (80 by default), outside `#[cfg(test)]` modules, in each crate's
`src/`. Prints them longest first and exits 1 when there is one and `--check` is given.

    python3 tests/house/long_functions.py [--limit 80] [--check] [--crate server]

Standard library only. Bodies are brace-matched after comments, strings and character
literals are blanked, so a brace in a string or a lifetime does not end a function.
"""
from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from import_cycles import CRATES, ROOT, strip_tests  # noqa: E402

FN = re.compile(r"\bfn\s+(\w+)\s*(<[^{;]*?>)?\s*\(")


def blank_literals(text: str) -> str:
    """Blank comments and string and char literals with spaces (newlines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        raw = re.match(r'r(#*)"', text[i:i + 10]) if c == "r" and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")) else None
        if text.startswith("//", i):
            end = text.find("\n", i)
            end = n if end < 0 else end
            out.append(" " * (end - i))
            i = end
        elif text.startswith("/*", i):
            end = text.find("*/", i)
            end = n if end < 0 else end + 2
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
        elif raw:
            end = text.find('"' + raw.group(1), i + len(raw.group(0)))
            end = n if end < 0 else end + 1 + len(raw.group(1))
            out.append(re.sub(r"[^\n]", " ", text[i:end]))
            i = end
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(re.sub(r"[^\n]", " ", text[i:j + 1]))
            i = j + 1
        elif c == "'" and re.match(r"'(\\.[^']*|[^\\'])'", text[i:i + 12]):
            m = re.match(r"'(\\.[^']*|[^\\'])'", text[i:i + 12])
            out.append(" " * len(m.group(0)))
            i += len(m.group(0))
        else:
            out.append(c)
            i += 1
    return "".join(out)


def long_functions(path: Path, limit: int) -> list[tuple[int, str, int]]:
    text = strip_tests(blank_literals(path.read_text()))
    found = []
    for m in FN.finditer(text):
        # The body starts at the first `{` after the signature (a `;` first means no body).
        j = m.end()
        depth = 1
        while j < len(text) and depth:  # skip the parameter list
            depth += {"(": 1, ")": -1}.get(text[j], 0)
            j += 1
        brace, semi = text.find("{", j), text.find(";", j)
        if brace < 0 or (0 <= semi < brace):
            continue
        depth, k = 1, brace + 1
        while k < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[k], 0)
            k += 1
        lines = text.count("\n", brace, k) + 1
        if lines > limit:
            found.append((lines, m.group(1), text.count("\n", 0, m.start()) + 1))
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--limit", type=int, default=80)
    parser.add_argument("--check", action="store_true", help="exit 1 when a function is over the limit")
    parser.add_argument("--crate", choices=sorted(CRATES))
    args = parser.parse_args()
    rows = []
    for crate, src in CRATES.items():
        if args.crate and crate != args.crate:
            continue
        for path in sorted((ROOT / src).rglob("*.rs")):
            if path.name == "tests.rs" or "/tests/" in str(path.relative_to(ROOT)):
                continue
            for lines, name, line in long_functions(path, args.limit):
                rows.append((lines, f"{path.relative_to(ROOT)}:{line}", name))
    for lines, where, name in sorted(rows, reverse=True):
        print(f"{lines:4d}  {where}  {name}")
    print(f"{len(rows)} function(s) over {args.limit} lines", file=sys.stderr)
    return 1 if rows and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
