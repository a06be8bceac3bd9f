#!/usr/bin/env python3
"""A VMC protocol receiver (marionette) on python-osc, for drumsim's tests and for a user who
wants to see what `drumsim render --vmc` or `drumsim live --vmc` sends.

    python3 scripts/vmc-receive.py [--port 39539] [--quiet-s 2] [--max-s 120] [--out frames.json]

It prints the port it listens on (0 picks a free one) as its first line, then receives until
the sender has been quiet for --quiet-s after its first message (or --max-s has passed), and
writes every frame it received (one per /VMC/Ext/T, the message that ends a frame) as JSON:
{"frames": [{"arrival_s", "t", "ok", "root", "bones": {name: [px, py, pz, qx, qy, qz, qw]},
"blend": {name: value}, "applied"}], "messages": count, "unknown": [addresses]}.
Needs `pip install python-osc` (scripts/setup-debian.sh installs it into
/opt/drumsim-python).
"""
import argparse
import json
import socket
import sys
import time

from pythonosc import dispatcher, osc_server


def grow_receive_buffer(sock, size):
    """Ask for `size` bytes of receive buffer: past net.core.rmem_max where allowed (root)."""
    so_rcvbufforce = getattr(socket, "SO_RCVBUFFORCE", 33)
    try:
        sock.setsockopt(socket.SOL_SOCKET, so_rcvbufforce, size)
    except OSError:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, size)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=39539)
    ap.add_argument("--quiet-s", type=float, default=2.0)
    ap.add_argument("--max-s", type=float, default=120.0)
    ap.add_argument("--out", default="-")
    args = ap.parse_args()

    frames = []
    state = {"frame": None, "messages": 0, "first": None, "last": None, "unknown": set()}

    def current():
        if state["frame"] is None:
            state["frame"] = {"bones": {}, "blend": {}, "root": None, "ok": None, "applied": False}
        return state["frame"]

    def on_message(address, *values):
        now = time.monotonic()
        state["messages"] += 1
        state["first"] = state["first"] or now
        state["last"] = now
        f = current()
        if address == "/VMC/Ext/Bone/Pos":
            f["bones"][values[0]] = list(values[1:8])
        elif address == "/VMC/Ext/Root/Pos":
            f["root"] = list(values[1:8])
        elif address == "/VMC/Ext/Blend/Val":
            f["blend"][values[0]] = values[1]
        elif address == "/VMC/Ext/Blend/Apply":
            f["applied"] = True
        elif address == "/VMC/Ext/OK":
            f["ok"] = values[0]
        elif address == "/VMC/Ext/T":
            f["t"] = values[0]
            f["arrival_s"] = now
            frames.append(f)
            state["frame"] = None
        else:
            state["unknown"].add(address)

    d = dispatcher.Dispatcher()
    d.set_default_handler(on_message)
    server = osc_server.BlockingOSCUDPServer((args.host, args.port), d)
    server.max_packet_size = 65535
    # A frame is about 110 messages, 60 frames a second: a receiver descheduled for a moment
    # on a busy machine must not lose datagrams to the kernel's default 208 KB buffer.
    grow_receive_buffer(server.socket, 16 << 20)
    server.timeout = 0.05
    print(server.server_address[1], flush=True)
    start = time.monotonic()
    while True:
        server.handle_request()
        now = time.monotonic()
        if now - start > args.max_s:
            break
        if state["last"] is not None and now - state["last"] > args.quiet_s:
            break
    server.server_close()
    t0 = frames[0]["arrival_s"] if frames else 0.0
    for f in frames:
        f["arrival_s"] -= t0
    out = {"frames": frames, "messages": state["messages"], "unknown": sorted(state["unknown"])}
    text = json.dumps(out)
    if args.out == "-":
        sys.stdout.write(text + "\n")
    else:
        with open(args.out, "w") as fh:
            fh.write(text)
    print(f"received {len(frames)} frames, {state['messages']} messages", file=sys.stderr)


if __name__ == "__main__":
    main()
