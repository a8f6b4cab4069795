#!/usr/bin/env bash
# A log nobody reads must not stop the relay server (issue 20), with real processes on 127.0.0.1
# (a free port, every wait bounded). lockroll-server's stderr is a FIFO that is held open but not
# read, as under a supervisor that stalls or a full journald: once the pipe's 64 KiB are full, a
# write() to it blocks. A hostile client (relay_bad_client --behavior refused) cycles
# connections whose hellos are refused, two warn lines each, until the server reports log lines
# dropped (the pipe is full); then two honest `lockroll client`s play 600 frames of one room
# under the flood. Both must complete on one final checksum, the status
# file must keep being rewritten (the loop runs) and count the log lines it dropped. Before the
# log was off the loop, the server blocked in write() on stderr and every room stopped.
#  1. the pipe is never read: SIGTERM still ends the process, exit 0, within a bound (the
#     log's last lines cannot be written, and the exit does not wait for them for good);
#  2. the pipe is read once the match is over: SIGTERM drains and exits 0, and the log ends
#     with the drain's last line and the count of lines dropped (nothing queued is lost);
#  3. the pipe's reader goes away (a supervisor restarts): the server lives on (SIGPIPE is
#     ignored; the lines are lost) and exits 0 on SIGTERM.
set -u
server_exe=$1
lockroll=$2
bad_client=$3
source "$(dirname "$0")/../process_test_support.sh"

# run_match DIR: a server whose stderr is DIR/stderr.fifo (held open on fd 3, not read; the
# server does not inherit fd 3: start_relay_server), the flood and the two honest clients;
# checks the clients and the status file. Sets server_pid.
run_match() {
    local dir=$1
    mkdir -p "$dir"
    mkfifo "$dir/stderr.fifo"
    exec 3<>"$dir/stderr.fifo"  # a reader exists (so the server's open does not block), and never reads
    start_relay_server --stderr "$dir/stderr.fifo" "$dir" "$server_exe"
    local port=$server_port
    # The flood first, until the log is provably under pressure: the status file counts lines
    # dropped (the pipe's 64 KiB and the log's queue are full). Waiting for that state, not for
    # a fixed flood length, keeps the test meaning the same on a loaded machine, where the flood
    # is slower (at load 5-8 a 12 s flood refused only 250-1,600 hellos and dropped no line).
    timeout 120 "$bad_client" --connect "127.0.0.1:$port" --room hostile --slot 0 --behavior refused --parallel 8 \
        --seconds 100 >"$dir/hostile.out" 2>&1 3>&- &
    local hostile=$!
    pids+=($hostile)
    local pressed=
    for _ in $(seq 600); do
        /usr/bin/python3 -c 'import json,sys; sys.exit(0 if json.load(open(sys.argv[1])).get("log_dropped", 0) > 0 else 1)' \
            "$dir/status.json" 2>/dev/null && { pressed=1; break; }
        sleep 0.1
    done
    [ -n "$pressed" ] || { fail "$dir: 60 s of flood dropped no log line (the pipe never filled)"; cat "$dir/status.json"; }
    # Then the honest match, under the flood.
    local cpids=()
    for s in 0 1; do
        timeout 90 "$lockroll" client --slot "$s" --players 2 --connect "127.0.0.1:$port" --room honest --frames 600 \
            --seed "$((s + 7))" --out "$dir/c$s" >"$dir/c$s.out" 2>&1 3>&- &
        cpids+=($!)
        pids+=($!)
    done
    # The loop runs while the pipe stays full: the status file (posted by the loop every second)
    # goes on changing.
    cp "$dir/status.json" "$dir/status.a.json" 2>/dev/null
    sleep 2.5
    cp "$dir/status.json" "$dir/status.b.json" 2>/dev/null
    for s in 0 1; do
        wait "${cpids[$s]}"
        local status=$?
        [ "$status" = 0 ] || { fail "$dir: honest client $s exit status $status"; tail -3 "$dir/c$s.out"; }
    done
    kill -TERM "$hostile" 2>/dev/null
    wait "$hostile"
    cat "$dir/hostile.out"
    sleep 1.5  # the status file is rewritten every second
    completed_on_one_final "$dir" "$dir/c0" "$dir/c1"
    /usr/bin/python3 - "$dir" <<'PY' || fail "$dir: the loop or its log"
import json, os, sys
base = sys.argv[1]
a = json.load(open(os.path.join(base, "status.a.json")))
b = json.load(open(os.path.join(base, "status.b.json")))
end = json.load(open(os.path.join(base, "status.json")))
# The loop went on while its log could not be written: uptime and traffic moved between samples.
assert b["uptime_s"] >= a["uptime_s"] + 1, (a["uptime_s"], b["uptime_s"])
assert b["datagrams_in"] > a["datagrams_in"], (a["datagrams_in"], b["datagrams_in"])
# The pressure was real: the lines the full pipe could not take were dropped and counted, and
# the flood went on through the match (two warn lines a refused hello).
assert end["log_dropped"] > 0, end
assert end["hellos_refused"] > b["hellos_refused"] > a["hellos_refused"], (a["hellos_refused"], b["hellos_refused"], end["hellos_refused"])
print("uptime", a["uptime_s"], "->", b["uptime_s"], "hellos refused", end["hellos_refused"], "log lines dropped",
      end["log_dropped"])
PY
}

