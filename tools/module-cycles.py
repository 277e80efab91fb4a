#!/usr/bin/env python3
"""Import cycles between vlf's modules (tests/architecture.rs runs it; exit 1 on a cycle).

Two levels are checked:
- the top-level modules of src/ (scene, prepare, lightfield, propagate, render, ...): module A
  depends on B when a file under A names `crate::B` (in a `use` or a path);
- sibling files inside one module (display::osc and display::tracking): the same, for
  `super::X` / `crate::M::X` between files of one folder. A folder's mod.rs is its parent, not
  a sibling: children using what their parent declares is how Rust modules are built.

    python3 tools/module-cycles.py            # print the graph's cycles (none: exit 0)
    python3 tools/module-cycles.py --graph    # also print every edge
"""

import re
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"
PATH = re.compile(r"\bcrate::([a-z_]+)(?:::([a-z_]+))?")
SUPER = re.compile(r"\bsuper::([a-z_]+)")
USE_GROUP = re.compile(r"use\s+crate::\{([^;]*)\};", re.S)


def strip_comments(text):
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r"/\*.*?\*/", "", text, flags=re.S)


def modules():
    """file -> (top-level module, sibling name or None for a folder's mod.rs / a top file)."""
    out = {}
    for f in SRC.rglob("*.rs"):
        rel = f.relative_to(SRC)
        if rel.name in ("main.rs", "lib.rs"):
            continue
        parts = rel.with_suffix("").parts
        top = parts[0]
        sibling = None
        if len(parts) >= 2 and parts[-1] != "mod":
            sibling = parts[1] if len(parts) == 2 else None
        out[f] = (top, sibling)
    return out


def edges():
    top_edges, sib_edges = set(), set()
    for f, (top, sibling) in modules().items():
        text = strip_comments(f.read_text())
        # `use crate::{a::X, b::Y}` groups name several modules
        names = []
        for group in USE_GROUP.findall(text):
            names += [(m, None) for m in re.findall(r"(?:^|[,{\s])([a-z_]+)::", group)]
        names += PATH.findall(text)
        for dep_top, dep_sub in names:
            if dep_top != top and ((SRC / dep_top).is_dir() or (SRC / f"{dep_top}.rs").exists()):
                top_edges.add((top, dep_top))
            if dep_top == top and sibling and dep_sub and dep_sub != sibling:
                if (SRC / top / f"{dep_sub}.rs").exists() or (SRC / top / dep_sub).is_dir():
                    sib_edges.add((f"{top}::{sibling}", f"{top}::{dep_sub}"))
        if sibling:
            for dep_sub in SUPER.findall(text):
                if dep_sub != sibling and ((SRC / top / f"{dep_sub}.rs").exists() or (SRC / top / dep_sub).is_dir()):
                    sib_edges.add((f"{top}::{sibling}", f"{top}::{dep_sub}"))
    return top_edges, sib_edges


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


def main(argv):
    top, sib = edges()
    status = 0
    for label, e in (("modules", top), ("files within a module", sib)):
        found, graph = cycles(e)
        if "--graph" in argv:
            for a in sorted(graph):
                print(f"{a} -> {', '.join(sorted(graph[a])) or '-'}")
        for comp in found:
            status = 1
            links = [f"{a} -> {b}" for a, b in sorted(e) if a in comp and b in comp]
            print(f"cycle among {label}: {{{', '.join(comp)}}}: {'; '.join(links)}")
    if status == 0:
        print(f"no import cycles ({len(top)} module edges, {len(sib)} file edges)")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
