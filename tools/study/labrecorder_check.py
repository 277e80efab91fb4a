#!/usr/bin/env python3
"""Records vlf's Lab Streaming Layer outlets with LabRecorder into an XDF file and loads it with
pyxdf, as a lab does (docs/guide/studies.md), then checks the file against the session log.

    python3 tools/study/labrecorder_check.py VLF LIGHT_FIELD OUT_DIR [--seconds S]
        [--labrecorder target/labrecorder/LabRecorderCLI]

VLF is the vlf binary, LIGHT_FIELD a .vlf or scene.toml for the run. The script writes a one-wall
display at 10 Hz walking a scripted path with a wand (and an lsl_api.cfg: IPv4 only), starts `vlf cave --headless --lsl --control --log`, starts LabRecorderCLI on
vlf.pose, vlf.frames and vlf.events, sends an event marker, lets the run go for S seconds
(default 5), stops it, ends the recording and loads OUT_DIR/session.xdf with pyxdf. It checks:
the three streams are in the file with their declared rates and channel counts; every pose sample
is its frame's row of the session log (frames.csv), value for value; frame numbers rise by one;
the event marker is there. It prints a JSON summary and writes it to OUT_DIR/labrecorder.json;
the exit code is 0 only when every check holds. Needs LabRecorderCLI
(`bash tools/study/get-labrecorder.sh`) and pyxdf (`python3 -m pip install pyxdf`).
"""

import argparse
import csv
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

POSE_COLUMNS = [
    "head_x", "head_y", "head_z", "head_qx", "head_qy", "head_qz", "head_qw",
    "wand_x", "wand_y", "wand_z", "wand_qx", "wand_qy", "wand_qz", "wand_qw",
    "room_x", "room_y", "room_z", "room_yaw_deg",
]
MARKER = "labrecorder check: stimulus on"


def write_display(out: Path):
    """The display, its walk and the machine-scoped LSL configuration; returns their paths."""
    walk = out / "walk.toml"
    walk.write_text(
        "[[keyframe]]\nt = 0.0\nhead = [0.0, 1.2, 0.3]\nposition = [0.0, 0.0, 2.2]\nyaw_deg = 0.0\n"
        "wand_position = [0.25, 1.0, 0.0]\nwand_yaw_deg = 25.0\nwand_pitch_deg = 12.0\n"
        "[[keyframe]]\nt = 6.0\nhead = [0.1, 1.1, 0.2]\nposition = [0.2, -0.1, 0.5]\nyaw_deg = 24.0\n"
        "wand_position = [0.3, 1.1, -0.1]\nwand_yaw_deg = 5.0\nwand_pitch_deg = -10.0\n"
    )
    display = out / "display.toml"
    display.write_text(
        'name = "labrecorder-check"\nrefresh_hz = 10\n[start_pose]\nposition = [0.0, 0.0, 2.2]\n'
        f'[tracking]\nsource = "scripted"\npath = "{walk}"\n[[wall]]\nname = "front"\n'
        "lower_left = [-0.3, 1.13, 0.0]\nlower_right = [0.3, 1.13, 0.0]\n"
        "upper_left = [-0.3, 1.47, 0.0]\npixels = [64, 36]\n"
        "output = { monitor = 0, window = [100, 100] }\n"
    )
    # IPv4 only; LSL's default resolve scope (liblsl 1.13, which the recorder built by
    # get-labrecorder.sh shares with vlf, finds only one of a process's outlets at machine scope)
    cfg = out / "lsl_api.cfg"
    cfg.write_text("[ports]\nIPv6 = disable\n")
    return display, cfg


def control_address(run):
    """The address `vlf cave --control 127.0.0.1:0` says it listens on."""
    said = []
    for line in run.stderr:
        if line.startswith("control: listening on "):
            return line.split("control: listening on ", 1)[1].strip()
        said.append(line)
    sys.exit("labrecorder_check.py: vlf cave ended without saying where it listens:\n" + "".join(said[-10:]))


def command(conn, reader, cmd):
    conn.sendall((json.dumps(cmd) + "\n").encode())
    return json.loads(reader.readline())


