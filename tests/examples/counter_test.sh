#!/usr/bin/env bash
# examples/counter, built against a fresh install prefix, plays 2 processes over ENet on
# 127.0.0.1 (free ports) to the same confirmed checksum of the last frame, then over its own
# UDP transport (udp_socket_transport.h) to the same checksum. Bounded: 60 s each.
#   counter_test.sh BUILD_DIR SOURCE_DIR WORK_DIR CXX GENERATOR
set -euo pipefail
build=$1 src=$2 work=$3 cxx=$4 gen=$5
here=$(cd "$(dirname "$0")" && pwd)
exe=$(bash "$here/build_example.sh" "$build" "$src" "$work" counter "$cxx" "$gen")/counter
# Bad arguments: exit 2 before anything is bound.
set +e; "$exe" 7 1 2 2>/dev/null; rc=$?; set -e
[ "$rc" = 2 ] || { echo "counter with a bad slot exited $rc, want 2" >&2; exit 1; }
# play NAME [TRANSPORT]: two processes on free ports; both must confirm the last frame with one
# checksum, printed into $work/NAME.checksum.
play() {
  local name=$1 kind=${2:-enet} p0 p1 a b ra=0 rb=0
  read -r p0 p1 < <(python3 "$src/tests/net/free_ports.py" 2)
  timeout 60 "$exe" 0 "$p0" "$p1" $frames "$kind" > "$work/$name.out0" 2> "$work/$name.err0" & a=$!
  timeout 60 "$exe" 1 "$p1" "$p0" $frames "$kind" > "$work/$name.out1" 2> "$work/$name.err1" & b=$!
  wait $a || ra=$?
  wait $b || rb=$?
  cat "$work/$name.out0" "$work/$name.out1"
  if [ "$ra" != 0 ] || [ "$rb" != 0 ]; then
    echo "$name: counter processes exited $ra and $rb" >&2; cat "$work/$name.err0" "$work/$name.err1" >&2; exit 1
  fi
  local c0 c1
  c0=$(awk '{print $NF}' "$work/$name.out0"); c1=$(awk '{print $NF}' "$work/$name.out1")
  [ -n "$c0" ] && [ "$c0" != 0000000000000000 ] || { echo "$name: no checksum from slot 0" >&2; exit 1; }
  [ "$c0" = "$c1" ] || { echo "$name: checksums differ: $c0 vs $c1" >&2; exit 1; }
  grep -q "event synchronized" "$work/$name.err0" || { echo "$name: slot 0 never reported synchronized" >&2; exit 1; }
  echo "$c0" > "$work/$name.checksum"
}
frames=240
play enet
# Over the game's own transport (plain UDP sockets, no ENet): the same match, the same checksum.
play udp udp
[ "$(cat "$work/enet.checksum")" = "$(cat "$work/udp.checksum")" ] ||
  { echo "the match over udp ended on another checksum than over ENet" >&2; exit 1; }
echo "counter: both processes confirmed frame $frames with checksum $(cat "$work/enet.checksum"), over ENet and over UDP"
