#!/usr/bin/env python3
"""Samples a soak run: every PERIOD seconds, the resident memory of the sim and
the policy node (from /proc) and the served rate, the commands the policy node
published on TOPIC in that window divided by its length (any message type:
subscribed as rospy.AnyMsg). Writes one CSV row per sample:

    t_s,sim_rss_kb,policy_rss_kb,commands,served_hz

and exits non-zero, naming the node, when one of the two processes dies.
Run by scripts/soak.sh:

    soak_sampler.py --sim-pid P --policy-pid P --topic /msspr/cmd_vel \
        --seconds 3600 --period 10 --out soak_samples.csv
"""
import argparse
import os
import sys
import threading
import time

import rospy


def rss_kb(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def alive(pid):
    try:
        os.kill(pid, 0)
        return True
    except OSError:
        return False


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sim-pid", type=int, required=True)
    p.add_argument("--policy-pid", type=int, required=True)
    p.add_argument("--topic", required=True, help="the policy node's command topic")
    p.add_argument("--seconds", type=float, required=True)
    p.add_argument("--period", type=float, default=10.0)
    p.add_argument("--out", required=True)
    a = p.parse_args()

    lock = threading.Lock()
    count = [0]

    def on_command(_msg):
        with lock:
            count[0] += 1

    rospy.init_node("msspr_soak_sampler", anonymous=True, disable_signals=True)
    rospy.Subscriber(a.topic, rospy.AnyMsg, on_command, queue_size=1000, tcp_nodelay=True)
    start = time.monotonic()
    last_t, last_count = 0.0, 0
    with open(a.out, "w") as out:
        out.write("t_s,sim_rss_kb,policy_rss_kb,commands,served_hz\n")
        while True:
            t = time.monotonic() - start
            for name, pid in (("sim", a.sim_pid), ("policy", a.policy_pid)):
                if not alive(pid):
                    print(f"[soak] the {name} node (pid {pid}) died at {t:.0f} s", file=sys.stderr)
                    return 1
            with lock:
                n = count[0]
            hz = (n - last_count) / (t - last_t) if t > last_t else 0.0
            out.write(f"{t:.1f},{rss_kb(a.sim_pid)},{rss_kb(a.policy_pid)},{n},{hz:.2f}\n")
            out.flush()
            last_t, last_count = t, n
            if t >= a.seconds:
                return 0
            time.sleep(max(0.0, min(a.period, a.seconds - t + 0.01)))


if __name__ == "__main__":
    sys.exit(main())
