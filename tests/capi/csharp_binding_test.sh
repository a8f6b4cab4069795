#!/usr/bin/env bash
# bindings/csharp/Lockroll.cs (P/Invoke over liblockroll.so): tests/capi/CsharpCounter.cs is
# compiled with mono's mcs, and two of it play 240 frames on 127.0.0.1 (free ports) to equal
# final checksums and equal game values. Bounded: 60 s per process. Skipped (77), naming the
# packages, when mcs or mono is missing.
#   csharp_binding_test.sh LIBLOCKROLL_SO
set -u
lib=$1
here=$(cd "$(dirname "$0")" && pwd)
command -v mcs >/dev/null && command -v mono >/dev/null ||
  { echo "skipped: mcs or mono missing (Debian mono-mcs mono-runtime)"; exit 77; }
source "$here/../process_test_support.sh"
source "$here/pair_match.sh"

mcs -out:"$tmp/CsharpCounter.exe" "$here/../../bindings/csharp/Lockroll.cs" "$here/CsharpCounter.cs" >"$tmp/mcs.log" 2>&1 ||
  { cat "$tmp/mcs.log"; echo "FAIL: the C# sample does not compile"; exit 1; }
export LD_LIBRARY_PATH=$(dirname "$lib")${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
frames=240
launch() { timeout 60 mono "$tmp/CsharpCounter.exe" "$1" "$2" "$3" $frames; }
pair_match launch

# A bad setting (slot 5 of 2: the remote slot is -4): lockroll's message naming it, exit 2.
out=$(timeout 20 mono "$tmp/CsharpCounter.exe" 5 7000 7001 10 2>&1); rc=$?
[[ $rc == 2 && $out == *"slot must be"* ]] || fail "slot 5 exited $rc, want 2 and lockroll's message: $out"
[[ $failures -eq 0 ]] && echo "C# binding: both processes confirmed frame $frames with checksum $checksum" ||
    echo "$failures failure(s)"
exit $((failures > 0))
