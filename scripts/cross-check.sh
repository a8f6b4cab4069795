#!/usr/bin/env bash
# Cross-compiler / cross-architecture determinism check.
#
# Builds the golden runner (tests/golden/golden_main.cpp + sim/*.cpp + harness/match/scene_loader.cpp)
# with every compiler, optimisation level and CPU below and compares its output, line by line,
# with tests/golden/checksums.txt. Any difference is a determinism bug: the simulation must give
# the same bits everywhere.
#
#   target         compiler                              128-bit math  run
#   gcc-O0         g++ -O0                               __int128      native
#   gcc-O3         g++ -O3                               __int128      native
#   clang14-O0     clang++-14 -O0                        __int128      native
#   clang14-O3     clang++-14 -O3                        __int128      native
#   aarch64        aarch64-linux-gnu-g++ -O2 -static     __int128      qemu-aarch64 (64-bit ARM)
#   s390x          s390x-linux-gnu-g++ -O2 -static       __int128      qemu-s390x (IBM Z, big-endian)
#   gcc-portable   g++ -O2 -DLOCKROLL_PORTABLE_MATH=1    portable      native
#   clang14-portable clang++-14 -O2 -DLOCKROLL_PORTABLE_MATH=1 portable native
#   i386           i686-linux-gnu-g++ -O2 -static        portable      native on x86-64, else qemu-i386
#   armhf          arm-linux-gnueabihf-g++ -O2 -static   portable      qemu-arm (32-bit ARM, hard float)
#   wasm32         em++ (emscripten) -O2 -fexceptions     __int128      node (NODERAWFS: reads the host's files)
#
# Threads column: every target that runs threads also runs the golden runner a second time with
# --workers 3 (the parallel step, docs/physics.md), which must print the same file. wasm32 is
# built without threads (no -pthread, no SharedArrayBuffer under node): its column says "none".
#
# A target whose compiler, emulator or library is missing is skipped with a message naming the
# Debian package; the others still run.
#
# Usage: scripts/cross-check.sh [--targets a,b,...] [--jobs N] [--keep] [--regenerate]
#   --targets     run only these targets (default: all)
#   --jobs N      compile up to N sources at once (default 2)
#   --keep        keep the work directory (binaries, outputs) and print its path
#   --regenerate  rewrite tests/golden/checksums.txt from the gcc-O3 build first, then check
#                 the other targets against it (after an intended change to the simulation)
#
# Exit status: 0 every target that ran matches (some may have been skipped); 1 a target differs
# (its name and first differing line are printed); 2 bad usage; 3 nothing could run (headers or
# every toolchain missing; CTest reports the test as skipped); 4 a build or a run fails.
# Needs (Debian 12): g++, clang-14, g++-aarch64-linux-gnu, g++-s390x-linux-gnu,
# g++-i686-linux-gnu, g++-arm-linux-gnueabihf, qemu-user, emscripten, nodejs, nlohmann-json3-dev,
# libxxhash-dev, libcli11-dev (scripts/install-deps.sh --cross). Works from a fresh clone: no
# CMake build used.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
golden="$root/tests/golden/checksums.txt"
all_targets=(gcc-O0 gcc-O3 clang14-O0 clang14-O3 aarch64 s390x gcc-portable clang14-portable i386 armhf wasm32)
targets=("${all_targets[@]}")
jobs=2
keep=0
regenerate=0

