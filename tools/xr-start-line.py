"""The start of headset runs (`vlf xr --json` reports), as tools/gpu-xr-start.sh prints it: per
report its late and dropped frames, its first frames' wake and GPU completion before their
predicted display time (ms, wake/GPU pairs), and the same frames' GPU span (first pass start to
last pass end) and the GPU's time since the frame before ended (span/before pairs). With --table,
a Markdown row per report instead: folder, run, late, dropped, the first frame's wake and GPU
completion before its display, and the medians of the swapchain layers' pass, the frame's GPU
span and the GPU's time between frames (docs/results/h200/headset-start/README.md).
  python3 tools/xr-start-line.py [--table] REPORT.json [...]"""
import json
import os
import sys


def ms(value):
    return "-" if value is None else f"{value:.1f}"


def median(report, key):
    value = report.get(key)
    return "-" if not value else f"{value['median']:.2f}"


def lines(path, report):
    first = report.get("first_frames") or []
    pairs = " ".join(
        f"{f['woke_before_display_ms']:.1f}/{f['gpu_done_before_display_ms']:.1f}" for f in first[:24]
    )
    spans = " ".join(f"{ms(f.get('gpu_span_ms'))}/{ms(f.get('gpu_before_ms'))}" for f in first[:24])
    print(
        f"{os.path.basename(path)}: late {report['late_frames']} dropped {report['dropped_frames']}; "
        f"first frames' wake/GPU done before display (ms): {pairs}"
    )
    print(f"  GPU span/before (ms): {spans}")


def row(path, report):
    first = (report.get("first_frames") or [{}])[0]
    run = os.path.basename(path).removeprefix("xr-").removesuffix(".json")
    cells = [
        os.path.basename(os.path.dirname(path)),
        run,
        str(report["late_frames"]),
        str(report["dropped_frames"]),
        ms(first.get("woke_before_display_ms")),
        ms(first.get("gpu_done_before_display_ms")),
        median(report, "layers_gpu_ms"),
        median(report, "frame_gpu_span_ms"),
        median(report, "gpu_between_frames_ms"),
    ]
    print("| " + " | ".join(cells) + " |")


def main():
    table = "--table" in sys.argv[1:]
    for path in [a for a in sys.argv[1:] if a != "--table"]:
        report = json.load(open(path))
        (row if table else lines)(path, report)


main()
