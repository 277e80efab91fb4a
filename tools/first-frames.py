#!/usr/bin/env python3
"""The first frames of CAVE runs (`vlf cave --json` reports, e.g. tools/gpu-body.sh's) beside
each other: the first timed frame's GPU and CPU+GPU time against the next frames', the run's
longest frame and where it fell, the worst view's p99/p50. Markdown on stdout.

    python3 tools/first-frames.py DIR [DIR ...]

Each DIR holds cave-*.json reports; a column per DIR (e.g. the build before and after a change).
"""
import json
import pathlib
import sys


def row(report):
    series = report["series"]
    cpu, gpu = series["cpu_frame_ms"], series["frame_gpu_ms"]
    worst = max(range(len(cpu)), key=lambda i: cpu[i])
    rest = sorted(cpu[1:])[len(cpu[1:]) // 2]
    return (
        f"{gpu[0]:.2f} / {cpu[0]:.2f} ms (then {rest:.2f})",
        f"{cpu[worst]:.2f} ms (frame {worst}, GPU {gpu[worst]:.2f})",
        f"{report['worst_p99_over_p50']:.3f}",
    )


def main(dirs):
    if not dirs:
        sys.exit(__doc__)
    names = sorted({p.name for d in dirs for p in pathlib.Path(d).glob("cave-*.json")})
    if not names:
        sys.exit(f"no cave-*.json in {', '.join(dirs)}")
    print("| run | build | first frame, GPU / CPU+GPU (median of the rest) | longest frame | worst view p99/p50 |")
    print("|---|---|---|---|---|")
    for name in names:
        for d in dirs:
            path = pathlib.Path(d) / name
            if not path.is_file():
                continue
            report = json.loads(path.read_text())
            commit = (pathlib.Path(d) / "commit.txt")
            build = commit.read_text().strip() if commit.is_file() else d
            first, longest, worst = row(report)
            print(f"| {name[5:-5]} on {report['adapter']} | {build} | {first} | {longest} | {worst} |")


if __name__ == "__main__":
    main(sys.argv[1:])
