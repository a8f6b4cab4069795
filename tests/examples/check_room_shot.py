#!/usr/bin/env python3
"""Checks a screenshot of examples/room (a 24- or 32-bit BMP as SDL_SaveBMP writes it): the room's
walls, the balls and both players must be on it, in the colours room.cpp draws them.
   check_room_shot.py FILE     exit 0 and a summary line, or exit 1 naming what is missing"""
import struct
import sys

COLOURS = {  # name: (r, g, b), fewest pixels expected
    "walls": ((128, 128, 136), 20000),   # four walls of 1 m at 50 px/m: ~ 4 * 700 * 50 / 2 visible
    "balls": ((240, 200, 40), 4000),     # 50 balls of radius 12 px, overlapping at worst
    "player 0": ((60, 120, 255), 300),   # 0.8 m square: 40 x 40 px
    "player 1": ((230, 60, 60), 300),
    "floor": ((28, 30, 40), 100000),
}

def pixels(path):
    data = open(path, "rb").read()
    if data[:2] != b"BM":
        sys.exit(f"{path}: not a BMP")
    offset = struct.unpack_from("<I", data, 10)[0]
    width, height = struct.unpack_from("<ii", data, 18)
    bpp = struct.unpack_from("<H", data, 28)[0]
    if bpp not in (24, 32):
        sys.exit(f"{path}: {bpp} bits per pixel, expected 24 or 32")
    step = bpp // 8
    row = (width * step + 3) & ~3
    for y in range(abs(height)):
        base = offset + y * row
        for x in range(width):
            b, g, r = data[base + x * step: base + x * step + 3]
            yield (r, g, b)

def main():
    counts = {name: 0 for name in COLOURS}
    by_colour = {c: name for name, (c, _) in COLOURS.items()}
    total = 0
    for p in pixels(sys.argv[1]):
        total += 1
        name = by_colour.get(p)
        if name:
            counts[name] += 1
    summary = ", ".join(f"{n} {counts[n]}" for n in COLOURS)
    missing = [n for n, (_, least) in COLOURS.items() if counts[n] < least]
    if missing:
        print(f"{sys.argv[1]}: too few pixels of {', '.join(missing)} ({summary}; {total} in all)")
        return 1
    print(f"{sys.argv[1]}: {summary} of {total} pixels")
    return 0

sys.exit(main())
