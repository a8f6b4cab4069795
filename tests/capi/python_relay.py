#!/usr/bin/env python3
"""One process of a 2-player match through a relay server, over bindings/python/lockroll.py: the
counter game of python_counter.py, as a player or as a spectator.

    python_relay.py SERVER_PORT ROLE FRAMES

ROLE is 0 or 1 (the slot this process plays) or "spectator" (watches: no slot, the server
places it). A player started again after a crash is started the same way (no join): it rejoins
by snapshot by itself.

Prints "ROLE OUTCOME frame F checksum HEX snapshot S value V" (S: the frame of the snapshot it
loaded, -1 for none); every event goes to stderr as it comes. Exits 0 when the run completed
with a final checksum, 1 when not, 2 on a bad setting (lockroll's message).
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

    def save(self):
        return struct.pack("<q", self.value)

    def load(self, data):
        if len(data) != 8:
            return False
        (self.value,) = struct.unpack("<q", data)
        return True

    def advance(self, inputs, status):
        self.value += 1 + sum(b * (p + 2) for p, b in enumerate(inputs))


def main():
    if len(sys.argv) != 4 or sys.argv[2] not in ("0", "1", "spectator"):
        print("usage: python_relay.py SERVER_PORT (0|1|spectator) FRAMES", file=sys.stderr)
        return 2
    port, role, frames = int(sys.argv[1]), sys.argv[2], int(sys.argv[3])
    game = Counter()
    try:
        builder = (lockroll.Builder().players(2).input_size(1).server("127.0.0.1", port).match_id(0x7e1a7)
                   .frames(frames).timeouts(run_us=60_000_000))
        if role == "spectator":
            builder.server_spectator()  # no slot: the server places this process
        else:
            builder.local_player(int(role))
        session = builder.start(game, 8)
    except lockroll.LockrollError as e:
        print(f"python_relay: {e}", file=sys.stderr)
        return 2
    snapshot = -1
    while True:  # the game's own loop, 100 frames a second
        # A spectator's input is 0 bytes; a player's one byte.
        local = b"" if role == "spectator" else bytes([1 if (session.frame() // 7 + int(role)) % 3 == 0 else 0])
        r = session.update(local)
        for e in session.events():
            if e.name == "snapshot_loaded":
                snapshot = e.frame
                # The binding's typed reason: a joiner loads to join, a spectator to watch.
                want = "spectating" if role == "spectator" else "joining"
                if e.reason != want:
                    print(f"python_relay: snapshot_loaded reason {e.reason}, want {want}", file=sys.stderr)
                    return 1
            print(e, file=sys.stderr, flush=True)
        if r.outcome != lockroll.RUNNING:
            break
        time.sleep(0.01)
    checksum = session.final_checksum()
    print(f"{role} {lockroll.outcome_name(r.outcome)} frame {frames} checksum {checksum or 0:016x} "
          f"snapshot {snapshot} value {game.value}", flush=True)
    session.close()
    return 0 if r.outcome == lockroll.COMPLETED and checksum else 1


if __name__ == "__main__":
    sys.exit(main())
