#!/usr/bin/env python3
"""Prints N distinct free UDP ports on 127.0.0.1 (bound together, then released).

Chosen below the kernel's ephemeral range from a random start, as harness/live/free_ports.h explains:
a port from that range can be handed to another process's unbound socket before our child binds
it; ports below it are never handed out by the kernel on its own.
"""
import random
import socket
import sys

LOWEST = 10000


def ephemeral_floor():
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as f:
            low = int(f.read().split()[0])
        return low if LOWEST < low <= 65535 else 32768
    except (OSError, ValueError, IndexError):
        return 32768


n = int(sys.argv[1])
floor = ephemeral_floor()
span = floor - LOWEST
start = random.randrange(span)
socks = []
for k in range(span):
    if len(socks) == n:
        break
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.bind(("127.0.0.1", LOWEST + (start + k) % span))
    except OSError:
        s.close()
        continue
    socks.append(s)
if len(socks) < n:
    sys.exit(f"free_ports: cannot find {n} free UDP ports on 127.0.0.1 below {floor}")
# Released before they are printed: a caller reading the line through a pipe (`read < <(...)`)
# starts binding at once, possibly before this process has exited.
ports = [s.getsockname()[1] for s in socks]
for s in socks:
    s.close()
print(" ".join(str(p) for p in ports), flush=True)
