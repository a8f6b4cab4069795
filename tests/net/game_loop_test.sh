#!/usr/bin/env bash
# Two real processes on 127.0.0.1 (free ports), each a game that owns its loop and calls
# NetSession::update() once per drawn frame at its own rate, unlike the 60 Hz tick rate: one
# draws at 144 Hz (updates that run no tick, an interpolation fraction between them), the other
# at 30 Hz (two ticks per update). Both must complete on the same confirmed checksum. Then the
# same over a transport of the game's own (examples/counter/udp_socket_transport.h: plain UDP
# sockets, no ENet), handed to the builder with transport().
#   game_loop_test.sh GAME_LOOP_PEER
set -u
exe=$1
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../process_test_support.sh"

# pair NAME FRAMES HZ0 HZ1 [TRANSPORT]: the two processes' result lines in $tmp/NAME-p0.out, -p1.out.
pair() {
    local name=$1 frames=$2 hz0=$3 hz1=$4 kind=${5:-enet} ports
    read -r -a ports <<<"$(/usr/bin/python3 "$here/free_ports.py" 2)"
    timeout 60 "$exe" 0 "${ports[0]}" "${ports[1]}" "$frames" "$hz0" "$kind" >"$tmp/$name-p0.out" 2>"$tmp/$name-p0.err" &
    local a=$!
    timeout 60 "$exe" 1 "${ports[1]}" "${ports[0]}" "$frames" "$hz1" "$kind" >"$tmp/$name-p1.out" 2>"$tmp/$name-p1.err" &
    local b=$!
    pids+=("$a" "$b")
    wait "$a" || fail "$name: slot 0 exited $?: $(cat "$tmp/$name-p0.out" "$tmp/$name-p0.err")"
    wait "$b" || fail "$name: slot 1 exited $?: $(cat "$tmp/$name-p1.out" "$tmp/$name-p1.err")"
    cat "$tmp/$name-p0.out" "$tmp/$name-p1.out"
}
# field FILE KEY: the value after KEY on the result line.
field() { awk -v k="$2" '{for (i = 1; i < NF; i++) if ($i == k) print $(i + 1)}' "$1"; }

frames=240
pair rates "$frames" 144 30
c0=$(field "$tmp/rates-p0.out" final) c1=$(field "$tmp/rates-p1.out" final)
[[ -n $c0 && $c0 != 0000000000000000 ]] || fail "rates: no final checksum from slot 0"
[[ $c0 == "$c1" ]] || fail "rates: final checksums differ: $c0 vs $c1"
for k in 0 1; do
    [[ $(field "$tmp/rates-p$k.out" outcome) == completed ]] || fail "rates: slot $k did not complete"
    [[ $(field "$tmp/rates-p$k.out" interpolation_ok) == 1 ]] || fail "rates: slot $k had an interpolation outside [0, 1)"
    (($(field "$tmp/rates-p$k.out" ticks) >= frames)) || fail "rates: slot $k ran fewer ticks than frames"
    # frames(N) plays N frames: lingering for the last confirmations steps no further.
    [[ $(field "$tmp/rates-p$k.out" shown) == "$frames" ]] || fail "rates: slot $k showed frame $(field "$tmp/rates-p$k.out" shown), not $frames"
done
# The 144 Hz game had frames with no tick due; the 30 Hz game ran several ticks in one update.
(($(field "$tmp/rates-p0.out" idle_updates) > 0)) || fail "rates: the 144 Hz game never had an update without a tick"
(($(field "$tmp/rates-p1.out" most_per_update) >= 2)) || fail "rates: the 30 Hz game never ran two ticks in one update"

# Over plain UDP sockets of the game's own: the same outcome, and no ENet anywhere.
pair udp "$frames" 60 50 udp
u0=$(field "$tmp/udp-p0.out" final) u1=$(field "$tmp/udp-p1.out" final)
[[ -n $u0 && $u0 != 0000000000000000 ]] || fail "udp: no final checksum from slot 0"
[[ $u0 == "$u1" ]] || fail "udp: final checksums differ: $u0 vs $u1"
# The same game and inputs: the same match as over ENet.
[[ $u0 == "$c0" ]] || fail "udp: final checksum $u0 differs from ENet's $c0"
for k in 0 1; do
    [[ $(field "$tmp/udp-p$k.out" outcome) == completed ]] || fail "udp: slot $k did not complete"
    [[ $(field "$tmp/udp-p$k.out" transport) == udp ]] || fail "udp: slot $k did not use the game's own transport"
    (($(field "$tmp/udp-p$k.out" sent) > frames / 2)) || fail "udp: slot $k sent too few datagrams through the game's own transport"
done

# Bad arguments: exit 2 naming the argument, before anything is bound.
out=$("$exe" 0 7000 7001 240 0 2>&1); rc=$?
[[ $rc -eq 2 && $out == *"RENDER_HZ 0"* ]] || fail "bad RENDER_HZ -> $rc: $out"
out=$("$exe" 0 7000 7001 240 60 carrier-pigeon 2>&1); rc=$?
[[ $rc -eq 2 && $out == *"transport carrier-pigeon"* ]] || fail "bad transport -> $rc: $out"

[[ $failures -eq 0 ]] && echo "all passed" || echo "$failures failure(s)"
exit $((failures > 0))
