#!/usr/bin/env python3
"""Import cycles between vlf's modules (tests/architecture.rs runs it; exit 1 on a cycle).

Every folder of src/ is checked, at every depth: the children of one module (the files and
folders beside each other: src/tracking/osc.rs and src/tracking/live.rs, or
src/xr/session.rs and src/xr/layers.rs) must not import each other in a circle.
Child A depends on its sibling B when a file anywhere under A names a path into B: `crate::...`,
`super::...` (also `super::super::...`, and inside an inline `mod tests`) or a `use` group of
them (`use crate::{a::X, b::Y}`, `use super::{b, c::Z}`). The top level (scene, prepare,
lightfield, propagate, render, ...) is the children of src/. A folder's mod.rs (or the file
beside a folder, src/scene/gltf.rs for src/scene/gltf/) is its parent, not a sibling: children
using what their parent declares is how Rust modules are built.

    python3 tools/module-cycles.py            # print the graph's cycles (none: exit 0)
    python3 tools/module-cycles.py --graph    # also print every edge
    python3 tools/module-cycles.py --src DIR  # another source tree (the script's own test)
"""

import re
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"
IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
# a path starting at crate/super/self; the tail may continue into a `{...}` group (handled apart)
PATH = re.compile(rf"\b(crate|super|self)((?:::{IDENT})*)(::\{{)?")
INLINE_MOD = re.compile(rf"\bmod\s+{IDENT}\s*\{{")


def strip_comments(text):
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r"/\*.*?\*/", "", text, flags=re.S)


def module_of(src, f):
    """src/display/window/status.rs -> (display, window, status); src/display/window/mod.rs -> (display, window)."""
    parts = f.relative_to(src).with_suffix("").parts
    return parts[:-1] if parts[-1] == "mod" else parts


def is_module(src, path):
    if not path:
        return True
    p = src.joinpath(*path)
    return p.with_suffix(".rs").is_file() or (p / "mod.rs").is_file()


def expand_group(body):
    """`a::X, b::{c, d::Y}` -> [[a, X], [b, c], [b, d, Y]] (top-level commas only)."""
    out, depth, start = [], 0, 0
    items = []
    for i, ch in enumerate(body):
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        elif ch == "," and depth == 0:
            items.append(body[start:i])
            start = i + 1
    items.append(body[start:])
    for item in items:
        item = item.strip()
        if not item or item == "*":
            continue
        if "{" in item:
            head, _, rest = item.partition("{")
            prefix = [s for s in head.split("::") if s]
            for tail in expand_group(rest[: rest.rindex("}")]):
                out.append(prefix + tail)
        else:
            out.append([s for s in item.split(" as ")[0].split("::") if s and s != "*"])
    return out


def inline_mod_depth(text):
    """For each character offset, how many inline `mod x { ... }` blocks enclose it (as a list of
    (start, end) ranges)."""
    ranges = []
    for m in INLINE_MOD.finditer(text):
        depth, i = 1, m.end()
        while i < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[i], 0)
            i += 1
        ranges.append((m.end(), i))
    return lambda pos: sum(1 for a, b in ranges if a <= pos < b)


def references(src, f):
    """The module paths (tuples) a file names, each cut to the longest prefix that is a module."""
    module = module_of(src, f)
    text = strip_comments(f.read_text())
    depth_at = inline_mod_depth(text)
    found = set()
    for m in PATH.finditer(text):
        root, tail, group = m[1], [s for s in m[2].split("::") if s], m[3]
        tails = [tail]
        if group:
            depth, i = 1, m.end()
            while i < len(text) and depth:
                depth += {"{": 1, "}": -1}.get(text[i], 0)
                i += 1
            tails = [tail + t for t in expand_group(text[m.end() : i - 1])]
        # where the path starts: the crate root, or this file's module (plus inline modules)
        inline = depth_at(m.start())
        if root == "crate":
            base = ()
        else:
            if inline:  # inside `mod tests { ... }` the path starts at that inline module
                base = module + ("<inline>",) * inline
            else:
                base = module
        for t in tails:
            path = list(base)
            rest = list(t)
            if root == "super":
                path = path[:-1]
            while rest and rest[0] == "super":
                path = path[:-1]
                rest = rest[1:]
            path = tuple(p for p in path if p != "<inline>")
            full = path + tuple(rest)
            while full and not is_module(src, full):
                full = full[:-1]
            found.add(full)
    return module, found


def edges(src):
    """(a, b) pairs of sibling modules, named by their paths ('xr::session')."""
    out = set()
    for f in sorted(src.rglob("*.rs")):
        if f.parent == src and f.name in ("main.rs", "lib.rs"):
            continue
        module, refs = references(src, f)
        for target in refs:
            common = 0
            while common < min(len(module), len(target)) and module[common] == target[common]:
                common += 1
            # both below their common folder (not the folder's own module): siblings
            if common < len(module) and common < len(target):
                parent = module[:common]
                out.add(("::".join(parent + (module[common],)), "::".join(parent + (target[common],))))
    return out


def cycles(edge_set):
    graph = {}
    for a, b in edge_set:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())
    # Tarjan's strongly connected components
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
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
    return out, graph


def folder(name):
    parts = name.split("::")[:-1]
    return "src/" + "".join(p + "/" for p in parts)


def main(argv):
    src = Path(argv[argv.index("--src") + 1]) if "--src" in argv else SRC
    e = edges(src)
    found, graph = cycles(e)
    if "--graph" in argv:
        for a in sorted(graph):
            print(f"{a} -> {', '.join(sorted(graph[a])) or '-'}")
    for comp in found:
        links = [f"{a} -> {b}" for a, b in sorted(e) if a in comp and b in comp]
        print(f"cycle among the children of {folder(comp[0])}: {{{', '.join(comp)}}}: {'; '.join(links)}")
    if not found:
        folders = {folder(a) for a, _ in e}
        print(f"no import cycles ({len(e)} edges between siblings in {len(folders)} folders)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
