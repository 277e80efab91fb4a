#!/usr/bin/env python3
"""Switching a study's named conditions from an experiment script (docs/guide/studies.md):
connects to `vlf cave --control ADDR`, asks for the state (the condition in effect), switches to
a condition, shows an unknown name refused (the reply lists the names there are; nothing
changes), asks for the state again and ends the run. Standard library only. Prints every reply
as a JSON line.

    python3 tools/study/conditions_example.py 127.0.0.1:7400 [CONDITION]

CONDITION defaults to gi-off (config/displays/cave-4wall-conditions.toml has gi-on, gi-off and
gi-on-dim). With --every N --times K it switches instead between all the conditions the display
has, cycling K times, one switch every N frames (tools/gpu-conditions.sh measures the frame
times around the switches), and then ends the run.
"""

import argparse
import json
import socket
import sys


def connect(addr: str):
    host, port = addr.rsplit(":", 1)
    sock = socket.create_connection((host, int(port)), timeout=600)
    stream = sock.makefile("rw", encoding="utf-8", newline="\n")

    def send(command: dict) -> dict:
        stream.write(json.dumps(command) + "\n")
        stream.flush()
        line = stream.readline()
        if not line:
            raise EOFError("vlf closed the connection: the run ended (its --frames)")
        reply = json.loads(line)
        print(json.dumps({"sent": command, "reply": reply}), flush=True)
        return reply

    return sock, send


def names_from_refusal(send) -> list:
    """The display's condition names, as the refusal of an unknown one lists them."""
    error = send({"cmd": "condition", "name": "no-such-condition"})["error"]
    listed = error.split("names: ", 1)[1].rstrip(")")
    return [n.strip() for n in listed.split(",")]


def cycle(send, every: int, times: int) -> None:
    """Switch through every condition `times` times, a switch every `every` frames."""
    names = names_from_refusal(send)
    frame = send({"cmd": "state"})["frame"]
    for _ in range(times):
        for name in names[1:] + names[:1]:
            # wait (by asking for the state) until `every` frames have passed since the last
            while send({"cmd": "state"})["frame"] < frame + every:
                pass
            frame = send({"cmd": "condition", "name": name})["frame"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("addr", help="what `vlf cave --control` printed, HOST:PORT")
    parser.add_argument("condition", nargs="?", default="gi-off")
    parser.add_argument("--every", type=int, help="cycle: a switch every N frames")
    parser.add_argument("--times", type=int, default=1, help="cycle: this many rounds")
    args = parser.parse_args()
    sock, send = connect(args.addr)
    with sock:
        if args.every:
            try:
                cycle(send, args.every, args.times)
            except EOFError as e:
                print(f"conditions_example.py: {e}", file=sys.stderr)
                return
        else:
            send({"cmd": "state"})
            send({"cmd": "condition", "name": args.condition})
            send({"cmd": "condition", "name": "sepia"})  # refused: nothing changes
            send({"cmd": "state"})
        send({"cmd": "stop"})


if __name__ == "__main__":
    main()
