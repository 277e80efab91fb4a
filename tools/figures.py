#!/usr/bin/env python3
"""Fills every measured figure in README.md and the user guide (docs/guide/*.md) from the committed
results, so none is typed by hand.

Two kinds of marks in the Markdown (HTML comments, invisible when rendered):

    <!--fig:NAME-->0.24<!--/fig-->
        an inline figure: NAME is a table in tools/figures.toml giving the results file
        (JSON or a CSV's rows), an expression over it and a format;

    <!--include:PATH-->
    ```
    ...
    ```
    <!--/include-->
        a verbatim text file from docs/results/ (e.g. a run's printed summary), fenced.

    python3 tools/figures.py            # rewrite README.md and docs/guide/*.md in place
    python3 tools/figures.py --check    # exit 1 and show the stale figures (tests/docs.rs runs it)

Expressions are Python over `j` (the file's JSON, keys as attributes: j.views[0].gpu_ms.p99)
with max, min, sum, len, abs, all, any, round and by(list, name) (the entry named so); a CSV is a list of rows of numbers/strings.
"""

import csv
import difflib
import json
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIG = re.compile(r"<!--fig:([A-Za-z0-9_]+)-->(.*?)<!--/fig-->", re.S)
INCLUDE = re.compile(r"<!--include:([^>]+?)-->\n(.*?)<!--/include-->", re.S)


class Node:
    """JSON with attribute access (j.a.b[0].c); missing keys raise with the path."""

    def __init__(self, value, path):
        self._v, self._p = value, path

    def __getattr__(self, key):
        if key.startswith("_"):
            raise AttributeError(key)
        if not isinstance(self._v, dict) or key not in self._v:
            raise KeyError(f"{self._p}.{key} is not in the results file")
        return wrap(self._v[key], f"{self._p}.{key}")

    def __getitem__(self, i):
        return wrap(self._v[i], f"{self._p}[{i}]")

    def __iter__(self):
        return (wrap(v, f"{self._p}[{i}]") for i, v in enumerate(self._v))

    def __len__(self):
        return len(self._v)


def wrap(v, path):
    return Node(v, path) if isinstance(v, (dict, list)) else v


def load(path):
    if path.suffix == ".csv":
        with open(path) as f:
            rows = list(csv.DictReader(f))
        return wrap([{k: _num(v) for k, v in r.items()} for r in rows], path.name)
    return wrap(json.loads(path.read_text()), path.name)


def _num(s):
    try:
        return float(s)
    except ValueError:
        return s


def by(items, name):
    """The entry of a list whose `name` is `name` (suite entries, CAVE views)."""
    for e in items:
        if e.name == name:
            return e
    raise KeyError(f"no entry named {name!r}")


SAFE = {"by": by, "int": int, "float": float, "max": max, "min": min, "sum": sum, "len": len, "abs": abs, "all": all, "any": any, "round": round}


def figure(name, table, cache):
    if name not in table:
        raise SystemExit(f"figure {name!r} is not defined in tools/figures.toml")
    spec = table[name]
    path = ROOT / spec["file"]
    if path not in cache:
        if not path.exists():
            raise SystemExit(f"tools/figures.toml [{name}]: {spec['file']} does not exist")
        cache[path] = load(path)
    try:
        value = eval(spec["expr"], {"__builtins__": SAFE}, {"j": cache[path]})  # noqa: S307 (own table)
    except Exception as e:  # the table is ours: say which entry is wrong
        raise SystemExit(f"tools/figures.toml [{name}]: {spec['expr']}: {e}")
    return spec.get("format", "{}").format(value)


def render(text, table):
    cache = {}
    text = FIG.sub(lambda m: f"<!--fig:{m[1]}-->{figure(m[1], table, cache)}<!--/fig-->", text)

    def include(m):
        path = ROOT / m[1].strip()
        if not path.exists():
            raise SystemExit(f"included file {m[1]} does not exist")
        body = path.read_text().rstrip("\n")
        return f"<!--include:{m[1]}-->\n```\n{body}\n```\n<!--/include-->"

    return INCLUDE.sub(include, text)


def documents():
    """README.md and the guide's pages, as paths relative to the repository."""
    return ["README.md"] + sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs/guide").glob("*.md"))


def main(argv):
    check = "--check" in argv
    table = tomllib.loads((ROOT / "tools/figures.toml").read_text())
    status = 0
    used = set()
    for doc in documents():
        path = ROOT / doc
        old = path.read_text()
        new = render(old, table)
        used |= {name for name, _ in FIG.findall(old)}
        if new == old:
            continue
        if check:
            diff = difflib.unified_diff(old.splitlines(), new.splitlines(), doc, doc + " (from the results)", lineterm="", n=0)
            print("\n".join(diff))
            print(f"{doc}: figures are stale; run `python3 tools/figures.py`", file=sys.stderr)
            status = 1
        else:
            tmp = path.with_suffix(".md.tmp")
            tmp.write_text(new)
            tmp.replace(path)
            print(f"{doc}: figures updated", file=sys.stderr)
    unused = sorted(set(table) - used)
    if unused:
        print(f"tools/figures.toml: defined but used in no document: {', '.join(unused)}", file=sys.stderr)
        status = 1
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
