#!/usr/bin/env bash
# examples/room, built against a fresh install prefix: two windows under Xvfb play each other
# through `lockroll proxy` (30 ms each way) to the same confirmed checksum, and each window's
# screenshot at frame 240 shows the room's walls, the balls and both players (pixels counted by
# check_room_shot.py). Each window draws in its own loop: slot 0 at 144 Hz, slot 1 at 45 Hz
# (several ticks per update), both on the 60 Hz match. Skipped (exit 77) when SDL2 or Xvfb is
# missing, naming the package.
#   room_test.sh BUILD_DIR SOURCE_DIR WORK_DIR CXX GENERATOR LOCKROLL_EXE
set -euo pipefail
build=$1 src=$2 work=$3 cxx=$4 gen=$5 lockroll=$6
here=$(cd "$(dirname "$0")" && pwd)
if ! pkg-config --exists sdl2; then echo "SKIPPED: examples/room needs SDL2 (Debian package libsdl2-dev)"; exit 77; fi
if ! command -v xvfb-run > /dev/null; then echo "SKIPPED: the room test needs xvfb-run (Debian package xvfb)"; exit 77; fi
exe=$(bash "$here/build_example.sh" "$build" "$src" "$work" room "$cxx" "$gen")/room
[ -x "$exe" ] || { echo "examples/room was not built (see $work/configure.log)" >&2; exit 1; }
read -r p0 p1 px < <(python3 "$src/tests/net/free_ports.py" 3)
frames=300
# Slot 0 reaches slot 1 through the proxy (the lower slot connects): both directions cross it.
timeout 120 "$lockroll" proxy --listen "127.0.0.1:$px" --to "127.0.0.1:$p1" --latency 30 --jitter 5 --duration-s 110 \
  > "$work/proxy.log" 2>&1 & proxy=$!
trap 'kill $proxy 2>/dev/null || true' EXIT
rc=0
timeout 150 xvfb-run -a -s "-screen 0 1600x900x24" bash -c "
  '$exe' 0 $p0 $px --frames $frames --bot --screenshot '$work/shot0.bmp' --shot-frame 240 > '$work/out0' 2> '$work/err0' & a=\$!
  '$exe' 1 $p1 $p0 --frames $frames --fps 45 --bot --screenshot '$work/shot1.bmp' --shot-frame 240 > '$work/out1' 2> '$work/err1' & b=\$!
  ra=0; rb=0; wait \$a || ra=\$?; wait \$b || rb=\$?; exit \$((ra + rb))" || rc=$?
cat "$work/out0" "$work/out1"
if [ "$rc" != 0 ]; then echo "room processes failed ($rc)" >&2; cat "$work/err0" "$work/err1" >&2; exit 1; fi
grep -q " completed " "$work/out0" && grep -q " completed " "$work/out1" || { echo "a room did not complete" >&2; exit 1; }
c0=$(awk '{print $NF}' "$work/out0"); c1=$(awk '{print $NF}' "$work/out1")
[ "$c0" = "$c1" ] && [ "$c0" != 0000000000000000 ] || { echo "checksums differ: $c0 vs $c1" >&2; exit 1; }
python3 "$here/check_room_shot.py" "$work/shot0.bmp"
python3 "$here/check_room_shot.py" "$work/shot1.bmp"
echo "room: both windows confirmed frame $frames with checksum $c0"
