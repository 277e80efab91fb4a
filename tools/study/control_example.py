#!/usr/bin/env python3
"""A minimal experiment script for `vlf cave --control ADDR` (docs/guide/studies.md): connects,
starts block 1 trial 1, marks it, teleports the room, asks for the state, shows a refused command, and ends the run.
Each command is one JSON object per line; each reply is one JSON line with the frame number the
command took effect in (or ok: false and the reason). Prints every reply as a JSON line.

    python3 tools/study/control_example.py 127.0.0.1:7400
"""

import json
import socket
import sys


def main(addr: str) -> None:
    host, port = addr.rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=120) as sock:
        stream = sock.makefile("rw", encoding="utf-8", newline="\n")

        def send(command: dict) -> dict:
            stream.write(json.dumps(command) + "\n")
            stream.flush()
            reply = json.loads(stream.readline())
            print(json.dumps({"sent": command, "reply": reply}), flush=True)
            return reply

        send({"cmd": "state"})
        send({"cmd": "trial", "block": 1, "trial": 1})
        send({"cmd": "event", "text": "trial 1 begins"})
        send({"cmd": "teleport", "position": [0.5, 0.0, 0.25], "yaw_deg": 30.0})
        send({"cmd": "fly", "to": "the moon"})  # refused: nothing changes
        send({"cmd": "state"})
        send({"cmd": "event", "text": "trial 1 ends"})
        send({"cmd": "stop"})


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: control_example.py HOST:PORT (what `vlf cave --control` printed)")
    main(sys.argv[1])