usage() { sed -n '/^# Usage:/,/^# Exit status/p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
while [[ $# -gt 0 ]]; do
    case "$1" in
        --targets) [[ $# -ge 2 ]] || usage; IFS=, read -r -a targets <<<"$2"; shift 2 ;;
        --jobs) [[ $# -ge 2 && "$2" =~ ^[1-9][0-9]*$ ]] || usage; jobs=$2; shift 2 ;;
        --keep) keep=1; shift ;;
        --regenerate) regenerate=1; shift ;;
        -h|--help) usage ;;
        *) echo "cross-check: unknown argument '$1'" >&2; usage ;;
    esac
done
for t in "${targets[@]}"; do
    [[ " ${all_targets[*]} " == *" $t "* ]] || { echo "cross-check: unknown target '$t' (known: ${all_targets[*]})" >&2; exit 2; }
done
if [[ $regenerate -eq 1 ]]; then  # gcc-O3 writes the golden file, so it goes first
    rest=()
    for t in "${targets[@]}"; do [[ $t == gcc-O3 ]] || rest+=("$t"); done
    targets=(gcc-O3 "${rest[@]}")
fi

# target -> compiler, flags, runner
compiler_of() {
    case "$1" in
        gcc-*) echo g++ ;;
        clang14-*) echo clang++-14 ;;
        wasm32) echo em++ ;;
        aarch64) echo aarch64-linux-gnu-g++ ;;
        s390x) echo s390x-linux-gnu-g++ ;;
        i386) echo i686-linux-gnu-g++ ;;
        armhf) echo arm-linux-gnueabihf-g++ ;;
    esac
}
# emscripten, not clang's wasm32-wasi: wasi's libc++ 14 has neither std::filesystem (the scene
# loader) nor exceptions. NODERAWFS lets the program read harness/scenes from the host; the
# synchronous instantiation avoids emscripten 3.1.6's fetch() of a file path on node >= 18.
wasm_link=(-fexceptions -sNODERAWFS=1 -sENVIRONMENT=node -sWASM_ASYNC_COMPILATION=0 -sALLOW_MEMORY_GROWTH=1)
# Debian's emscripten finds its node modules (acorn) there; Debian's node looks there anyway.
export NODE_PATH=/usr/share/nodejs${NODE_PATH:+:$NODE_PATH}
flags_of() {
    case "$1" in
        *-O0) echo "-O0" ;;
        *-O3) echo "-O3" ;;
        *-portable) echo "-O2 -DLOCKROLL_PORTABLE_MATH=1" ;;
        aarch64|s390x|i386|armhf) echo "-O2" ;;
        wasm32) echo "-O2 -fexceptions" ;;
    esac
}
link_flags_of() {
    case "$1" in
        aarch64|s390x|i386|armhf) echo "-static" ;;
        wasm32) echo "${wasm_link[*]}" ;;
    esac
}
# The golden runner's file name (emscripten writes JavaScript plus golden.wasm beside it).
exe_of() { case "$1" in wasm32) echo golden.js ;; *) echo golden ;; esac; }
# Workers of the threads column's run; empty: the target has no threads.
threads_of() { case "$1" in wasm32) ;; *) echo 3 ;; esac; }
runner_of() {
    case "$1" in
        aarch64) echo qemu-aarch64 ;;
        s390x) echo qemu-s390x ;;
        armhf) echo qemu-arm ;;
        i386) [[ $(uname -m) == x86_64 ]] || echo qemu-i386 ;;
        wasm32) echo node ;;
    esac
}
package_of() {
    case "$1" in
        g++) echo g++ ;; clang++-14) echo clang-14 ;;
        aarch64-linux-gnu-g++) echo g++-aarch64-linux-gnu ;; s390x-linux-gnu-g++) echo g++-s390x-linux-gnu ;;
        i686-linux-gnu-g++) echo g++-i686-linux-gnu ;; arm-linux-gnueabihf-g++) echo g++-arm-linux-gnueabihf ;;
        qemu-*) echo qemu-user ;; node) echo nodejs ;; em++) echo emscripten ;;
    esac
}
# Prints what target $1 lacks, one "tool (package)" per line; nothing when it can run.
missing_of() {
    local t=$1 tool
    for tool in "$(compiler_of "$t")" $(runner_of "$t"); do
        command -v "$tool" >/dev/null || echo "'$tool' (Debian package $(package_of "$tool"))"
    done
}

# Targets whose toolchain is missing are skipped (named with the package to install).
runnable=()
skipped=()
for t in "${targets[@]}"; do
    lacks=$(missing_of "$t")
    if [[ -n "$lacks" ]]; then
        echo "cross-check: $t skipped: needs $(echo "$lacks" | paste -sd, - | sed 's/,/, /g')" >&2
        skipped+=("$t")
    else
        runnable+=("$t")
    fi
done
if [[ $regenerate -eq 1 && " ${skipped[*]} " == *" gcc-O3 "* ]]; then
    echo "cross-check: --regenerate needs the gcc-O3 target" >&2
    exit 3
