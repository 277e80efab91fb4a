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
]


def medians(reports, key):
    values = sorted(r[key]["median"] for r in reports if r.get(key))
    if not values:
        return "-"
    low, high = f"{values[0]:.2f}", f"{values[-1]:.2f}"
    return low if low == high else f"{low}-{high}"


def row(folder, what, reports):
    late = [r["late_frames"] for r in reports]
    with_late = [n for n in late if n > 0]
    per_run = f"{min(with_late)}-{max(with_late)}" if with_late else "0"
    dropped = sum(r["dropped_frames"] for r in reports)
    cells = [
        f"`{folder}/`",
        what,
        str(len(reports)),
        f"{len(with_late)} of {len(reports)}",
        per_run,
        str(dropped),
        medians(reports, "layers_gpu_ms"),
        medians(reports, "frame_gpu_span_ms"),
        medians(reports, "gpu_between_frames_ms"),
    ]
    return "| " + " | ".join(cells) + " |"


def main():
    root = sys.argv[1]
    date = open(os.path.join(root, "ca6dca7", "date.txt")).read().strip()[:10]
    gpu = open(os.path.join(root, "ca6dca7", "gpu.txt")).read().strip()
    print(f"#### The headset's first frames, and the pass that puts the eyes on the swapchains — {date}\n")
    print(
        f"{gpu}, `tools/gpu-xr-start.sh` (the paced headset, 2064x2208 per eye at 90 Hz on vlf's test "
        "runtime, runs of 900 frames of the 100K classroom with glossy floors and metal, a few without "
        "them; per-run table and raw reports: "
        "[docs/results/h200/headset-start/](docs/results/h200/headset-start/README.md)). The \"about 2.8 ms "
        "of slack a frame\" assumed above was 0.15 ms: the pass that puts both eyes on the swapchains (a "
        "full-screen fragment pass, untimed until then) took 2.6 ms of each 11.1 ms frame on the H200, "
        "whose graphics units are a small part of the chip, so a frame that starts late (the first after "
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
    print(
        "\nWhere the runtime takes depth, the depth-only fragment pass (2.0 ms) is what remains of the "
        "layers' pass; without depth the compute passes take 0.10 ms.\n"
    )


main()