def record(args, out: Path, env):
    """Runs vlf and LabRecorderCLI together; returns the event's reply and the log directory."""
    display, _ = write_display(out)
    log_dir = out / "log"
    run = subprocess.Popen(
        [args.vlf, "cave", str(display), "--headless", "--lsl", "--frames", "100000",
         "--control", "127.0.0.1:0", "--scene", args.light_field, "--log", str(log_dir),
         "--out", str(out / "frames")],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    addr = control_address(run)
    xdf = out / "session.xdf"
    # the outlets open once the run's light field is on the GPU: ask again until LabRecorder
    # finds all three (it resolves for one second each time)
    for attempt in range(30):
        recorder = subprocess.Popen(
            [args.labrecorder, str(xdf), 'name="vlf.pose"', 'name="vlf.frames"', 'name="vlf.events"'],
            env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        )
        missing = None
        for line in recorder.stdout:
            if "Starting the recording" in line:
                break
            if "matched no stream" in line:
                missing = line.strip()
        if missing is None:
            break
        recorder.wait()
        time.sleep(0.5)
    else:
        run.kill()
        sys.exit(f"labrecorder_check.py: LabRecorderCLI after 30 tries: {missing}")
    time.sleep(1.0)
    host, port = addr.rsplit(":", 1)
    with socket.create_connection((host, int(port))) as conn:
        reader = conn.makefile("r")
        reply = command(conn, reader, {"cmd": "event", "text": MARKER})
        time.sleep(args.seconds)
        command(conn, reader, {"cmd": "stop"})
    run.wait(timeout=60)
    # the last samples reach the recorder's inlets before it closes the file
    time.sleep(2.0)
    recorder.communicate("\n", timeout=60)
    return reply, log_dir, xdf


def log_rows(log_dir: Path):
    with open(log_dir / "frames.csv", newline="") as f:
        return {int(r["frame"]): r for r in csv.DictReader(f)}


def check(xdf: Path, rows, reply):
    """The checks on the XDF file; returns (summary, failures)."""
    import pyxdf

    streams, header = pyxdf.load_xdf(str(xdf), dejitter_timestamps=False)
    by_name = {s["info"]["name"][0]: s for s in streams}
    failures, summary = [], {"xdf": str(xdf), "streams": {}}
    for name, rate, channels in [("vlf.pose", 10.0, 20), ("vlf.frames", 10.0, 6), ("vlf.events", 0.0, 1)]:
        s = by_name.get(name)
        if s is None:
            failures.append(f"{name} is not in the XDF file")
            continue
        info = s["info"]
        got = (float(info["nominal_srate"][0]), int(info["channel_count"][0]))
        stamps = s["time_stamps"]
        summary["streams"][name] = {"nominal_srate": got[0], "channel_count": got[1], "samples": len(stamps)}
        if got != (rate, channels):
            failures.append(f"{name}: rate and channels {got}, declared {(rate, channels)}")
    if failures:
        return summary, failures
    pose = by_name["vlf.pose"]
    values = pose["time_series"]
    stamps = pose["time_stamps"]
    import numpy as np

    mismatched = 0
    for sample in values:
        # the stream's channels are float32, as the log's columns (written in the shortest form
        # that reads back to the same float32)
        row = rows.get(int(sample[19]))
        logged = None if row is None else np.array([np.float32(row[c]) for c in POSE_COLUMNS])
        if logged is None or not np.array_equal(np.asarray(sample[:18], dtype=np.float32), logged):
            mismatched += 1
    span = stamps[-1] - stamps[0] if len(stamps) > 1 else 0.0
    rate = (len(stamps) - 1) / span if span > 0 else 0.0
    summary["pose"] = {"samples": len(values), "rate_hz": rate, "mismatched_against_frames_csv": mismatched}
    if len(values) < 20 or mismatched or abs(rate - 10.0) > 1.0:
        failures.append(f"pose stream: {len(values)} samples at {rate:.2f} Hz, {mismatched} unlike frames.csv")
    frames = [int(v[0]) for v in by_name["vlf.frames"]["time_series"]]
    if any(b != a + 1 for a, b in zip(frames, frames[1:])):
        failures.append("vlf.frames: frame numbers do not rise by one")
    events = [e[0] for e in by_name["vlf.events"]["time_series"]]
    summary["events"] = len(events)
    summary["event_frame"] = reply.get("frame")
    if MARKER not in events:
        failures.append(f"the event marker {MARKER!r} is not on vlf.events")
    return summary, failures


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("vlf")
    p.add_argument("light_field")
    p.add_argument("out_dir")
    p.add_argument("--seconds", type=float, default=5.0)
    p.add_argument("--labrecorder", default="target/labrecorder/LabRecorderCLI")
    args = p.parse_args()
    if not os.access(args.labrecorder, os.X_OK):
        sys.exit(f"labrecorder_check.py: no LabRecorderCLI at {args.labrecorder}: "
                 "`bash tools/study/get-labrecorder.sh` builds it")
    try:
        import pyxdf  # noqa: F401
    except ImportError:
        sys.exit("labrecorder_check.py: pyxdf is missing: `python3 -m pip install pyxdf`")
    out = Path(args.out_dir).resolve()
    if (out / "log").exists() or (out / "session.xdf").exists():
        sys.exit(f"labrecorder_check.py: {out} holds an earlier check's log or XDF file: name a new directory")
    out.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, LSLAPICFG=str(out / "lsl_api.cfg"))
    lib = str(Path(args.labrecorder).resolve().parent)
    env["LD_LIBRARY_PATH"] = lib + (":" + env["LD_LIBRARY_PATH"] if env.get("LD_LIBRARY_PATH") else "")
    reply, log_dir, xdf = record(args, out, env)
    summary, failures = check(xdf, log_rows(log_dir), reply)
    summary["failures"] = failures
    text = json.dumps(summary, indent=2)
    (out / "labrecorder.json").write_text(text + "\n")
    print(text)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
