"""Two lines for a headset report (`vlf xr --json`): its late and dropped frames, and its first
frames' wake and GPU completion before their predicted display time (ms), as wake/GPU pairs; then
the same frames' GPU span (first pass start to last pass end) and the GPU's time since the frame
before ended, as span/before pairs. Used by tools/gpu-xr-start.sh.
  python3 tools/xr-start-line.py REPORT.json"""
import json
import sys

report = json.load(open(sys.argv[1]))
first = report.get("first_frames") or []
pairs = " ".join(
    f"{f['woke_before_display_ms']:.1f}/{f['gpu_done_before_display_ms']:.1f}" for f in first[:24]
)
name = sys.argv[1].split("/")[-1]
print(
    f"{name}: late {report['late_frames']} dropped {report['dropped_frames']}; "
    f"first frames' wake/GPU done before display (ms): {pairs}"
)

def ms(value):
    return "-" if value is None else f"{value:.1f}"


spans = " ".join(f"{ms(f.get('gpu_span_ms'))}/{ms(f.get('gpu_before_ms'))}" for f in first[:24])
print(f"  GPU span/before (ms): {spans}")
