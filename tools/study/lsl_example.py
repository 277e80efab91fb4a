#!/usr/bin/env python3
"""Reads vlf's Lab Streaming Layer outlets (`vlf cave --lsl`) with pylsl while an experiment
script drives the run, as a lab's recorder would (docs/guide/studies.md).

    python3 tools/study/lsl_example.py HOST:PORT [SECONDS]

HOST:PORT is the run's `--control` address. The script resolves vlf.pose, vlf.frames and
vlf.events, opens an inlet on each, sends an event marker and a trial over the control
connection, reads the streams for SECONDS (default 3), stops the run and reads on until the
last frame has come. It prints one JSON object: LSL's clock when it began and ended, the control
replies, and per stream its description (rate, channel labels) and every sample with its
timestamp. tests/study.rs runs it against a headless run and checks the samples against the
session log. Needs pylsl (`bash tools/setup.sh test` installs it).
"""

import json
import math
import socket
import sys
import time

try:
    import pylsl
except Exception as e:  # ImportError, or a pylsl that cannot load its liblsl
    sys.exit(
        f"lsl_example.py: cannot load pylsl ({e}): `bash tools/setup.sh test` installs it "
        "(or `python3 -m pip install pylsl`; its Linux wheels bring their own liblsl)"
    )

STREAMS = ["vlf.pose", "vlf.frames", "vlf.events"]


def resolve(name, timeout=30.0):
    found = pylsl.resolve_byprop("name", name, 1, timeout)
    if not found:
        sys.exit(f"lsl_example.py: no LSL stream {name} after {timeout:.0f} s: is `vlf cave --lsl` running?")
    return found[0]


def labels(info):
    """The channel labels in a stream's description."""
    out, channel = [], info.desc().child("channels").child("channel")
    while not channel.empty():
        out.append(channel.child_value("label"))
        channel = channel.next_sibling()
    return out


def command(conn, reader, cmd):
    conn.sendall((json.dumps(cmd) + "\n").encode())
    return json.loads(reader.readline())


def clean(value):
    """NaN as None, so that the output is JSON."""
    return None if isinstance(value, float) and math.isnan(value) else value


def main():
    addr = sys.argv[1]
    seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 3.0
    began = pylsl.local_clock()
    inlets = {}
    for name in STREAMS:
        inlet = pylsl.StreamInlet(resolve(name), max_buflen=60)
        inlet.open_stream(10.0)
        inlets[name] = inlet
    out = {name: {"samples": []} for name in STREAMS}
    for name, inlet in inlets.items():
        info = inlet.info(10.0)
        out[name].update(rate=info.nominal_srate(), type=info.type(), labels=labels(info))

    def pull():
        for name, inlet in inlets.items():
            samples, stamps = inlet.pull_chunk(timeout=0.0)
            for s, t in zip(samples, stamps):
                out[name]["samples"].append([t, [clean(v) for v in s]])

    host, port = addr.rsplit(":", 1)
    conn = socket.create_connection((host, int(port)), timeout=60)
    reader = conn.makefile("r")
    replies = [
        command(conn, reader, {"cmd": "event", "text": "lsl check: stimulus on"}),
        command(conn, reader, {"cmd": "trial", "block": 2, "trial": 5}),
    ]
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        pull()
        time.sleep(0.02)
    replies.append(command(conn, reader, {"cmd": "stop"}))
    last = replies[-1]["frame"]
    # on until the stop's frame has come on every stream (it is the run's last)
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        pull()
        frames = out["vlf.frames"]["samples"]
        events = [s[1][0] for s in out["vlf.events"]["samples"]]
        if frames and frames[-1][1][0] == last and any('"stop"' in e for e in events):
            break
        time.sleep(0.02)
    print(json.dumps({"clock": [began, pylsl.local_clock()], "replies": replies, "streams": out}))


if __name__ == "__main__":
    main()
