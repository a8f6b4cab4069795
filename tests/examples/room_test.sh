#!/usr/bin/env bash
# examples/room, built against a fresh install prefix: two windows under Xvfb play each other
# through `lockroll proxy` (30 ms each way) to the same confirmed checksum, and each window's
# screenshot at frame 240 shows the room's walls, the balls and both players, and the overlay's
# words (SDL2_ttf) where the room says it drew them: "ping N ms" (at least 40 through the proxy's
# 60 ms round trip), "input delay 2", "rollback N frames", "frames behind N" (pixels counted by
# check_room_shot.py). Each window draws in its own loop: slot 0 at 144 Hz, slot 1 at 45 Hz
# (several ticks per update), both on the 60 Hz match. A --font that does not open is refused
# with exit 2 before any work. Skipped (exit 77) when SDL2, SDL2_ttf, the DejaVu font or Xvfb is
# missing, naming the package (scripts/install-deps.sh installs them all).
#   room_test.sh BUILD_DIR SOURCE_DIR WORK_DIR CXX GENERATOR LOCKROLL_EXE
set -euo pipefail
build=$1 src=$2 work=$3 cxx=$4 gen=$5 lockroll=$6
here=$(cd "$(dirname "$0")" && pwd)
skip() { echo "SKIPPED: $1 (scripts/install-deps.sh installs it)"; exit 77; }
pkg-config --exists sdl2 || skip "examples/room needs SDL2 (Debian package libsdl2-dev)"
pkg-config --exists SDL2_ttf || skip "examples/room needs SDL2_ttf (Debian package libsdl2-ttf-dev)"
font=/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf  # room.cpp's default
[ -r "$font" ] || skip "the room test needs $font (Debian package fonts-dejavu-core)"
command -v xvfb-run > /dev/null || skip "the room test needs xvfb-run (Debian package xvfb)"
command -v xauth > /dev/null || skip "xvfb-run needs xauth (Debian package xauth)"
exe=$(bash "$here/build_example.sh" "$build" "$src" "$work" room "$cxx" "$gen")/room
[ -x "$exe" ] || { echo "examples/room was not built (see $work/configure.log)" >&2; exit 1; }
read -r p0 p1 px < <(python3 "$src/tests/net/free_ports.py" 3)
# Bad input is refused before any work (no window, no socket): a font that does not open.
frc=0; "$exe" 0 "$p0" "$p1" --font "$work/no-such-font.ttf" > /dev/null 2> "$work/font.err" || frc=$?
[ "$frc" = 2 ] && grep -q -- "--font $work/no-such-font.ttf" "$work/font.err" ||
  { echo "room --font MISSING: exit $frc, expected 2 naming the file:" >&2; cat "$work/font.err" >&2; exit 1; }
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
grep -q "^slot 0 completed " "$work/out0" && grep -q "^slot 1 completed " "$work/out1" || { echo "a room did not complete" >&2; exit 1; }
c0=$(awk '/^slot /{print $NF}' "$work/out0"); c1=$(awk '/^slot /{print $NF}' "$work/out1")
[ "$c0" = "$c1" ] && [ "$c0" != 0000000000000000 ] || { echo "checksums differ: $c0 vs $c1" >&2; exit 1; }
# The overlay's words, as each room says it drew them at frame 240 (the screenshot's frame).
for n in 0 1; do
  words() { sed -n "s/^overlay [0-9]* [0-9]* [0-9]* [0-9]* //p" "$work/out$n"; }
  ping=$(words | sed -n 's/^ping \([0-9][0-9]*\) ms$/\1/p')
  [ -n "$ping" ] && [ "$ping" -ge 40 ] || { echo "room $n: no 'ping N ms' of at least 40 (the proxy's round trip is 60 ms):" >&2; words >&2; exit 1; }
  for want in '^input delay 2$' '^rollback [0-9]+ frames?$' '^frames behind -?[0-9]+$' '^rollback: runs ahead'; do
    words | grep -Eq "$want" || { echo "room $n: no overlay text matching $want:" >&2; words >&2; exit 1; }
  done
  python3 "$here/check_room_shot.py" "$work/shot$n.bmp" --overlay "$work/out$n"
done
echo "room: both windows confirmed frame $frames with checksum $c0"
