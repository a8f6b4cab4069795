#!/usr/bin/env python3
"""bench/udp_echo, plain and batched (--batch N), as a real process on 127.0.0.1.

relay_bench compares the relay server's CPU with this echo's (docs/performance.md, "Density");
the comparison is fair only if the echo sends back every datagram it is sent, exactly once, to
its own sender, bytes unchanged, and the batched echo really batches. Checked here, per mode:
(and --batch N --pass-us P, passes as the server's) four client sockets send numbered datagrams of varied lengths, in bursts queued while the echo
is stopped (SIGSTOP) so that a batched receive finds many waiting; each socket must get back
exactly the datagrams it sent, each once, and nothing more after a quiet wait; on SIGTERM the
echo exits 0 and its count line (stderr) says every datagram came in and went out, and with
--batch N that it took them in at most one receive call per N (rounded up per burst).
With --pass-us, SIGTERM while a pass sleeps ends the echo too (not a read that blocks for good
once the traffic has stopped: relay_bench would wait and kill it, losing its count line).
Bad flags exit 2.

usage: udp_echo_test.py build/bench/udp_echo
"""
import collections
import re
import select
import signal
import socket
import subprocess
import sys
import time

SOCKETS = 4
BURSTS = 3
PER_BURST = 51  # per socket: 204 queued a burst, not a multiple of the batch sizes tried


def start(echo, args):
    p = subprocess.Popen([echo] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    ready, _, _ = select.select([p.stdout], [], [], 10)
    line = p.stdout.readline().decode() if ready else ""
    m = re.match(r"ready (\d+)", line)
    if not m:
        p.kill()
        raise SystemExit(f"FAIL: {echo} {args}: no 'ready PORT' line (got {line!r})")
    return p, int(m.group(1))


def check_mode(echo, args, batch):
    failures = []
    p, port = start(echo, args)
    socks = []
    for _ in range(SOCKETS):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        s.bind(("127.0.0.1", 0))
        s.setblocking(False)
        socks.append(s)
    sent = [collections.Counter() for _ in socks]
    got = [collections.Counter() for _ in socks]
    total = 0
    for burst in range(BURSTS):
        p.send_signal(signal.SIGSTOP)  # the burst queues: a batched receive finds it waiting
        time.sleep(0.05)
        for i in range(PER_BURST):
            for k, s in enumerate(socks):
                n = burst * PER_BURST + i
                payload = f"{k}:{n}:".encode() + bytes([n % 251]) * ((n * 37 + k) % 300)
                s.sendto(payload, ("127.0.0.1", port))
                sent[k][payload] += 1
                total += 1
        p.send_signal(signal.SIGCONT)
        deadline = time.time() + 5
        while sum(sum(c.values()) for c in got) < total and time.time() < deadline:
            ready, _, _ = select.select(socks, [], [], 0.1)
            for s in ready:
                k = socks.index(s)
                while True:
                    try:
                        data, frm = s.recvfrom(4096)
                    except BlockingIOError:
                        break
                    if frm != ("127.0.0.1", port):
                        failures.append(f"socket {k}: a datagram from {frm}, not the echo")
                    got[k][data] += 1
    time.sleep(0.3)  # anything sent twice or late arrives now
    for k, s in enumerate(socks):
        while True:
            try:
                data, _ = s.recvfrom(4096)
            except BlockingIOError:
                break
            got[k][data] += 1
    for k in range(SOCKETS):
        missing = sent[k] - got[k]
        extra = got[k] - sent[k]
        if missing:
            failures.append(f"socket {k}: {sum(missing.values())} of its {sum(sent[k].values())} datagrams not echoed")
        if extra:
            failures.append(f"socket {k}: {sum(extra.values())} datagrams it did not send once (duplicates or others')")
    p.send_signal(signal.SIGTERM)
    try:
        status = p.wait(timeout=5)
    except subprocess.TimeoutExpired:
        p.kill()
        status = "none (killed after 5 s)"
    err = p.stderr.read().decode()
    if status != 0:
        failures.append(f"exit status {status} on SIGTERM, expected 0")
    m = re.search(r"(\d+) datagrams in, (\d+) echoed, (\d+) receive calls, (\d+) send calls", err)
    if not m:
        failures.append(f"no count line on stderr: {err!r}")
    else:
        d_in, d_out, receives, sends = map(int, m.groups())
        if d_in != total or d_out != total:
            failures.append(f"count line says {d_in} in, {d_out} echoed; {total} were sent")
        if batch:
            # Each burst of SOCKETS * PER_BURST waits whole: ceil(burst / batch) receives take it,
            # plus the receive each burst's wait ends in (and one interrupted by SIGTERM).
            most = BURSTS * (-(-SOCKETS * PER_BURST // batch) + 1) + 1
            if receives > most:
                failures.append(f"--batch {batch}: {receives} receive calls for {d_in} datagrams, at most {most} if batched")
            if sends > receives:
                failures.append(f"--batch {batch}: {sends} send calls for {receives} receives, expected one sendmmsg a batch")
    for s in socks:
        s.close()
    name = " ".join(args) or "plain"
    print(f"{name}: {total} datagrams sent, {sum(sum(c.values()) for c in got)} echoed back"
          + (f"; echo's count: {m.group(0)}" if m else ""))
    return [f"{name}: {f}" for f in failures]


def check_term_in_pass_sleep(echo):
    # 100 ms passes: after B's echo the next pass sleeps until ~100 ms after B's pass began,
    # and the SIGTERM sent as soon as B is back lands in that sleep.
    p, port = start(echo, ["--batch", "8", "--pass-us", "100000"])
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.settimeout(2)
    failures = []
    try:
        for payload in (b"A", b"B"):
            s.sendto(payload, ("127.0.0.1", port))
            if s.recvfrom(64)[0] != payload:
                failures.append(f"--pass-us: {payload!r} not echoed as sent")
    except socket.timeout:
        failures.append("--pass-us: no echo within 2 s")
    p.send_signal(signal.SIGTERM)
    try:
        status = p.wait(timeout=2)
        if status != 0:
            failures.append(f"--pass-us: exit status {status} on SIGTERM in a pass's sleep, expected 0")
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()
        failures.append("--pass-us: still running 2 s after SIGTERM in a pass's sleep")
    s.close()
    return failures


def check_bad_flags(echo):
    failures = []
    for args in (["--batch", "0"], ["--batch", "1025"], ["--batch", "x"], ["--batch"], ["--port", "70000"], ["--pass-us", "1000"],
                 ["--batch", "8", "--pass-us", "-1"], ["--bogus"]):
        r = subprocess.run([echo] + args, capture_output=True, timeout=10)
        if r.returncode != 2:
            failures.append(f"{' '.join(args)}: exit status {r.returncode}, expected 2")
    return failures


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    echo = sys.argv[1]
    failures = check_mode(echo, [], 0)
    failures += check_mode(echo, ["--batch", "8"], 8)
    failures += check_mode(echo, ["--batch", "64"], 64)
    failures += check_mode(echo, ["--batch", "8", "--pass-us", "2000"], 8)
    failures += check_term_in_pass_sleep(echo)
    failures += check_bad_flags(echo)
    for f in failures:
        print("FAIL:", f)
    if failures:
        sys.exit(1)
    print("udp_echo: ok")


if __name__ == "__main__":
    main()
