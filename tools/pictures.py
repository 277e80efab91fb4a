#!/usr/bin/env python3
"""The documents' pictures and what makes them: docs/images/pictures.toml (the manifest).

Every picture README.md, BENCHMARKS.md, ARCHITECTURE.md and the guide (docs/guide/) show has an entry: the command that
makes it (`made_by`), where it must run (`machine`: gpu or software), what it shows (`shows`:
the repository paths whose change changes the picture: scenes, display configs, results it is
drawn from, the code that draws it), and, stamped when it was made, the commit, the adapter and
`inputs_sha256`, a hash of the `shows` paths then. tests/docs.rs recomputes that hash (the
same definition as `inputs_hash` here) and fails, naming the command, when the picture's
inputs have changed since it was made.

  python3 tools/pictures.py names [--machine gpu|software]   entries tools/pictures.sh makes
  python3 tools/pictures.py describe VLF OUT WORK NAME...    (tools/pictures.sh) OUT/pictures-stamp.json
  python3 tools/pictures.py stamp OUT                        copy OUT's pictures to docs/images, stamp them
  python3 tools/pictures.py restamp NAME...                  stamp pictures made by their own scripts
"""
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MANIFEST = ROOT / "docs/images/pictures.toml"


def inputs_hash(shows):
    """sha256 over the files below each `shows` path, in order; within a folder by relative
    path (as text, '/'-separated): each file's path, a NUL, its bytes, a NUL."""
    h = hashlib.sha256()
    for entry in shows:
        path = ROOT / entry
        if path.is_dir():
            files = sorted(
                (p for p in path.rglob("*") if p.is_file()),
                key=lambda p: p.relative_to(ROOT).as_posix(),
            )
        elif path.is_file():
            files = [path]
        else:
            sys.exit(f"tools/pictures.py: {entry} (in `shows`) does not exist")
        for f in files:
            h.update(f.relative_to(ROOT).as_posix().encode() + b"\0")
            h.update(f.read_bytes() + b"\0")
    return h.hexdigest()


def load():
    with open(MANIFEST, "rb") as f:
        return tomllib.load(f)["pictures"]


def commit():
    # the lent GPU machine's copy of the tree carries a stale .git: the script running there is
    # told the commit it was made from (VLF_COMMIT), as the GPU scripts are
    if os.environ.get("VLF_COMMIT"):
        return os.environ["VLF_COMMIT"]
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, capture_output=True, text=True)
    return head.stdout.strip() + ("+changes" if dirty.stdout.strip() else "")


def write(pictures):
    """The manifest back, entries in their order, keys in a fixed order."""
    keys = ["image", "made_by", "machine", "shows", "made_at", "adapter", "inputs_sha256"]
    lines = [
        "# The documents' pictures: what makes each one and what it shows (tools/pictures.py explains the",
        "# fields; tests/docs.rs fails when a picture's `shows` changed since `inputs_sha256`).",
        "# Stamped by tools/pictures.py: edit `made_by`, `machine` and `shows` by hand, not the rest.",
        "",
    ]
    for name, p in pictures.items():
        lines.append(f"[pictures.{name}]")
        for k in keys:
            if k in p:
                lines.append(f"{k} = {json.dumps(p[k])}")
        lines.append("")
    MANIFEST.write_text("\n".join(lines))


def main():
    cmd = sys.argv[1] if len(sys.argv) > 1 else ""
    pictures = load()
    if cmd == "names":
        machine = sys.argv[3] if len(sys.argv) > 3 and sys.argv[2] == "--machine" else None
        for name, p in pictures.items():
            if p["made_by"].startswith("tools/pictures.sh") and (machine is None or p["machine"] == machine):
                print(name)
    elif cmd == "describe":
        vlf, out, work, names = sys.argv[2], Path(sys.argv[3]), Path(sys.argv[4]), sys.argv[5:]
        adapter = "unknown"
        # the first report that names its adapter (an older stamp in the folder does not)
        for report in sorted(work.glob("*.json")):
            named = json.loads(report.read_text()).get("adapter")
            if isinstance(named, dict) and "name" in named:
                adapter = named["name"]
                break
        stamp = {n: {"made_at": commit(), "adapter": adapter, "inputs_sha256": inputs_hash(pictures[n]["shows"])} for n in names}
        (out / "pictures-stamp.json").write_text(json.dumps(stamp, indent=1))
        print(f"{len(names)} picture(s) in {out}, made with {vlf} on {adapter}")
    elif cmd == "stamp":
        out = Path(sys.argv[2])
        stamp = json.loads((out / "pictures-stamp.json").read_text())
        for name, s in stamp.items():
            image = pictures[name]["image"]
            shutil.copyfile(out / image, ROOT / "docs/images" / image)
            pictures[name].update(s)
            print(f"docs/images/{image}: {s['adapter']} at {s['made_at']}")
        write(pictures)
    elif cmd == "restamp":
        for name in sys.argv[2:]:
            pictures[name]["inputs_sha256"] = inputs_hash(pictures[name]["shows"])
        write(pictures)
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
