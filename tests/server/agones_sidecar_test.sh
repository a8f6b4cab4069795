#!/usr/bin/env bash
# server/agones/agones-sidecar.sh against a stand-in for the Agones SDK server (a small HTTP
# server on 127.0.0.1 that records every request) and a status file in lockroll-server's own
# format (taken from a real lockroll-server, then edited step by step):
#  1. a fresh "ready" file: the sidecar says Ready (once) and Health (every period);
#  2. rooms_closed grows by 3: it asks the `rooms` Counter for countDiff -3; the SDK refuses the
#     first try, so it must retry, and give back 3 in all, not 6;
#  3. rooms_closed grows by 2 more: countDiff -2;
#  4. "draining" with 0 rooms: Shutdown, and the sidecar exits 0.
# Everything bounded by timeouts; loopback only.
set -u
server=$1
sidecar=$2
source "$(dirname "$0")/../process_test_support.sh"
command -v curl >/dev/null || { echo "FAIL: curl is not installed (scripts/install-deps.sh installs it)"; exit 1; }

# The status file, as lockroll-server writes it: start one, keep its file, stop it (it drains at
# once: no rooms).
"$server" --listen 127.0.0.1:0 --ready-file "$tmp/ready" --status-file "$tmp/real.json" >"$tmp/server.log" 2>&1 &
spid=$!
pids+=("$spid")
for _ in $(seq 100); do [ -s "$tmp/real.json" ] && break; sleep 0.1; done
[ -s "$tmp/real.json" ] || { echo "FAIL: lockroll-server wrote no status file"; cat "$tmp/server.log"; exit 1; }
kill -TERM "$spid"
wait "$spid" 2>/dev/null
grep -q '"rooms_closed": 0' "$tmp/real.json" || fail "status file has no rooms_closed field: $(cat "$tmp/real.json")"
# status STATE ROOMS CLOSED: rewrite the file the sidecar reads, atomically as the server does.
status() {
    sed -e "s/\"state\": \"[a-z]*\"/\"state\": \"$1\"/" -e "s/\"rooms\": [0-9]*/\"rooms\": $2/" \
        -e "s/\"rooms_closed\": [0-9]*/\"rooms_closed\": $3/" "$tmp/real.json" >"$tmp/status.tmp"
    mv "$tmp/status.tmp" "$tmp/status.json"
}

# The SDK stand-in: logs "METHOD PATH BODY" per request; the first counter PATCH gets a 500.
cat >"$tmp/sdk.py" <<'PY'
import http.server, sys
log = open(sys.argv[1], "a", buffering=1)
patches = 0
class H(http.server.BaseHTTPRequestHandler):
    def handle_one(self, method):
        global patches
        body = self.rfile.read(int(self.headers.get("Content-Length", 0))).decode()
        log.write(f"{method} {self.path} {body}\n")
        code = 200
        if method == "PATCH":
            patches += 1
            code = 500 if patches == 1 else 200
        self.send_response(code)
        self.send_header("Content-Length", "2")
        self.end_headers()
        self.wfile.write(b"{}")
    def do_POST(self): self.handle_one("POST")
    def do_PATCH(self): self.handle_one("PATCH")
    def log_message(self, *a): pass
s = http.server.HTTPServer(("127.0.0.1", 0), H)
open(sys.argv[2], "w").write(str(s.server_address[1]))
s.serve_forever()
PY
python3 "$tmp/sdk.py" "$tmp/requests.log" "$tmp/sdk.port" &
pids+=($!)
for _ in $(seq 50); do [ -s "$tmp/sdk.port" ] && break; sleep 0.1; done
sdk_port=$(cat "$tmp/sdk.port" 2>/dev/null)
[ -n "$sdk_port" ] || { echo "FAIL: SDK stand-in did not start"; exit 1; }

status ready 0 0
LOCKROLL_STATUS_FILE="$tmp/status.json" AGONES_SDK_HTTP_PORT=$sdk_port LOCKROLL_HEALTH_PERIOD_S=0.2 \
    sh "$sidecar" 2>"$tmp/sidecar.log" &
side=$!
pids+=("$side")

# wait_for PATTERN COUNT: until requests.log has COUNT lines matching PATTERN (10 s at most).
wait_for() {
    for _ in $(seq 100); do [ "$(grep -c -- "$1" "$tmp/requests.log" 2>/dev/null)" -ge "$2" ] && return 0; sleep 0.1; done
    return 1
}

wait_for "POST /ready" 1 || fail "no Ready"
wait_for "POST /health" 3 || fail "no periodic Health"
status ready 4 3
wait_for "PATCH /v1beta1/counters/rooms" 2 || fail "no retried Counter update after 3 rooms closed"
status ready 2 5
wait_for '"countDiff": "-2"' 1 || fail "no Counter update of -2 after 2 more rooms closed"
status draining 0 5
wait_for "POST /shutdown" 1 || fail "no Shutdown after draining with 0 rooms"
for _ in $(seq 50); do kill -0 "$side" 2>/dev/null || break; sleep 0.1; done
if kill -0 "$side" 2>/dev/null; then fail "sidecar still running after Shutdown"; else
    wait "$side"; rc=$?; [ "$rc" -eq 0 ] || fail "sidecar exited $rc"; fi

# Exactly what was asked of the Counter: -3 refused, -3 again, then -2 (5 rooms in all, once).
got=$(grep PATCH "$tmp/requests.log" | sed 's/.*"countDiff": "\(-[0-9]*\)".*/\1/' | tr '\n' ' ')
[ "$got" = "-3 -3 -2 " ] || fail "Counter updates were '$got', expected '-3 -3 -2 '"
[ "$(grep -c 'POST /ready' "$tmp/requests.log")" -eq 1 ] || fail "Ready sent more than once"

if [ "$failures" -ne 0 ]; then
    echo "--- requests"; cat "$tmp/requests.log"; echo "--- sidecar"; cat "$tmp/sidecar.log"
    exit 1
fi
echo "agones sidecar: Ready, Health, Counter given back 5 rooms (one retry), Shutdown"
