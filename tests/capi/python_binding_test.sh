#!/usr/bin/env bash
# bindings/python/lockroll.py (ctypes over liblockroll.so): two Python processes on 127.0.0.1
# (free ports), each a counter game in Python (tests/capi/python_counter.py), play 240 frames
# with input delay 0 (so rollbacks call the Python load()) to equal final checksums and equal
# game values; then a bad setting raises LockrollError naming it. Bounded: 60 s per process.
#   python_binding_test.sh LIBLOCKROLL_SO
set -u
export LOCKROLL_LIBRARY=$1
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../process_test_support.sh"
source "$here/pair_match.sh"

frames=240
launch() { timeout 60 python3 "$here/python_counter.py" "$1" "$2" "$3" $frames 0; }
pair_match launch
# Input delay 0: remote inputs are predicted, so some frame was rolled back through load().
(($(field "$tmp/p0.out" loads) + $(field "$tmp/p1.out" loads) > 0)) || fail "no rollback ever called the Python load()"

# A bad setting: LockrollError with lockroll's message, exit 2 (listening on an ephemeral port,
# should it get that far).
out=$(timeout 20 python3 "$here/python_counter.py" 0 0 7001 10 -3 2>&1); rc=$?
[[ $rc == 2 ]] || fail "a negative input delay exited $rc, want 2: $out"
grep -qi "delay" <<<"$out" || fail "the error does not name the input delay: $out"
[[ $failures -eq 0 ]] && echo "python binding: both processes confirmed frame $frames with checksum $checksum" ||
    echo "$failures failure(s)"
exit $((failures > 0))
