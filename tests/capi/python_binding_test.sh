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
field() { awk -v k="$2" '{for (i = 1; i < NF; i++) if ($i == k) print $(i + 1)}' "$1"; }

frames=240
read -r -a ports <<<"$(python3 "$here/../net/free_ports.py" 2)"
timeout 60 python3 "$here/python_counter.py" 0 "${ports[0]}" "${ports[1]}" $frames 0 >"$tmp/p0.out" 2>"$tmp/p0.err" &
a=$!
timeout 60 python3 "$here/python_counter.py" 1 "${ports[1]}" "${ports[0]}" $frames 0 >"$tmp/p1.out" 2>"$tmp/p1.err" &
b=$!
pids+=("$a" "$b")
wait "$a" || fail "slot 0 exited $?: $(cat "$tmp/p0.out" "$tmp/p0.err")"
wait "$b" || fail "slot 1 exited $?: $(cat "$tmp/p1.out" "$tmp/p1.err")"
cat "$tmp/p0.out" "$tmp/p1.out"
c0=$(field "$tmp/p0.out" checksum) c1=$(field "$tmp/p1.out" checksum)
[[ -n $c0 && $c0 != 0000000000000000 ]] || fail "no final checksum from slot 0"
[[ $c0 == "$c1" ]] || fail "final checksums differ: $c0 vs $c1"
[[ $(field "$tmp/p0.out" value) == "$(field "$tmp/p1.out" value)" ]] || fail "the Python games ended on different values"
grep -q "completed" "$tmp/p0.out" && grep -q "completed" "$tmp/p1.out" || fail "a process did not complete"
grep -q "event synchronized" "$tmp/p0.err" || fail "slot 0 never reported synchronized"
# Input delay 0: remote inputs are predicted, so some frame was rolled back through load().
(($(field "$tmp/p0.out" loads) + $(field "$tmp/p1.out" loads) > 0)) || fail "no rollback ever called the Python load()"

# A bad setting: LockrollError with lockroll's message, exit 2 before anything plays.
out=$(timeout 20 python3 "$here/python_counter.py" 0 "${ports[0]}" "${ports[0]}" 10 -3 2>&1); rc=$?
[[ $rc == 2 ]] || fail "a negative input delay exited $rc, want 2: $out"
grep -qi "delay" <<<"$out" || fail "the error does not name the input delay: $out"
[[ $failures -eq 0 ]] && echo "python binding: both processes confirmed frame $frames with checksum $c0" ||
    echo "$failures failure(s)"
exit $((failures > 0))