fi
targets=("${runnable[@]}")
missing=0
[[ ${#targets[@]} -gt 0 ]] || { echo "cross-check: no target can run" >&2; missing=1; }
# Header-only dependencies, handed to every compiler through one directory of symlinks so that
# cross compilers never see the host's /usr/include.
headers=(/usr/include/nlohmann /usr/include/xxhash.h /usr/include/CLI)
for h in "${headers[@]}"; do
    [[ -e "$h" ]] || { echo "cross-check: missing $h (install nlohmann-json3-dev, libxxhash-dev, libcli11-dev)" >&2; missing=1; }
done
[[ $missing -eq 0 ]] || exit 3
[[ $regenerate -eq 1 || -f "$golden" ]] || { echo "cross-check: no golden file $golden (run with --regenerate)" >&2; exit 3; }

work=$(mktemp -d "${TMPDIR:-/tmp}/lockroll-cross.XXXXXX")
if [[ $keep -eq 1 ]]; then echo "cross-check: work directory $work"; else trap 'rm -rf "$work"' EXIT; fi
mkdir -p "$work/include/lockroll"
for h in "${headers[@]}"; do ln -s "$h" "$work/include/$(basename "$h")"; done
# sim/'s headers include each other as <lockroll/sim/...> (the installed spelling).
ln -s "$root/sim" "$work/include/lockroll/sim"

sources=("$root"/sim/*.cpp "$root/harness/match/scene_loader.cpp" "$root/tests/golden/golden_main.cpp")
common=(-std=c++20 -ffp-contract=off -fno-fast-math -w -I"$root" -I"$work/include")

now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }

# Builds target $1 into $work/$1/golden; compiles sources in parallel (up to $jobs at once).
build() {
    local t=$1 dir="$work/$1" cxx flags
    cxx=$(compiler_of "$t"); flags=$(flags_of "$t")
    mkdir -p "$dir"
    local pids=() objs=() i=0 failed=0
    for src in "${sources[@]}"; do
        local obj="$dir/$i.o"; i=$((i + 1)); objs+=("$obj")
        "$cxx" "${common[@]}" $flags -c "$src" -o "$obj" 2>"$obj.log" &
        pids+=($!)
        if [[ ${#pids[@]} -ge $jobs ]]; then wait "${pids[0]}" || failed=1; pids=("${pids[@]:1}"); fi
    done
    for p in "${pids[@]}"; do wait "$p" || failed=1; done
    if [[ $failed -ne 0 ]]; then cat "$dir"/*.log >&2; return 1; fi
    "$cxx" $flags "${objs[@]}" $(link_flags_of "$t") -o "$dir/$(exe_of "$t")" 2>"$dir/link.log" || { cat "$dir/link.log" >&2; return 1; }
}

# Prints the first differing data line between golden file $1 and output $2, if any.
first_difference() {
    awk 'FNR == 1 { f++ } /^#/ || /^$/ { next } f == 1 { w[++n] = $0; next } { g[++m] = $0 }
         END {
           k = (n > m) ? n : m
           for (i = 1; i <= k; i++) {
             a = (i <= n) ? w[i] : "(end of file)"; b = (i <= m) ? g[i] : "(no output)"
             if (a != b) { printf "data line %d: expected \"%s\", got \"%s\"", i, a, b; exit }
           }
         }' "$1" "$2"
}

start=$(now)
status=0
declare -A result
for t in "${targets[@]}"; do
    t0=$(now)
    if ! build "$t"; then
        echo "cross-check: $t: build failed" >&2
        exit 4
    fi
    t1=$(now)
    out="$work/$t/output.txt"
    # shellcheck disable=SC2046
    if ! $(runner_of "$t") "$work/$t/$(exe_of "$t")" --scene-dir "$root/harness/scenes" >"$out" 2>"$work/$t/stderr.txt"; then
        echo "cross-check: $t: golden runner failed:" >&2
        cat "$work/$t/stderr.txt" >&2
        exit 4
    fi
    t2=$(now)
    if [[ $regenerate -eq 1 && $t == gcc-O3 ]]; then
        {
            echo "# Golden checksums: \`scene frame checksum\` from tests/golden/golden_main.cpp (scripted"
            echo "# inputs, see docs/determinism.md). Every compiler and CPU must reproduce these lines;"
            echo "# regenerate only after an intended simulation change: scripts/cross-check.sh --regenerate"
            cat "$out"
        } >"$golden.tmp.$$"
        mv "$golden.tmp.$$" "$golden"
        echo "cross-check: regenerated $golden from $t ($(grep -vc '^#' "$golden") lines)"
    fi
    diff=$(first_difference "$golden" "$out")
    threads="none"
    workers=$(threads_of "$t")
    if [[ -z "$diff" && -n "$workers" ]]; then
        tout="$work/$t/output-threads.txt"
        # shellcheck disable=SC2046
        if ! $(runner_of "$t") "$work/$t/$(exe_of "$t")" --scene-dir "$root/harness/scenes" --workers "$workers" \
                >"$tout" 2>"$work/$t/stderr-threads.txt"; then
            echo "cross-check: $t: golden runner failed at $workers workers:" >&2
            cat "$work/$t/stderr-threads.txt" >&2
            exit 4
        fi
        diff=$(first_difference "$golden" "$tout")
        [[ -z "$diff" ]] || diff="$diff (at $workers workers)"
        threads="$workers workers match, $(elapsed "$t2" "$(now)")s"
    fi
    if [[ -z "$diff" ]]; then
        result[$t]="match"
        printf 'cross-check: %-16s match   (build %ss, run %ss; threads: %s)\n' "$t" "$(elapsed "$t0" "$t1")" \
            "$(elapsed "$t1" "$t2")" "$threads"
    else
        result[$t]="MISMATCH"
        printf 'cross-check: %-16s MISMATCH at %s\n' "$t" "$diff" >&2
        status=1
    fi
done
total=$(elapsed "$start" "$(now)")
if [[ $status -eq 0 ]]; then
    echo "cross-check: all ${#targets[@]} targets that ran reproduce $(grep -vc '^#' "$golden") golden checksums (${total}s)" \
         "$([[ ${#skipped[@]} -eq 0 ]] && echo "none skipped" || echo "skipped: ${skipped[*]}")"
else
    echo "cross-check: FAILED: $(for t in "${targets[@]}"; do [[ ${result[$t]} == match ]] || printf '%s ' "$t"; done)differ from $golden (${total}s)" >&2
fi
exit $status
