#!/usr/bin/env python3
"""Prints the per-task table of an msspr results JSON (msspr_eval --out)."""
import json
import sys

r = json.load(open(sys.argv[1]))
print(f"\n  {r.get('env', '?')} / {r.get('agent', '?')}: {r.get('episodes_per_task', '?')} episodes per task, "
      f"{r.get('max_steps', '?')} steps at most")
print("  task  start -> goal     success   mean steps to goal")


def board(states):
    """A puzzle board row by row, as msspr_eval prints it: 000/010/000."""
    side = round(len(states) ** 0.5)
    rows = [states[i:i + side] for i in range(0, len(states), side)]
    return "/".join("".join("1" if x > 0.5 else "0" for x in row) for row in rows)


for t in r["tasks"]:
    s, g = t.get("start", []), t.get("goal", [])
    if len(s) == 2 and len(g) == 2:  # custom tasks and cube-single: positions (m)
        where = f"({s[0]:.2f},{s[1]:.2f}) -> ({g[0]:.2f},{g[1]:.2f})"
    elif len(s) > 2 and len(s) == len(g):  # the puzzles' boards
        where = f"{board(s)}->{board(g)}"
    elif "start_cell" in t and "goal_cell" in t:  # the mazes' cells
        s, g = t["start_cell"], t["goal_cell"]
        where = f"({s[0]},{s[1]}) -> ({g[0]},{g[1]})"
    else:  # cube-double, the scene: the task's id says it
        where = ""
    print(f"  {t['task_id']:>4}  {where:<16}   {100 * t['success']:6.1f}%   "
          f"{t.get('mean_steps_successful', 0):8.1f}")
print(f"  mean success: {100 * r['mean_success']:.1f}%   (wall time {r.get('wall_time_s', 0):.1f} s)\n")
