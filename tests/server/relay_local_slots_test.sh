#!/usr/bin/env bash
# Several local players through the relay server with real processes on 127.0.0.1 (issue 23;
# the server picks a free port, every wait bounded):
#  1. bad --slot lists exit 2 naming the flag and the slot, before anything starts (client,
#     token; a P2P peer plays one slot);
#  2. an open server, a couch client playing slots 0 and 1 (`--slot 0,1`, one connection) and
#     an online client playing slot 2 play 300 frames of a 3-player match: both complete on
#     the same final checksum, and the server saw two connections, not three;
#  3. a server started with --key: the couch's token lists both slots (`lockroll token --slot
#     0,1`), the online player's names slot 2; the same match completes equal, and the couch
#     presenting a one-slot token is refused (token mismatch).
set -u
lockroll=$1
source "$(dirname "$0")/../process_test_support.sh"

# ---- 1. bad --slot lists: exit 2, before anything starts ----
expect_2 "client: a slot twice" "--slot 0,0: slot 0 is named twice" \
    "$lockroll" client --connect 127.0.0.1:9 --room r --players 3 --slot 0,0 --out "$tmp/o"
expect_2 "client: a slot out of range" "--slot 0,3: slot 3 is out of range 0..2" \
    "$lockroll" client --connect 127.0.0.1:9 --room r --players 3 --slot 0,3 --out "$tmp/o"
expect_2 "client: a spectator of several slots" "a spectator has one id" \
    "$lockroll" client --connect 127.0.0.1:9 --room r --players 3 --slot 3,4 --spectate --out "$tmp/o"
expect_2 "peer: several slots" "a peer plays one slot" \
    "$lockroll" peer --listen 127.0.0.1:0 --players 3 --slot 0,1 --out "$tmp/o"
"$lockroll" token --new-key --key "$tmp/key" >/dev/null || fail "token --new-key"
expect_2 "token: a slot out of range" "--slot 1,2: slot 2 is out of range 0..1" \
    "$lockroll" token --key "$tmp/key" --room r --slot 1,2 --out "$tmp/t"
[ -e "$tmp/o" ] && fail "a bad --slot still created its output directory"
[ -e "$tmp/t" ] && fail "a bad --slot still wrote a token"

# play DIR ROOM [TOKEN0 TOKEN2]: the couch (slots 0,1) and the online player (slot 2), 300
# frames; true when both completed on one final checksum.
play() {
    local dir=$1 room=$2 t0=${3:-} t2=${4:-}
    timeout 120 "$lockroll" client --slot 0,1 --players 3 --connect "127.0.0.1:$server_port" --room "$room" --frames 300 \
        ${t0:+--token "$t0"} --seed 3 --out "$dir/couch" >"$dir/couch.out" 2>&1 &
    local couch=$!
    pids+=("$couch")
    timeout 120 "$lockroll" client --slot 2 --players 3 --connect "127.0.0.1:$server_port" --room "$room" --frames 300 \
        ${t2:+--token "$t2"} --seed 4 --out "$dir/online" >"$dir/online.out" 2>&1 &
    local online=$!
    pids+=("$online")
    local ok=0
    wait "$couch" || { fail "$room: the couch exited $?"; ok=1; }
    wait "$online" || { fail "$room: the online client exited $?"; ok=1; }
    [ "$ok" = 0 ] || return 1
    /usr/bin/python3 - "$dir" <<'PY'
import json, os, sys
base = sys.argv[1]
c = [json.load(open(os.path.join(base, n, "summary.json"))) for n in ("couch", "online")]
assert all(x["outcome"] == "completed" for x in c), [x["outcome"] for x in c]
assert c[0]["final_checksum"] and c[0]["final_checksum"] == c[1]["final_checksum"], [x["final_checksum"] for x in c]
assert c[0]["local_slots"] == [0, 1] and c[1]["local_slots"] == [2], [x["local_slots"] for x in c]
# Everyone's inputs arrived: nobody's stream was replaced for good (a slot not its owner's
# would be replaced on every frame).
assert c[0]["relay"]["replaced_any"] < 100 and c[1]["relay"]["replaced_any"] < 100, [x["relay"] for x in c]
PY
}

# ---- 2. an open server: a couch of two and one online player ----
dir=$tmp/open
mkdir -p "$dir"
start_server "$dir"
if [ -n "$server_port" ]; then
    if play "$dir" couch; then echo "ok: open"; else fail "open"; show_logs "$dir"; fi
    grep -c "joined" "$dir/server.log" | grep -qx 2 || fail "open: the server did not see exactly two connections join: $(grep joined "$dir/server.log")"
fi
kill -TERM "$server_pid" 2>/dev/null

# ---- 3. a keyed server: the couch's token lists both slots ----
dir=$tmp/keyed
mkdir -p "$dir"
"$lockroll" token --key "$tmp/key" --room keyed --players 3 --slot 0,1 --client-id 1 --expires-in 600 --out "$dir/t01" >/dev/null ||
    fail "token for slots 0,1"
"$lockroll" token --key "$tmp/key" --room keyed --players 3 --slot 2 --client-id 2 --expires-in 600 --out "$dir/t2" >/dev/null ||
    fail "token for slot 2"
"$lockroll" token --key "$tmp/key" --room keyed --players 3 --slot 0 --client-id 1 --expires-in 600 --out "$dir/t0" >/dev/null ||
    fail "token for slot 0"
start_server "$dir" --key "$tmp/key"
if [ -n "$server_port" ]; then
    # The couch with a token for slot 0 alone: refused before the room exists.
    timeout 60 "$lockroll" client --slot 0,1 --players 3 --connect "127.0.0.1:$server_port" --room keyed --frames 60 \
        --connect-timeout 10 --token "$dir/t0" --out "$dir/short" >"$dir/short.out" 2>&1 &&
        fail "keyed: a couch with a one-slot token was admitted"
    grep -q "connect token is for another room, slot" "$dir/short/peer.log" ||
        fail "keyed: no mismatch reason in: $(tail -3 "$dir/short/peer.log")"
    if play "$dir" keyed "$dir/t01" "$dir/t2"; then echo "ok: keyed"; else fail "keyed"; show_logs "$dir"; fi
fi
kill -TERM "$server_pid" 2>/dev/null

[ "$failures" = 0 ] && echo "relay local slots: all passed" || echo "relay local slots: $failures failed"
exit $((failures > 0))
