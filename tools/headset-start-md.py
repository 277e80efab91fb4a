"""BENCHMARKS.md's section on the headset's first frames, from what tools/gpu-xr-start.sh wrote
into DIR (docs/results/h200/headset-start/: a folder per build or variant, each with its runs'
`vlf xr --json` reports): per folder the runs, how many had late frames and how many, and the
medians of the swapchain layers' pass, the frame's GPU span and the GPU's time between frames.
Called by tools/benchmarks-md.sh.   python3 tools/headset-start-md.py DIR"""
import glob
import json
import os
import sys

# what each folder ran (its README says more)
FOLDERS = [
    ("124a285", "the session's starting build"),
    ("instrumented", "124a285, the layers' pass and the frames' GPU spans timed"),
    ("layer-pass", "the same, 300 frames: the layers' pass with and without depth, per eye, raster first hits"),
    ("ca6dca7", "two empty frames after the frame-time fit"),
    ("1496ca9-beside-pictures", "the colour by a compute pass; its first three runs beside tools/pictures.sh on the same GPU: not a measure"),
    ("1496ca9", "the colour by a compute pass and a copy (`--layer-colour compute`; one run with `fragment`)"),
    ("872cc80", "the same after render.wgsl's one specular lookup a bounce"),
    ("d025f1f", "the layers' pair ending after the compute path's copies (one run without depth)"),
    ("load", "the layers' passes load their images instead of clearing them: compute (2 runs), fragment (1 run, now the default)"),
]


def medians(reports, key):
    values = sorted(r[key]["median"] for r in reports if r.get(key))
    if not values:
        return "-"
    low, high = f"{values[0]:.2f}", f"{values[-1]:.2f}"
    return low if low == high else f"{low}-{high}"


def row(folder, what, reports):
    # null where the runtime could not convert its clock: not counted
    late = [r["late_frames"] for r in reports if r.get("late_frames") is not None]
    with_late = [n for n in late if n > 0]
    per_run = f"{min(with_late)}-{max(with_late)}" if with_late else "0"
    dropped = sum(r.get("dropped_frames") or 0 for r in reports)
    cells = [
        f"`{folder}/`",
        what,
        str(len(reports)),
        f"{len(with_late)} of {len(late)}",
        per_run,
        str(dropped),
        medians(reports, "layers_gpu_ms"),
        medians(reports, "frame_gpu_span_ms"),
        medians(reports, "gpu_between_frames_ms"),
    ]
    return "| " + " | ".join(cells) + " |"


def reports_of(root, folder, contains=""):
    paths = sorted(glob.glob(os.path.join(root, folder, f"xr-*{contains}*.json")))
    return [json.load(open(p)) for p in paths]


def median_of(reports, key):
    values = sorted(r[key]["median"] for r in reports if r.get(key))
    return values[len(values) // 2] if values else float("nan")


def newest(root, name):
    """The newest folder's `name` file (date.txt, gpu.txt), by its date."""
    folders = [f for f, _ in FOLDERS if os.path.exists(os.path.join(root, f, "date.txt"))]
    folder = max(folders, key=lambda f: open(os.path.join(root, f, "date.txt")).read())
    return open(os.path.join(root, folder, name)).read().strip()


def main():
    root = sys.argv[1]
    date, gpu = newest(root, "date.txt")[:10], newest(root, "gpu.txt")
    before = reports_of(root, "instrumented")
    period = before[0]["display_period_ms"]
    print(f"#### The headset's first frames, and the pass that puts the eyes on the swapchains — {date}\n")
    print(
        f"{gpu}, `tools/gpu-xr-start.sh` (the paced headset, 2064x2208 per eye at 90 Hz on vlf's test "
        "runtime, runs of 900 frames of the 100K classroom with glossy floors and metal, a few without "
        "them; per-run table and raw reports: "
        "[docs/results/h200/headset-start/](docs/results/h200/headset-start/README.md)). The \"about 2.8 ms "
        f"of slack a frame\" assumed above was {period - median_of(before, 'frame_gpu_span_ms'):.2f} ms: "
        "the pass that puts both eyes on the swapchains (a full-screen fragment pass, untimed until then) "
        f"took {median_of(before, 'layers_gpu_ms'):.1f} ms of each {period:.1f} ms frame on the H200, "
        "most of it clearing the swapchain images first (below), so a frame that starts late (the first after "
        "the frame-time fit always did: xrWaitFrame hands it back at once) left the GPU behind for dozens "
        "of frames.\n"
    )
    print(
        "| folder | what ran | runs | runs with late frames | late frames per such run | dropped | "
        "layers' pass p50 (ms) | frame's GPU span p50 (ms) | GPU idle between frames p50 (ms) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for folder, what in FOLDERS:
        paths = sorted(glob.glob(os.path.join(root, folder, "xr-*.json")))
        if paths:
            print(row(folder, what, [json.load(open(p)) for p in paths]))
    with_depth = median_of(reports_of(root, "1496ca9", "compute-run"), "layers_gpu_ms")
    alone = median_of(reports_of(root, "d025f1f", "nodepth"), "layers_gpu_ms")
    loaded = median_of(reports_of(root, "load", "load-run"), "layers_gpu_ms")
    fragment = median_of(reports_of(root, "load", "load-fragment"), "layers_gpu_ms")
    print(
        f"\nWith the compute pass the layers' pass took {with_depth:.2f} ms where the runtime takes "
        f"depth (with the depth-only fragment pass) and {alone:.2f} ms without depth (compute passes, "
        "copies and the empty passes that hand the images back). Most of the fragment pass's cost was "
        f"clearing its images first: loading them instead, the fragment pass with the depth takes "
        f"{fragment:.2f} ms and the compute path {loaded:.2f} ms, so the fragment pass is the default "
        "again.\n"
    )


main()
