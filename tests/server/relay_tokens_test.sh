#!/usr/bin/env bash
# Connect tokens with real processes on 127.0.0.1 (issue 20; free ports, every wait bounded):
#  1. bad flags and files exit 2 before anything starts (lockroll token, client --token,
#     server --key);
#  2. a server started with --key, two clients with tokens from `lockroll token` play 300
#     frames to equal checksums; while they play, a token-less client and a client presenting
#     slot 0's token from another process are refused with their reasons, and exit non-zero;
#     the server's status counts both, and the honest clients complete;
#  3. without --key the server says at start that tokens are off.
set -u
lockroll=$1
source "$(dirname "$0")/../process_test_support.sh"

# ---- 1. bad flags and files: exit 2, before anything starts ----
echo "not hex" >"$tmp/bad.hex"
expect_2 "token: missing key" "key file '$tmp/none' cannot be read" \
    "$lockroll" token --key "$tmp/none" --room r --slot 0 --out "$tmp/t"
expect_2 "client: missing token" "token file '$tmp/none' cannot be read" \
    "$lockroll" client --connect 127.0.0.1:9 --room r --slot 0 --token "$tmp/none" --out "$tmp/o"
expect_2 "client: token not hex" "is not hex text" \
    "$lockroll" client --connect 127.0.0.1:9 --room r --slot 0 --token "$tmp/bad.hex" --out "$tmp/o"
expect_2 "server: key not hex" "is not hex text" "$lockroll" server --listen 127.0.0.1:0 --key "$tmp/bad.hex"
[ -e "$tmp/o" ] && fail "client: a bad --token still created its output directory"

# ---- 2. a keyed server: tokens admit, token-less and replayed hellos are refused ----
dir=$tmp/keyed
mkdir -p "$dir"
"$lockroll" token --new-key --key "$dir/key" >/dev/null || fail "token --new-key"
expect_2 "token: key exists" "exists" "$lockroll" token --new-key --key "$dir/key"
for k in 0 1; do
    "$lockroll" token --key "$dir/key" --room tok --slot $k --client-id $((k + 1)) --expires-in 600 \
        --out "$dir/t$k" >/dev/null || fail "token for slot $k"
done
start_server "$dir" --key "$dir/key"
port=$server_port
for k in 0 1; do
    timeout 120 "$lockroll" client --slot $k --players 2 --connect "127.0.0.1:$port" --room tok --frames 300 \
        --token "$dir/t$k" --out "$dir/c$k" >"$dir/c$k.out" 2>&1 &
    pids+=($!); cpids[$k]=$!
done
for _ in $(seq 200); do grep -q room_started "$dir/server.log" 2>/dev/null && break; sleep 0.1; done
grep -q room_started "$dir/server.log" || fail "the tokened room did not start"
# While the room plays: no token at all, then slot 0's token from another process.
timeout 60 "$lockroll" client --slot 1 --players 2 --connect "127.0.0.1:$port" --room tok --frames 60 \
    --connect-timeout 10 --out "$dir/none" >"$dir/none.out" 2>&1 && fail "a token-less client was admitted"
timeout 60 "$lockroll" client --slot 0 --players 2 --connect "127.0.0.1:$port" --room tok --frames 60 \
    --connect-timeout 10 --token "$dir/t0" --out "$dir/replay" >"$dir/replay.out" 2>&1 &&
    fail "a replayed token was admitted while its holder played"
for k in 0 1; do
    wait "${cpids[$k]}" || { fail "keyed: client $k exit status $?"; tail -5 "$dir/c$k.out"; show_logs "$dir"; }
done
sleep 1.2  # the status file is rewritten every second
if /usr/bin/python3 - "$dir" <<'PY'
import json, os, sys
base = sys.argv[1]
def s(name): return json.load(open(os.path.join(base, name, "summary.json")))
def log(name): return open(os.path.join(base, name)).read()
c = [s("c0"), s("c1")]
assert all(x["outcome"] == "completed" for x in c), [x["outcome"] for x in c]
assert c[0]["final_checksum"] == c[1]["final_checksum"] and c[0]["final_checksum"], c
assert "requires a connect token" in log("none/peer.log"), log("none/peer.log")[-800:]
assert "already in use by a live connection" in log("replay/peer.log"), log("replay/peer.log")[-800:]
server = log("server.log")
assert "connect tokens required" in server, server[:600]
st = json.load(open(os.path.join(base, "status.json")))
assert st["tokens_refused"] >= 1 and st["token_replays"] >= 1, st
PY
then echo "ok: keyed"; else fail "keyed"; show_logs "$dir"; fi
kill -TERM "$server_pid" 2>/dev/null

# ---- 3. without --key: open, and said so at start ----
dir=$tmp/open
mkdir -p "$dir"
"$lockroll" server --listen 127.0.0.1:0 --ready-file "$dir/ready" --run-seconds 1 >"$dir/server.out" 2>"$dir/server.log" &
open_pid=$!
pids+=("$open_pid")
timeout 30 tail --pid="$open_pid" -f /dev/null
grep -q "no --key: connect tokens off" "$dir/server.log" && echo "ok: open" || fail "open: no line saying tokens are off"

[ "$failures" = 0 ] && echo "relay tokens: all passed" || echo "relay tokens: $failures failed"
exit $((failures > 0))
