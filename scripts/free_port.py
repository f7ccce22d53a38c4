#!/usr/bin/env python3
"""Prints a TCP port on 127.0.0.1 that is free now, for a private ROS master.

usage: scripts/free_port.py [SEED]

Ports are drawn from 20000-32767, below Linux's ephemeral range (32768-60999), where
outgoing connections take their local ports; SEED (default: the parent's PID) makes the
draw differ between concurrent callers. Each candidate is checked by binding it.
"""
import os
import random
import socket
import sys


def main():
    seed = int(sys.argv[1]) if len(sys.argv) > 1 else os.getppid()
    rng = random.Random(seed)
    for _ in range(500):
        port = rng.randrange(20000, 32768)
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
        print(port)
        return 0
    print("free_port: no free port in 20000-32767", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
