#!/usr/bin/env python3
"""Prints the per-task table of an msspr results JSON (msspr_eval --out)."""
import json
import sys

r = json.load(open(sys.argv[1]))
print(f"\n  {r.get('env', '?')} / {r.get('agent', '?')}: {r.get('episodes_per_task', '?')} episodes per task, "
      f"{r.get('max_steps', '?')} steps at most")
print("  task  start -> goal     success   mean steps to goal")
for t in r["tasks"]:
    if "start" in t and "goal" in t:  # custom tasks and cube-single: positions (m)
        s, g = t["start"], t["goal"]
        where = f"({s[0]:.2f},{s[1]:.2f}) -> ({g[0]:.2f},{g[1]:.2f})"
    else:
        s, g = t.get("start_cell", ["?", "?"]), t.get("goal_cell", ["?", "?"])
        where = f"({s[0]},{s[1]}) -> ({g[0]},{g[1]})"
    print(f"  {t['task_id']:>4}  {where}   {100 * t['success']:6.1f}%   "
          f"{t.get('mean_steps_successful', 0):8.1f}")
print(f"  mean success: {100 * r['mean_success']:.1f}%   (wall time {r.get('wall_time_s', 0):.1f} s)\n")
