#!/usr/bin/env python3
"""A 2-player game in Python over bindings/python/lockroll.py: one integer, as examples/c_counter.

    python_counter.py SLOT MY_PORT PEER_PORT FRAMES [DELAY]

DELAY is the input delay (default 2); 0 makes rollbacks, and so the game's load(), certain.

Prints "slot S OUTCOME frame F checksum HEX events N rollbacks R loads L bytes_sent B value V"; exits 0
when the run completed with a final checksum, 2 on a bad setting (lockroll's message).
"""
import os
import struct
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bindings", "python"))
import lockroll  # noqa: E402


class Counter:
    """The whole state: one integer, saved as 8 little-endian bytes."""

    def __init__(self):
        self.value = 0
        self.loads = 0

    def save(self):
        return struct.pack("<q", self.value)

    def load(self, data):
        if len(data) != 8:
            return False  # not one of ours: unchanged
        (self.value,) = struct.unpack("<q", data)
        self.loads += 1
        return True

    def advance(self, inputs, status):
        self.value += 1 + sum(b * (p + 2) for p, b in enumerate(inputs))


def main():
    if len(sys.argv) not in (5, 6):
        print("usage: python_counter.py SLOT MY_PORT PEER_PORT FRAMES [DELAY]", file=sys.stderr)
        return 2
    names = ["SLOT", "MY_PORT", "PEER_PORT", "FRAMES", "DELAY"]
    values = []
    for name, text in zip(names, sys.argv[1:]):
        try:
            values.append(int(text))
        except ValueError:
            print(f"python_counter: {name} must be an integer, got {text!r}", file=sys.stderr)
            return 2
    slot, my_port, peer_port, frames = values[:4]
    delay = values[4] if len(values) == 5 else 2
    game = Counter()
    try:
        session = (lockroll.Builder().players(2).input_size(1).local_player(slot)
                   .remote_player(1 - slot, "127.0.0.1", peer_port).listen("127.0.0.1", my_port)
                   .match_id(0xc0117e4).input_delay(delay).frames(frames).timeouts(connect_us=20_000_000).start(game, 8))
    except lockroll.LockrollError as e:
        print(f"python_counter: {e}", file=sys.stderr)
        return 2
    events = rollbacks = 0
    while True:  # the game's own loop, 100 frames a second
        press = 1 if (session.frame() // 7 + slot) % 3 == 0 else 0
        r = session.update(bytes([press]))
        rollbacks += 1 if r.rollback_depth else 0
        for e in session.events():
            events += 1
            print(e, file=sys.stderr)
        if r.outcome != lockroll.RUNNING:
            break
        time.sleep(0.01)
    checksum = session.final_checksum()
    stats = session.network_stats(1 - slot)
    print(f"slot {slot} {lockroll.outcome_name(r.outcome)} frame {frames} checksum {checksum or 0:016x} "
          f"events {events} rollbacks {rollbacks} loads {game.loads} bytes_sent {stats.bytes_sent} value {game.value}")
    session.close()
    return 0 if r.outcome == lockroll.COMPLETED and checksum else 1


if __name__ == "__main__":
    sys.exit(main())
