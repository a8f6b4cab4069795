#!/usr/bin/env python3
"""Checks a screenshot of examples/room (a 24- or 32-bit BMP as SDL_SaveBMP writes it): the room's
walls, the balls and both players must be on it, in the colours room.cpp draws them; with
--overlay, the overlay's words too: each "overlay X Y W H WORDS" line the room printed for that
frame names a rectangle that must hold the light grey pixels of that many letters (SDL2_ttf's
anti-aliased text: about 24 per letter at 15 points; at least 8 are asked for).
   check_room_shot.py FILE [--overlay ROOM_STDOUT]
       exit 0 and a summary line, or exit 1 naming what is missing"""
import struct
import sys

COLOURS = {  # name: (r, g, b), fewest pixels expected
    "walls": ((128, 128, 136), 20000),   # four walls of 1 m at 50 px/m: ~ 4 * 700 * 50 / 2 visible
    "balls": ((240, 200, 40), 4000),     # 50 balls of radius 12 px, overlapping at worst
    "player 0": ((60, 120, 255), 300),   # 0.8 m square: 40 x 40 px
    "player 1": ((230, 60, 60), 300),
    "floor": ((28, 30, 40), 100000),
}
LIT_PER_LETTER = 8


class Image:
    def __init__(self, path):
        data = open(path, "rb").read()
        if data[:2] != b"BM":
            sys.exit(f"{path}: not a BMP")
        self.data = data
        self.offset = struct.unpack_from("<I", data, 10)[0]
        self.width, height = struct.unpack_from("<ii", data, 18)
        self.bottom_up = height > 0
        self.height = abs(height)
        bpp = struct.unpack_from("<H", data, 28)[0]
        if bpp not in (24, 32):
            sys.exit(f"{path}: {bpp} bits per pixel, expected 24 or 32")
        self.step = bpp // 8
        self.row = (self.width * self.step + 3) & ~3

    def pixel(self, x, y):
        """(r, g, b) at column x, row y counted from the top."""
        stored = self.height - 1 - y if self.bottom_up else y
        base = self.offset + stored * self.row + x * self.step
        b, g, r = self.data[base: base + 3]
        return (r, g, b)

    def pixels(self):
        for y in range(self.height):
            for x in range(self.width):
                yield self.pixel(x, y)


def lit(p):
    """A pixel of the overlay's text: light and grey (its bars are dark grey and green, its
    background the floor's dark blue)."""
    return min(p) >= 150 and max(p) - min(p) <= 24


def check_overlay(image, room_stdout):
    """Problems with the overlay's words, and a summary of what was found."""
    problems, found = [], []
    for line in open(room_stdout):
        if not line.startswith("overlay "):
            continue
        fields = line.rstrip("\n").split(" ", 5)
        if len(fields) != 6:
            problems.append(f"unreadable overlay line {line.strip()!r}")
            continue
        x, y, w, h = map(int, fields[1:5])
        words = fields[5]
        letters = sum(1 for c in words if not c.isspace())
        if x < 0 or y < 0 or w <= 0 or h <= 0 or x + w > image.width or y + h > image.height:
            problems.append(f"{words!r} drawn outside the window ({x},{y} {w}x{h})")
            continue
        count = sum(1 for yy in range(y, y + h) for xx in range(x, x + w) if lit(image.pixel(xx, yy)))
        found.append(f"{words!r} {count}")
        if count < LIT_PER_LETTER * letters:
            problems.append(f"{words!r}: {count} text pixels at {x},{y} {w}x{h}, fewer than {LIT_PER_LETTER} "
                            f"for each of its {letters} letters")
    if not found and not problems:
        problems.append(f"{room_stdout} has no overlay lines (the room drew no words)")
    return problems, ", ".join(found)


def main():
    args = sys.argv[1:]
    overlay = None
    if len(args) == 3 and args[1] == "--overlay":
        overlay = args[2]
    elif len(args) != 1:
        sys.exit("usage: check_room_shot.py FILE [--overlay ROOM_STDOUT]")
    path = args[0]
    image = Image(path)
    counts = {name: 0 for name in COLOURS}
    by_colour = {c: name for name, (c, _) in COLOURS.items()}
    total = 0
    for p in image.pixels():
        total += 1
        name = by_colour.get(p)
        if name:
            counts[name] += 1
    summary = ", ".join(f"{n} {counts[n]}" for n in COLOURS)
    missing = [n for n, (_, least) in COLOURS.items() if counts[n] < least]
    if missing:
        print(f"{path}: too few pixels of {', '.join(missing)} ({summary}; {total} in all)")
        return 1
    if overlay:
        problems, words = check_overlay(image, overlay)
        if problems:
            print(f"{path}: overlay: " + "; ".join(problems))
            return 1
        summary += f"; overlay text pixels: {words}"
    print(f"{path}: {summary} of {total} pixels")
    return 0


sys.exit(main())
