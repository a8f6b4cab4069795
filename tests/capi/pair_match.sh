# Sourced by the binding tests (after tests/process_test_support.sh): one 2-process match of a
# counter game on 127.0.0.1 and the checks every binding must pass.
#   pair_match LAUNCH   runs `LAUNCH SLOT MY_PORT PEER_PORT` for slots 0 and 1 on free ports
#                       (LAUNCH bounds its process with timeout); the result lines go to
#                       $tmp/p0.out, $tmp/p1.out. Both must complete on one final checksum
#                       (left in $checksum) and one game value, and slot 0 must report
#                       synchronized; each failure is counted with fail.
#   field FILE KEY      the value after KEY on FILE's result line
field() { awk -v k="$2" '{for (i = 1; i < NF; i++) if ($i == k) print $(i + 1)}' "$1"; }
pair_match() {
    local launch=$1 a b c1
    local -a ports
    read -r -a ports <<<"$(python3 "$here/../net/free_ports.py" 2)"
    "$launch" 0 "${ports[0]}" "${ports[1]}" >"$tmp/p0.out" 2>"$tmp/p0.err" &
    a=$!
    "$launch" 1 "${ports[1]}" "${ports[0]}" >"$tmp/p1.out" 2>"$tmp/p1.err" &
    b=$!
    pids+=("$a" "$b")
    wait "$a" || fail "slot 0 exited $?: $(cat "$tmp/p0.out" "$tmp/p0.err")"
    wait "$b" || fail "slot 1 exited $?: $(cat "$tmp/p1.out" "$tmp/p1.err")"
    cat "$tmp/p0.out" "$tmp/p1.out"
    checksum=$(field "$tmp/p0.out" checksum) c1=$(field "$tmp/p1.out" checksum)
    [[ -n $checksum && $checksum != 0000000000000000 ]] || fail "no final checksum from slot 0"
    [[ $checksum == "$c1" ]] || fail "final checksums differ: $checksum vs $c1"
    [[ $(field "$tmp/p0.out" value) == "$(field "$tmp/p1.out" value)" ]] || fail "the games ended on different values"
    grep -q "completed" "$tmp/p0.out" && grep -q "completed" "$tmp/p1.out" || fail "a process did not complete"
    grep -q "event synchronized" "$tmp/p0.err" || fail "slot 0 never reported synchronized"
}