# wait_exit PID WHAT: the process exits 0 within 15 s of SIGTERM.
wait_exit() {
    local pid=$1 what=$2
    kill -TERM "$pid"
    for _ in $(seq 150); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$pid" 2>/dev/null; then
        fail "$what: still running 15 s after SIGTERM"
        return
    fi
    wait "$pid"
    local status=$?
    [ "$status" = 0 ] || fail "$what: exit status $status after SIGTERM"
}

# ---- 1. the pipe is never read ----
dir=$tmp/unread
run_match "$dir"
wait_exit "$server_pid" "unread pipe"
timeout 3 cat <&3 >"$dir/server.log"  # what the pipe holds: the first 64 KiB
exec 3>&-
grep -q "listening on" "$dir/server.log" || fail "unread pipe: no start lines in the pipe"

# ---- 2. the pipe is read once the match is over: nothing queued is lost at exit ----
dir=$tmp/late
run_match "$dir"
exec 4<"$dir/stderr.fifo"  # opened here, before fd 3 closes: the pipe never has no reader
timeout 30 cat <&4 >"$dir/server.log" 3>&- 4<&- &
reader=$!
pids+=($reader)
exec 3>&- 4<&-  # the reader is the only one left: it sees EOF when the server exits
wait_exit "$server_pid" "late reader"
wait "$reader" || fail "late reader: cat did not end with the server"
tail -3 "$dir/server.log"
tail -1 "$dir/server.log" | grep -q "drained: every room finished; exiting" || fail "late reader: the log's last line is not the drain's"
grep -Eq "log: [0-9]+ lines dropped" "$dir/server.log" || fail "late reader: the dropped lines were not reported"

# ---- 3. the reader goes away: the server plays on (SIGPIPE ignored, the lines are lost) ----
dir=$tmp/gone
mkdir -p "$dir"
mkfifo "$dir/stderr.fifo"
exec 3<>"$dir/stderr.fifo"
start_relay_server --stderr "$dir/stderr.fifo" "$dir" "$server_exe"
port=$server_port
timeout 30 "$bad_client" --connect "127.0.0.1:$port" --room hostile --slot 0 --behavior refused --parallel 8 \
    --seconds 2 >"$dir/hostile.out" 2>&1 3>&-
exec 3>&-  # the pipe's only reader closes: the next write() fails with EPIPE (and SIGPIPE)
sleep 1.5
kill -0 "$server_pid" 2>/dev/null || fail "gone: the server died when its log's reader went away"
cp "$dir/status.json" "$dir/status.a.json" 2>/dev/null
sleep 1.5
cmp -s "$dir/status.json" "$dir/status.a.json" && fail "gone: the status file stopped changing"
wait_exit "$server_pid" "gone reader"

[ "$failures" = 0 ] || { show_logs "$tmp"; exit 1; }
echo "relay log pressure test: ok"
