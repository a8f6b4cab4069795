#!/usr/bin/env bash
# examples/c_counter (C99 over <lockroll/lockroll.h> and liblockroll.so), built against a fresh
# install prefix only, plays 2 processes over ENet on 127.0.0.1 (free ports) to the same
# confirmed checksum of the last frame. Bounded: 60 s. Bad arguments exit 2 naming the argument.
# It also builds with a plain `cc -std=c99` and lockroll-c.pc's flags.
#   c_counter_test.sh BUILD_DIR SOURCE_DIR WORK_DIR CXX GENERATOR
set -euo pipefail
build=$1 src=$2 work=$3 cxx=$4 gen=$5
here=$(cd "$(dirname "$0")" && pwd)
exe=$(bash "$here/build_example.sh" "$build" "$src" "$work" c_counter "$cxx" "$gen")/c_counter
# Linked to the installed liblockroll.so, not the build tree's.
ldd "$exe" > "$work/ldd.txt"
grep -q "$work/prefix/.*liblockroll\.so" "$work/ldd.txt" ||
  { echo "c_counter does not load liblockroll.so from the install prefix:" >&2; cat "$work/ldd.txt" >&2; exit 1; }
# Without CMake: pkg-config's lockroll-c flags and a plain C99 compiler line.
pc=$(PKG_CONFIG_PATH=$(ls -d "$work"/prefix/lib*/pkgconfig | head -1) pkg-config --cflags --libs lockroll-c)
libdir=$(ls -d "$work"/prefix/lib* | head -1)
# shellcheck disable=SC2086
cc -std=c99 -Wall -Wextra -Wpedantic -Werror "$src/examples/c_counter/c_counter.c" $pc -Wl,-rpath,"$libdir" \
  -o "$work/c_counter_pc" || { echo "c_counter does not build with pkg-config's flags ($pc)" >&2; exit 1; }
set +e; "$work/c_counter_pc" 0 1 0 2>/dev/null; rc=$?; set -e
[ "$rc" = 2 ] || { echo "the pkg-config build with PEER_PORT 0 exited $rc, want 2" >&2; exit 1; }
set +e; msg=$("$exe" 7 1 2 2>&1); rc=$?; set -e
[ "$rc" = 2 ] || { echo "c_counter with a bad slot exited $rc, want 2" >&2; exit 1; }
grep -q "SLOT" <<<"$msg" || { echo "c_counter's message does not name SLOT: $msg" >&2; exit 1; }
frames=240
read -r p0 p1 < <(python3 "$src/tests/net/free_ports.py" 2)
ra=0 rb=0
timeout 60 "$exe" 0 "$p0" "$p1" $frames > "$work/out0" 2> "$work/err0" & a=$!
timeout 60 "$exe" 1 "$p1" "$p0" $frames > "$work/out1" 2> "$work/err1" & b=$!
wait $a || ra=$?
wait $b || rb=$?
cat "$work/out0" "$work/out1"
if [ "$ra" != 0 ] || [ "$rb" != 0 ]; then
  echo "c_counter processes exited $ra and $rb" >&2; cat "$work/err0" "$work/err1" >&2; exit 1
fi
c0=$(awk '{print $NF}' "$work/out0"); c1=$(awk '{print $NF}' "$work/out1")
[ -n "$c0" ] && [ "$c0" != 0000000000000000 ] || { echo "no checksum from slot 0" >&2; exit 1; }
[ "$c0" = "$c1" ] || { echo "checksums differ: $c0 vs $c1" >&2; exit 1; }
grep -q "completed" "$work/out0" && grep -q "completed" "$work/out1" || { echo "a process did not complete" >&2; exit 1; }
grep -q "event synchronized" "$work/err0" || { echo "slot 0 never reported synchronized" >&2; exit 1; }
echo "c_counter: both processes confirmed frame $frames with checksum $c0"
