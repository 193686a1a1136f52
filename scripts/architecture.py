#!/usr/bin/env python3
"""The library's structure, read off its source: the module tree, the largest
functions, the import circles and the places that choose a method.

    python3 scripts/architecture.py            # the report
    python3 scripts/architecture.py --check    # exit 1 on a circle or a long function

An import is any `crate::a::b` path in code (comments and doc comments left
out), resolved to the longest module prefix that has a file. A circle is a
strongly connected set of two or more modules: between files, and between
the top-level rooms (the first path segment: `method`, `verify`, ...).
A function's length counts the lines from its `fn` to its closing brace;
tests (`#[cfg(test)] mod tests`) are left out.
"""
import argparse
import re
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CRATES = {
    "bellyflop": ROOT / "crates/bellyflop/src",
    "bellyflop-cli": ROOT / "crates/bellyflop-cli/src",
}
LONG_FUNCTION = 120
# A choice between the methods: a match arm on `Method::Scvx` (each match
# on the method has one).
METHOD_CHOICE = re.compile(r"Method::Scvx\b[^,;]*=>")


def module_of(src: Path, file: Path) -> tuple:
    parts = list(file.relative_to(src).with_suffix("").parts)
    if parts[-1] in ("mod", "lib", "main"):
        parts = parts[:-1]
    return tuple(parts)


def strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return "\n".join(line.split("//", 1)[0] for line in text.splitlines())


def without_tests(text: str) -> str:
    """The text before `#[cfg(test)]` at the file's top level (where every
    file keeps its tests)."""
    m = re.search(r"^#\[cfg\(test\)\]\s*\nmod tests", text, flags=re.M)
    return text[: m.start()] if m else text


def root_reexports(root_text: str, modules: set) -> dict:
    """Names that the crate root re-exports (`pub use a::b::{X, Y}`), to
    the module that defines them: a path through the root to a re-export is
    an import of that module, not of the root."""
    out = {}
    for m in re.finditer(r"pub use ([\w:]+?)(?:::\{([^}]*)\}|::(\w+));", strip_comments(root_text)):
        base = m.group(1).split("::")
        names = [n.strip().split(" as ")[-1] for n in (m.group(2) or m.group(3)).split(",") if n.strip()]
        for k in range(len(base), 0, -1):
            if tuple(base[:k]) in modules:
                for n in names:
                    out[n] = tuple(base[:k])
                break
    return out


REEXPORTS = {}


def imports(text: str, here: tuple, modules: set) -> set:
    """The modules that `text` names by `crate::` or `super::` paths,
    including grouped `use crate::{a, b::c}` imports."""
    found = set()
    code = strip_comments(text)

    def resolve(path):
        for k in range(len(path), 0, -1):
            if tuple(path[:k]) in modules:
                return tuple(path[:k])
        return REEXPORTS.get(path[0], ())  # an item of the crate root

    # Expand `crate::{a::x, b}` groups one level deep.
    for m in re.finditer(r"\bcrate::\{([^}]*)\}", code):
        for item in m.group(1).split(","):
            item = item.strip()
            if item:
                path = re.findall(r"\w+", item.split(" as ")[0])
                r = resolve(path)
                if r is not None:
                    found.add(r)
    for m in re.finditer(r"\bcrate((?:::\w+)+)", code):
        r = resolve(m.group(1).strip(":").split("::"))
        if r is not None:
            found.add(r)
    for m in re.finditer(r"\bsuper((?:::\w+)+)", code):
        base = list(here[:-1])
        r = resolve(base + m.group(1).strip(":").split("::"))
        if r is not None:
            found.add(r)
    if here == ():
        # The crate root names its own modules without `crate::`.
        for m in re.finditer(r"(?<![:\w])(\w+)((?:::\w+)*)::", code):
            r = resolve([m.group(1)] + m.group(2).strip(":").split("::")[:1])
            if r and r[0] == m.group(1):
                found.add(r)
    found.discard(here)
    return found


def functions(text: str):
    """(name, first line, length) of every fn with a body."""
    lines = text.splitlines()
    out = []
    i = 0
    fn_re = re.compile(r"^\s*(?:pub(?:\([\w:]+\))?\s+)?(?:const\s+)?(?:unsafe\s+)?(?:extern\s+\"C\"\s+)?fn\s+(\w+)")
    while i < len(lines):
        m = fn_re.match(lines[i])
        if not m:
            i += 1
            continue
        depth, started, j = 0, False, i
        while j < len(lines):
            code = lines[j].split("//", 1)[0]
            code = re.sub(r'"(?:\\.|[^"\\])*"', '""', code)
            code = re.sub(r"'(?:\\.|[^'\\])'", "''", code)
            if not started and ";" in code and "{" not in code:
                break  # a declaration without a body
            depth += code.count("{") - code.count("}")
            if "{" in code:
                started = True
            if started and depth <= 0:
                out.append((m.group(1), i + 1, j - i + 1))
                break
            j += 1
        i += 1
    return out


def circles(graph: dict) -> list:
    """Strongly connected components of two or more nodes (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

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

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def name(m: tuple) -> str:
    return "::".join(m) or "(crate root)"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="exit 1 on a circle or a function over the limit in the library")
    ap.add_argument("--tree", action="store_true", help="print the module tree")
    args = ap.parse_args()
    failures = []
    for crate, src in CRATES.items():
        files = sorted(src.rglob("*.rs"))
        modules = {module_of(src, f): f for f in files}
        REEXPORTS.clear()
        REEXPORTS.update(root_reexports(modules[()].read_text(), set(modules)))
        graph, folders = defaultdict(set), defaultdict(set)
        longest, choices = [], []
        for m, f in modules.items():
            text = without_tests(f.read_text())
            for dep in imports(text, m, set(modules)):
                graph[m].add(dep)
                if m and dep and m[0] != dep[0]:
                    folders[m[0]].add(dep[0])
            for fn, line, length in functions(text):
                longest.append((length, f"{f.relative_to(ROOT)}:{line}", fn))
            for k, line in enumerate(strip_comments(text).splitlines()):
                if METHOD_CHOICE.search(line):
                    choices.append(f"{f.relative_to(ROOT)}:{k + 1}")
        print(f"# {crate}: {len(files)} files")
        if args.tree:
            for m in sorted(modules):
                print("  " + "  " * max(len(m) - 1, 0) + (m[-1] if m else "(root)") + f"  ({sum(1 for _ in modules[m].open())} lines)")
        longest.sort(reverse=True)
        print(f"largest functions (over {LONG_FUNCTION} lines: {sum(1 for l in longest if l[0] > LONG_FUNCTION)}):")
        for length, where, fn in longest[:8]:
            print(f"  {length:5d}  {fn}  {where}")
        file_circles = circles(graph)
        room_circles = circles(folders)
        print(f"import circles between modules: {len(file_circles)}")
        for c in file_circles:
            print("  " + " <-> ".join(name(m) for m in c))
        print(f"import circles between top-level rooms: {len(room_circles)}")
        for c in room_circles:
            print("  " + " <-> ".join(c))
        print(f"places that choose a method: {len(choices)}")
        for c in choices:
            print("  " + c)
        print()
        if crate == "bellyflop":
            failures += [f"{crate}: {fn} is {n} lines ({w})" for n, w, fn in longest if n > LONG_FUNCTION]
        failures += [f"{crate}: circle " + " <-> ".join(name(m) for m in c) for c in file_circles]
    if args.check and failures:
        print("\n".join(failures), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
