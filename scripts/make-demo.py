#!/usr/bin/env python3
"""Write assets/demo/demo.mid: a 24-second General MIDI drum groove that exercises the kit.

Four bars of a rock beat on closed hi-hat (with an opening on the 'and' of four), a bar of
ride with bell accents, a tom fill, a crash with a choke (polyphonic aftertouch), rim shots and
cross-stick, kick and hi-hat pedal, and velocities from ghost notes to accents. 100 BPM, 480
ticks per beat, SMF type 0, channel 10. No dependencies: the file is written byte by byte.
"""
import struct
import sys

TPB = 480
CH = 9  # channel 10


def vlq(n):
    out = [n & 0x7F]
    n >>= 7
    while n:
        out.insert(0, 0x80 | (n & 0x7F))
        n >>= 7
    return bytes(out)


events = []  # (tick, order, bytes)


def note(tick, key, vel, length=60):
    events.append((tick, 1, bytes([0x90 | CH, key, vel])))
    events.append((tick + length, 0, bytes([0x80 | CH, key, 0])))


def cc4(tick, value):
    events.append((tick, 1, bytes([0xB0 | CH, 4, value])))


def aftertouch(tick, key, pressure):
    events.append((tick, 1, bytes([0xA0 | CH, key, pressure])))


e8 = TPB // 2
bar = 4 * TPB
cc4(0, 127)
# Bars 1-4: rock beat, closed hi-hat eighths, hi-hat opens on the last eighth of bars 2 and 4.
for b in range(4):
    t0 = b * bar
    for i in range(8):
        t = t0 + i * e8
        open_hh = b % 2 == 1 and i == 7
        if open_hh:
            cc4(t - 10, 20)
            note(t, 46, 100)
            cc4(t + e8 - 20, 127)  # the foot closes it again
        else:
            note(t, 42, 95 if i % 2 == 0 else 60)
    for i in (0, 5):
        note(t0 + i * e8, 36, 110)
    note(t0 + 2 * e8, 38, 115)
    note(t0 + 6 * e8, 38, 118)
    note(t0 + 3 * e8 + TPB // 4, 38, 25)  # ghost note
# Bar 5: ride with bell accents, cross-stick backbeat, hi-hat pedal on 2 and 4.
t0 = 4 * bar
for i in range(8):
    note(t0 + i * e8, 53 if i % 4 == 0 else 51, 105 if i % 4 == 0 else 80)
for i in (0, 3, 5):
    note(t0 + i * e8, 36, 100)
for i in (2, 6):
    note(t0 + i * e8, 37, 90)
    note(t0 + i * e8, 44, 70)
# Bar 6: tom fill in sixteenths, snare rim shots at the end.
t0 = 5 * bar
s16 = TPB // 4
fill = [50, 50, 48, 48, 47, 47, 45, 45, 43, 43, 41, 41, 38, 38, 40, 40]
for i, key in enumerate(fill):
    note(t0 + i * s16, key, 70 + 3 * i)
# Bar 7: crash + kick on one, choked on beat two; splash and china; then the groove again.
t0 = 6 * bar
note(t0, 49, 127)
note(t0, 36, 120)
aftertouch(t0 + TPB, 49, 127)
aftertouch(t0 + TPB + 60, 49, 0)
note(t0 + 2 * TPB, 55, 100)
note(t0 + 3 * TPB, 52, 110)
note(t0 + 3 * TPB, 38, 110)
# Bars 8-9: groove on the ride, then a final crash.
for b in (7, 8):
    t0 = b * bar
    for i in range(8):
        note(t0 + i * e8, 51, 90 if i % 2 == 0 else 65)
    for i in (0, 5):
        note(t0 + i * e8, 36, 105)
    note(t0 + 2 * e8, 38, 110)
    note(t0 + 6 * e8, 38, 112)
t0 = 9 * bar
note(t0, 49, 120)
note(t0, 36, 120)
note(t0, 40, 120)

events.sort(key=lambda e: (e[0], e[1]))
track = bytearray()
track += vlq(0) + b"\xff\x51\x03" + (600000).to_bytes(3, "big")  # 100 BPM
track += vlq(0) + b"\xff\x58\x04\x04\x02\x18\x08"
last = 0
for tick, _, data in events:
    track += vlq(tick - last) + data
    last = tick
track += vlq(bar) + b"\xff\x2f\x00"
out = b"MThd" + struct.pack(">IHHH", 6, 0, 1, TPB) + b"MTrk" + struct.pack(">I", len(track)) + bytes(track)
path = sys.argv[1] if len(sys.argv) > 1 else "assets/demo/demo.mid"
with open(path, "wb") as f:
    f.write(out)
print(f"wrote {path}: {len(out)} bytes, {len(events)} events")
