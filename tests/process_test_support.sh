# Sourced by the shell tests that start real processes (tests/net, tests/server): a scratch
# directory, the processes to kill when the test ends however it ends, and failure counting.
#   tmp       scratch directory, removed at exit (KEEP=1 keeps it and says where)
#   pids      add every background process: it is killed (-9) at exit
#   fail MSG  prints FAIL: MSG and counts it; `failures` holds the count
#   show_logs DIR   the last lines of every process log under DIR (server.log, peer.log,
#                   *.stderr.log), and the first lines of any sanitizer report in it, so a
#                   failure can be diagnosed from CI's output alone
#   expect_2 WHAT MESSAGE COMMAND...   COMMAND exits 2 printing MESSAGE (bad flags), else fail
#   start_relay_server [--stderr PATH] DIR COMMAND...   a relay server, COMMAND (`"$lockroll"
#                   server [ARGS...]` or `"$server_exe" [ARGS...]`) given --listen on a free port
#                   of 127.0.0.1 and its ready and status files in DIR (its output in
#                   DIR/server.out, its log in DIR/server.log or PATH, e.g. a FIFO); sets
#                   server_pid and server_port. The server inherits no fd 3 (a test may hold a
#                   pipe's end there). Not ready in 10 s: a failure that ends the test, its logs
#                   shown (nothing after it can run)
#   start_server DIR [ARGS...]   `$lockroll server` the same way (the test sets lockroll), but
#                   not ready is a failure the test goes on after (server_port empty)
#   completed_on_one_final WHAT DIR...   each client DIR's summary.json says completed, all on
#                   one final checksum (printed), else a failure naming WHAT
tmp=$(mktemp -d)
pids=()
failures=0
process_test_cleanup() {
    for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done
    if [ -n "${KEEP:-}" ]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap process_test_cleanup EXIT
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
show_logs() {
    local f
    for f in $(find "$1" -name 'server.log' -o -name 'peer.log' -o -name '*.stderr.log' | sort); do
        echo "--- ${f#"$1"/} (its sanitizer reports' first lines, then its last 8 lines)"
        grep -m3 -E 'ERROR: [A-Za-z]*Sanitizer|: runtime error: ' "$f"
        tail -8 "$f"
    done
}
expect_2() {  # expect_2 WHAT MESSAGE COMMAND...
    local what=$1 message=$2; shift 2
    timeout 20 "$@" >"$tmp/out.txt" 2>&1
    local status=$?
    [ "$status" = 2 ] || fail "$what: exit status $status, expected 2"
    grep -q -- "$message" "$tmp/out.txt" || fail "$what: no '$message' in: $(cat "$tmp/out.txt")"
}
launch_relay_server() {  # launch_relay_server [--stderr PATH] DIR COMMAND...: sets server_pid, server_port (empty: not ready)
    local log=
    [ "$1" = --stderr ] && { log=$2; shift 2; }
    local dir=$1; shift
    mkdir -p "$dir"
    "$@" --listen 127.0.0.1:0 --ready-file "$dir/ready" --status-file "$dir/status.json" \
        >"$dir/server.out" 2>"${log:-$dir/server.log}" 3>&- &
    server_pid=$!
    pids+=("$server_pid")
    for _ in $(seq 100); do [ -s "$dir/ready" ] && break; sleep 0.1; done
    server_port=$(cat "$dir/ready" 2>/dev/null)
}
start_relay_server() {  # start_relay_server [--stderr PATH] DIR COMMAND...
    launch_relay_server "$@"
    [ "$1" = --stderr ] && shift 2
    [ -n "$server_port" ] || { fail "the relay server in $1 did not get ready"; show_logs "$1"; exit 1; }
}
start_server() {  # start_server DIR [ARGS...]
    local dir=$1; shift
    launch_relay_server "$dir" "$lockroll" server "$@"
    [ -n "$server_port" ] || fail "server in $dir did not get ready"
}
completed_on_one_final() {  # completed_on_one_final WHAT DIR...
    local what=$1; shift
    /usr/bin/python3 - "$@" <<'PY' || fail "$what: the clients did not all complete on one final checksum"
import json, os, sys
c = [json.load(open(os.path.join(d, "summary.json"))) for d in sys.argv[1:]]
assert all(x["outcome"] == "completed" for x in c), [(x["outcome"], x.get("outcome_detail")) for x in c]
assert c[0]["final_checksum"] and len({x["final_checksum"] for x in c}) == 1, [x["final_checksum"] for x in c]
print("completed on one final", c[0]["final_checksum"])
PY
}
