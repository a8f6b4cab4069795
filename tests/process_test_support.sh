# Sourced by the shell tests that start real processes (tests/net, tests/server): a scratch
# directory, the processes to kill when the test ends however it ends, and failure counting.
#   tmp       scratch directory, removed at exit (KEEP=1 keeps it and says where)
#   pids      add every background process: it is killed (-9) at exit
#   fail MSG  prints FAIL: MSG and counts it; `failures` holds the count
tmp=$(mktemp -d)
pids=()
failures=0
process_test_cleanup() {
    for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done
    if [ -n "${KEEP:-}" ]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
}
trap process_test_cleanup EXIT
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
