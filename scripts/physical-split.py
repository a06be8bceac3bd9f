#!/usr/bin/env python3
"""The physical render's measures over a Groove MIDI split (DESIGN.md section 5).

Runs `examples/physical_probe` (JSON=1) on every take of the split in data/gmd/info.csv,
two processes at once, and prints recall, precision, timing, IPD, the Spearman correlation
of velocity with contact speed, the deepest stick and the worst five takes.

    cargo build --release --example physical_probe
    python3 scripts/physical-split.py [validation|train] [KIT]
    python3 scripts/physical-split.py --rows FILE ...   (lines of JSON=1 physical_probe)
"""
import csv
import json
import math
import os
import subprocess
import sys

args = sys.argv[1:]
rows = []
if args[:1] == ["--rows"]:
    # Aggregate lines an earlier run printed (JSON=1 physical_probe ... > FILE).
    split, kit = "(given rows)", "(as run)"
    for path in args[1:]:
        with open(path) as f:
            rows += [json.loads(line) for line in f if line.startswith("{")]
else:
    split = args[0] if len(args) > 0 else "validation"
    kit = args[1] if len(args) > 1 else "default"
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with open(os.path.join(root, "data/gmd/info.csv"), newline="") as f:
        takes = [os.path.join("data/gmd", r["midi_filename"]) for r in csv.DictReader(f) if r["split"].strip() == split]
    probe = os.path.join(root, "target/release/examples/physical_probe")
    env = dict(os.environ, JSON="1", KIT=kit)
    jobs = [subprocess.Popen([probe, *takes[i::2]], cwd=root, env=env, stdout=subprocess.PIPE, text=True) for i in range(2)]
    for j in jobs:
        out, _ = j.communicate()
        rows += [json.loads(line) for line in out.splitlines() if line.startswith("{")]


def ranks(x):
    order = sorted(range(len(x)), key=lambda i: x[i])
    r = [0.0] * len(x)
    i = 0
    while i < len(order):
        k = i
        while k + 1 < len(order) and x[order[k + 1]] == x[order[i]]:
            k += 1
        for m in order[i : k + 1]:
            r[m] = (i + k) / 2 + 1
        i = k + 1
    return r


def spearman(a, b):
    ra, rb = ranks(a), ranks(b)
    ma, mb = sum(ra) / len(ra), sum(rb) / len(rb)
    cov = sum((x - ma) * (y - mb) for x, y in zip(ra, rb))
    return cov / math.sqrt(sum((x - ma) ** 2 for x in ra) * sum((y - mb) ** 2 for y in rb))


notes = sum(r["notes"] for r in rows)
hit = sum(r["hit"] for r in rows)
contacts = sum(r["contacts"] for r in rows)
spurious = sum(r["spurious"] for r in rows)
errs = [e for r in rows for e in r["timing_ms"]]
mean = sum(errs) / len(errs)
sd = math.sqrt(sum((e - mean) ** 2 for e in errs) / len(errs))
abs_sorted = sorted(abs(e) for e in errs)
ipd = sorted(x for r in rows for x in r["ipd_mm"])
# As `drumsim eval`: the left foot's chick closes the hi-hat at CHICK_SPEED_SCALE (src/kit/mod.rs)
# of the speed map's speed by design; scaled back, it ranks with the sticks and the beater.
CHICK_SPEED_SCALE = 0.4
vs = [[p[0], p[1] / CHICK_SPEED_SCALE if len(p) > 2 and p[2] == "LeftFoot" else p[1], *p[2:]] for r in rows for p in r["vel_speed"]]
seconds = sum(r["seconds"] for r in rows)
wall = sum(r["wall_s"] for r in rows)
print(f"{len(rows)} takes of {split} on kit {kit}, {seconds / 60:.1f} min of playing, body at {seconds / wall:.1f}x real time")
print(f"recall {100 * hit / notes:.2f} % ({hit} of {notes} notes), precision {100 * (contacts - spurious) / contacts:.2f} % ({spurious} of {contacts} contacts played no note)")
print(f"timing mean {mean:+.2f} ms, sd {sd:.2f} ms, p95 |err| {abs_sorted[int(0.95 * len(abs_sorted)) - 1]:.2f} ms")
print(f"IPD mean {sum(ipd) / len(ipd):.1f} mm, p95 {ipd[int(0.95 * len(ipd)) - 1]:.1f} mm (sticks)")
print(f"velocity-speed Spearman {spearman([p[0] for p in vs], [p[1] for p in vs]):.3f}", end="")
# Rows from the current probe also name the limb and whether the contact was a hoop's.
sticks = [p for p in vs if len(p) > 2 and "Hand" in p[2]]
print(f" (sticks alone {spearman([p[0] for p in sticks], [p[1] for p in sticks]):.3f})" if len(sticks) > 2 else "")
for limb in ["LeftHand", "RightHand", "RightFoot", "LeftFoot"]:
    of = [p for p in vs if len(p) > 2 and p[2] == limb]
    if len(of) > 2:
        print(f"  {limb}: {spearman([p[0] for p in of], [p[1] for p in of]):.3f} over {len(of)} notes")
print(f"deepest stick {max(r['sank_mm'] for r in rows):.1f} mm; all finite: {all(r['finite'] for r in rows)}; largest energy {max(r['energy_j'] for r in rows):.0f} J")
worst = sorted(rows, key=lambda r: r["hit"] / max(r["notes"], 1))[:5]
for r in worst:
    print(f"  worst: {r['take'].removeprefix('data/gmd/')}: {100 * r['hit'] / max(r['notes'], 1):.1f} % of {r['notes']} notes")
below = sum(1 for r in rows if r["hit"] < 0.97 * r["notes"])
print(f"takes below 97 % recall: {below}")
