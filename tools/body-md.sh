#!/usr/bin/env bash
# BENCHMARKS.md's section on the body in the walk CAVE, from what tools/gpu-body.sh wrote into
# DIR (its cave-<scene>-<variant>.json reports; fixed-<scene>-{old,new}.json and
# pics-identity.txt where the comparison with the build before the objects was run).
#   tools/body-md.sh DIR
set -euo pipefail
dir=$1
python3 - "$dir" <<'PY'
import glob, json, os, sys
d = sys.argv[1]
gpu = open(os.path.join(d, "gpu.txt")).read().strip()
commit = open(os.path.join(d, "commit.txt")).read().strip()
date = open(os.path.join(d, "date.txt")).read().strip()[:10]
print(f"### A body in the walk CAVE (issue 28) — {date}\n")
frames = next(json.load(open(p))["frames"] for p in sorted(glob.glob(os.path.join(d, "cave-*.json"))))
print(f"{gpu}, build {commit}, `bash tools/gpu-body.sh VLF OUT {frames}`: the walk CAVE "
      "(`config/displays/cave-4wall-walk.toml`: 8 views of 1920x1200, 120 Hz, paced) on the "
      f"classroom walks, {frames} frames each: without moving objects, with the shipped avatar on the "
      "walking head (`assets/avatar/mannequin.glb`, 4,456 triangles), the same without its "
      "shadows, with its own direct light per pixel rather than at its vertices, without the "
      "shadow atlas's indirect rays (where run), and the "
      f"avatar with a 199,712-triangle prop. Raw reports: `{os.path.relpath(d)}/`.\n")
print("| scene | objects | all views GPU p50 / p99 | eye rays per pixel, median per view | moving objects' pass p50 / p99 | worst view p99/p50 | frame max |")
print("|---|---|---|---|---|---|---|")
names = {"none": "none", "body-noshadow": "avatar, no shadows", "body": "avatar with shadows",
         "body-perpixel": "avatar, shadows per pixel", "body-prop": "avatar + 200K prop, shadows",
         "body-pixeldirect": "avatar with shadows, its direct light per pixel",
         "body-noindirect": "avatar with shadows, no indirect rays in the atlas"}
for scene, label in [("classroom-100k", "100K classroom"), ("classroom-1m", "1M classroom")]:
    for variant in ["none", "body-noshadow", "body-noindirect", "body", "body-pixeldirect", "body-perpixel", "body-prop"]:
        path = os.path.join(d, f"cave-{scene}-{variant}.json")
        if not os.path.exists(path):
            continue
        r = json.load(open(path))
        views = r["all_views_gpu_ms"]
        objects = r.get("objects_gpu_ms")
        update = f"{objects['median']:.3f} / {objects['p99']:.3f} ms" if objects else ""
        pacer = r.get("pacer")
        if pacer:
            medians = [v["median"] for v in pacer["eye_rays_per_pixel"]]
            rays = f"{min(medians):.2f}-{max(medians):.2f}"
        else:
            rays = "1 (nothing fits)"
        frame_max = max(r["series"]["cpu_frame_ms"])
        print(f"| {label} | {names[variant]} | {views['median']:.2f} / {views['p99']:.2f} ms | {rays} | {update} | {r['worst_p99_over_p50']:.3f} | {frame_max:.2f} ms |")
print()
fixed = {b: sorted(glob.glob(os.path.join(d, f"fixed-*-{b}.json"))) for b in ["old", "new"]}
if fixed["old"] and fixed["new"]:
    old = json.load(open(fixed["old"][0]))["all_views_gpu_ms"]["median"]
    new = json.load(open(fixed["new"][0]))["all_views_gpu_ms"]["median"]
    print(f"- Without moving objects, against the build before them at a fixed 4 eye rays per pixel "
          f"on the 100K walk (`fixed-*.json`): {old:.2f} ms before, {new:.2f} ms now "
          f"({100 * (new / old - 1):+.1f}%).")
ident = os.path.join(d, "pics-identity.txt")
if os.path.exists(ident):
    lines = open(ident).read().split("\n")
    same = sum(1 for l in lines if l.endswith("identical"))
    print(f"- The documents' GPU pictures made by both builds: {same} of {len([l for l in lines if l])} byte-identical (`pics-identity.txt`).")
print("- The moving objects' pass is their GPU time per frame before the views: skinning, triangles, "
      "refit, and where made once per frame the vertices' direct light and the shadow atlas.")
probed = any("objects_gpu_ms" in (json.load(open(p)).get("fit") or {})
             for p in glob.glob(os.path.join(d, "cave-*.json")))
reserve = ("by the pacer's reserve, made at the fit from the pass as probed (each report's fit "
           "line) and raised by its sustained peaks" if probed else
           "(the pacer's reserve follows its peaks), so a view's time moves as that pass's peaks do")
print("- Limits (120 Hz): every view's GPU p99/p50 <= 1.10, frame max <= 8.33 ms. Paced, the views "
      f"make room for the moving objects' pass {reserve}; see docs/guide/objects.md, "
      "\"What it costs\".")
print()
PY
