#!/usr/bin/env python3
"""Sums a LibTorch autograd-profiler chrome trace (msspr_bench_core --profile)
per op: self time (the op's time less the ops it called), calls, and the
share of the profiled wall time. Usage: profile_summary.py TRACE [STEPS] [TOP]

profile_summary.py --count TRACE [STEPS]: the number of profiler events per
step instead, as one JSON line (scripts/count_ops.sh): every event; the ATen
ops (aten::*), all of them and the top-level ones (not called from inside
another ATen op: the dispatches the trainer and autograd make); the autograd
backward functions; the copy_/_to_copy (casts and copies) among the ATen ops;
and the ten most called ATen ops."""
import json
import sys
from collections import defaultdict


def load_events(path):
    with open(path) as f:
        text = f.read().strip()
    # The legacy profiler may leave a trailing comma before the closing bracket.
    if text.endswith(',]'):
        text = text[:-2] + ']'
    events = json.loads(text)
    if isinstance(events, dict):
        events = events.get('traceEvents', [])
    return events


def count(path, steps):
    spans = defaultdict(list)
    for e in load_events(path):
        if e.get('ph') == 'X' and 'dur' in e:
            spans[e.get('tid', 0)].append((float(e['ts']), float(e['dur']), e['name']))
    n = defaultdict(int)
    calls = defaultdict(int)
    for evs in spans.values():
        evs.sort(key=lambda x: (x[0], -x[1]))
        aten_ends = []  # ends of the enclosing ATen ops
        for ts, dur, name in evs:
            while aten_ends and aten_ends[-1] <= ts:
                aten_ends.pop()
            n['events'] += 1
            if name.startswith('aten::'):
                n['aten_ops'] += 1
                calls[name] += 1
                if not aten_ends:
                    n['aten_ops_top_level'] += 1
                if name in ('aten::copy_', 'aten::_to_copy'):
                    n['copy_and_to_copy'] += 1
                aten_ends.append(ts + dur)
            elif 'Backward' in name and not name.startswith('autograd::engine'):
                n['autograd_functions'] += 1
    out = {'trace': path, 'steps': steps, 'threads_seen': len(spans)}
    for k in ('events', 'aten_ops', 'aten_ops_top_level', 'copy_and_to_copy', 'autograd_functions'):
        out[k + '_per_step'] = round(n[k] / steps, 1)
    out['most_called_per_step'] = {k: round(v / steps, 1)
                                   for k, v in sorted(calls.items(), key=lambda kv: -kv[1])[:10]}
    print(json.dumps(out))
    return 0


def main():
    args = sys.argv[1:]
    counting = bool(args) and args[0] == '--count'
    if counting:
        args = args[1:]
    if not args:
        print(__doc__, file=sys.stderr)
        return 2
    path = args[0]
    steps = int(args[1]) if len(args) > 1 else 5
    top = int(args[2]) if len(args) > 2 else 25
    try:
        if counting:
            return count(path, steps)
        events = load_events(path)
    except (OSError, ValueError) as e:
        print(f"profile_summary: cannot read {path}: {e}", file=sys.stderr)
        return 1
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
