# Sourced by the shell tests that start real processes (tests/net, tests/server): a scratch
# directory, the processes to kill when the test ends however it ends, and failure counting.
#   tmp       scratch directory, removed at exit (KEEP=1 keeps it and says where)
#   pids      add every background process: it is killed (-9) at exit
#   fail MSG  prints FAIL: MSG and counts it; `failures` holds the count
#   show_logs DIR   the last lines of every process log under DIR (server.log, peer.log,
#                   *.stderr.log), so a failure can be diagnosed from CI's output alone
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
        echo "--- ${f#"$1"/} (last 8 lines)"
        tail -8 "$f"
    done
}
