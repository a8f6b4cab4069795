# shellcheck shell=bash
# Sourced, after tests/process_test_support.sh, by the relay shell tests that play one room with
# `lockroll client`s against a relay server of their own. The test sets lockroll.
#   start_relay_match SECONDS DIR PLAYERS ROOM FRAMES SEED SLOT...   a fresh `$lockroll server`
#                   in DIR (start_relay_server: sets server_pid and server_port, ends the test
#                   if it is not ready), then, in the background and each bounded by timeout(1)
#                   SECONDS, for each SLOT a `$lockroll client` of that slot of PLAYERS in ROOM on
#                   it for FRAMES frames with input seed SEED + SLOT, its outputs (summary.json,
#                   events.jsonl) in DIR/cSLOT and what it prints in DIR/cSLOT.out. Sets
#                   client_pids (in SLOT order) and adds them to pids (killed at exit). Other
#                   players (a bad client) join ROOM on 127.0.0.1:$server_port.
start_relay_match() {  # start_relay_match SECONDS DIR PLAYERS ROOM FRAMES SEED SLOT...
    local seconds=$1 dir=$2 players=$3 room=$4 frames=$5 seed=$6 slot
    shift 6
    start_relay_server "$dir" "$lockroll" server
    client_pids=()
    for slot in "$@"; do
        timeout "$seconds" "$lockroll" client --slot "$slot" --players "$players" --connect "127.0.0.1:$server_port" \
            --room "$room" --frames "$frames" --seed "$((seed + slot))" --out "$dir/c$slot" >"$dir/c$slot.out" 2>&1 &
        client_pids+=($!)
        pids+=($!)
    done
}
