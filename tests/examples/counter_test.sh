#!/usr/bin/env bash
# examples/counter, built against a fresh install prefix, plays 2 processes over ENet on
# 127.0.0.1 (free ports) to the same confirmed checksum of the last frame. Bounded: 60 s.
#   counter_test.sh BUILD_DIR SOURCE_DIR WORK_DIR CXX GENERATOR
set -euo pipefail
build=$1 src=$2 work=$3 cxx=$4 gen=$5
here=$(cd "$(dirname "$0")" && pwd)
exe=$(bash "$here/build_example.sh" "$build" "$src" "$work" counter "$cxx" "$gen")/counter
# Bad arguments: exit 2 before anything is bound.
set +e; "$exe" 7 1 2 2>/dev/null; rc=$?; set -e
[ "$rc" = 2 ] || { echo "counter with a bad slot exited $rc, want 2" >&2; exit 1; }
read -r p0 p1 < <(python3 "$src/tests/net/free_ports.py" 2)
frames=240
timeout 60 "$exe" 0 "$p0" "$p1" $frames > "$work/out0" 2> "$work/err0" & a=$!
timeout 60 "$exe" 1 "$p1" "$p0" $frames > "$work/out1" 2> "$work/err1" & b=$!
ra=0; rb=0
wait $a || ra=$?
wait $b || rb=$?
cat "$work/out0" "$work/out1"
if [ "$ra" != 0 ] || [ "$rb" != 0 ]; then
  echo "counter processes exited $ra and $rb" >&2; cat "$work/err0" "$work/err1" >&2; exit 1
fi
c0=$(awk '{print $NF}' "$work/out0"); c1=$(awk '{print $NF}' "$work/out1")
[ -n "$c0" ] && [ "$c0" != 0000000000000000 ] || { echo "no checksum from slot 0" >&2; exit 1; }
[ "$c0" = "$c1" ] || { echo "checksums differ: $c0 vs $c1" >&2; exit 1; }
grep -q "event synchronized" "$work/err0" || { echo "slot 0 never reported synchronized" >&2; exit 1; }
echo "counter: both processes confirmed frame $frames with checksum $c0"
