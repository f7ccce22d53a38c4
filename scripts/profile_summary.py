#!/usr/bin/env python3
"""Sums a LibTorch autograd-profiler chrome trace (msspr_bench_core --profile)
per op: self time (the op's time less the ops it called), calls, and the
share of the profiled wall time. Usage: profile_summary.py TRACE [STEPS] [TOP]"""
import json
import sys
from collections import defaultdict


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    path = sys.argv[1]
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    top = int(sys.argv[3]) if len(sys.argv) > 3 else 25
    try:
        with open(path) as f:
            text = f.read().strip()
        # The legacy profiler may leave a trailing comma before the closing bracket.
        if text.endswith(',]'):
            text = text[:-2] + ']'
        events = json.loads(text)
    except (OSError, ValueError) as e:
        print(f"profile_summary: cannot read {path}: {e}", file=sys.stderr)
        return 1
    if isinstance(events, dict):
        events = events.get('traceEvents', [])
    spans = defaultdict(list)
    for e in events:
        if e.get('ph') == 'X' and 'dur' in e:
            spans[e.get('tid', 0)].append((float(e['ts']), float(e['dur']), e['name']))
    self_time = defaultdict(float)
    calls = defaultdict(int)
    wall = 0.0
    for tid, evs in spans.items():
        evs.sort(key=lambda x: (x[0], -x[1]))
        stack = []  # [end, name, child_time]
        lo, hi = float('inf'), 0.0
        def pop():
            end, name, child, dur = stack.pop()
            self_time[name] += dur - child
            if stack:
                stack[-1][2] += dur
        for ts, dur, name in evs:
            lo, hi = min(lo, ts), max(hi, ts + dur)
            while stack and stack[-1][0] <= ts:
                pop()
            stack.append([ts + dur, name, 0.0, dur])
            calls[name] += 1
        while stack:
            pop()
        wall = max(wall, hi - lo)
    total = sum(self_time.values())
    print(f"{path}: {steps} steps, {wall / 1000 / steps:.1f} ms/step wall in the profiled ops, "
          f"{total / 1000 / steps:.1f} ms/step of op self time")
    print(f"{'op':40s} {'ms/step':>8s} {'share':>6s} {'calls/step':>10s}")
    for name, t in sorted(self_time.items(), key=lambda kv: -kv[1])[:top]:
        print(f"{name[:40]:40s} {t / 1000 / steps:8.2f} {100 * t / total:5.1f}% {calls[name] / steps:10.0f}")
    return 0


if __name__ == '__main__':
    sys.exit(main())
