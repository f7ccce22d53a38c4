#!/usr/bin/env python3
"""Markdown table of training runs from their eval.csv files.

usage: scripts/results_table.py [--last N] [--until-wall SECONDS] RUN_DIR [RUN_DIR ...]

For each run: the last evaluation's step, success per task and mean (OGBench's
protocol when the run evaluated 50 episodes per task), the mean over its last
N evaluations (default 3: OGBench's figure for a seed), the wall time (DIR.wall_s
when present, else the last wall_s in eval.csv) and, when DIR-custom50.json exists
(msspr_eval_inprocess --tasks-file config/eval_tasks_medium_random50.yaml --episodes 1
--out ...), the success on those custom tasks. --until-wall S keeps only the
evaluations made within S seconds of training (to compare agents at equal wall time).
Runs named <variant>-s<seed> are also grouped by variant: the mean over seeds of each
seed's last-N figure, +- half its spread (max - min) / 2, and min and max.
"""
import collections
import csv
import os
import re
import json
import sys


def read_eval(path):
    rows = collections.defaultdict(dict)
    with open(path) as f:
        for rec in csv.reader(f):
            if len(rec) != 3 or rec[0] == "step":
                continue
            rows[int(rec[0])][rec[1]] = float(rec[2])
    return {s: r for s, r in rows.items() if "mean_success" in r}


def main(argv):
    last_n, until = 3, None
    dirs = []
    it = iter(argv)
    for a in it:
        if a == "--last":
            last_n = int(next(it))
        elif a == "--until-wall":
            until = float(next(it))
        else:
            dirs.append(a)
    if not dirs or last_n < 1:
        print(__doc__, file=sys.stderr)
        return 2
    out = [f"| run | step | task 1 | task 2 | task 3 | task 4 | task 5 | mean | mean of last {last_n} evals | 50 random tasks | wall (min) |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    groups = collections.defaultdict(list)
    for d in dirs:
        ev = read_eval(os.path.join(d, "eval.csv"))
        if until is not None:
            ev = {k: r for k, r in ev.items() if r.get("wall_s", float("inf")) <= until}
        if not ev:
            print(f"{d}: no evaluation rows", file=sys.stderr)
            continue
        steps = sorted(ev)
        last = ev[steps[-1]]
        prev = [ev[s]["mean_success"] for s in steps[-last_n:]]
        wall = last.get("wall_s", float("nan"))
        if until is None and os.path.exists(d.rstrip("/") + ".wall_s"):
            wall = float(open(d.rstrip("/") + ".wall_s").read())
        tasks = " | ".join(f"{100 * last.get(f'success_task{t}', float('nan')):.0f}" for t in range(1, 6))
        name = os.path.basename(d.rstrip("/"))
        custom_path = d.rstrip("/") + "-custom50.json"
        custom = float("nan")
        if os.path.exists(custom_path):
            custom = 100 * json.load(open(custom_path))["mean_success"]
        out.append(f"| {name} | {steps[-1]} | {tasks} | **{100 * last['mean_success']:.1f}** | "
                   f"{100 * sum(prev) / len(prev):.1f} | {custom:.0f} | {wall / 60:.1f} |")
        m = re.match(r"(.+)-s(\d+)$", name)
        if m:
            groups[m.group(1)].append((100 * sum(prev) / len(prev), custom))
    print("\n".join(out))
    if groups:
        print(f"\n| variant | seeds | mean of last {last_n} evals, over seeds | min | max | 50 random tasks (mean) |"
              "\n|---|---|---|---|---|---|")
        for v, rows in groups.items():
            xs = [r[0] for r in rows]
            cs = [r[1] for r in rows]
            print(f"| {v} | {len(xs)} | {sum(xs) / len(xs):.1f} ± {(max(xs) - min(xs)) / 2:.1f} | {min(xs):.1f} | "
                  f"{max(xs):.1f} | {sum(cs) / len(cs):.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
