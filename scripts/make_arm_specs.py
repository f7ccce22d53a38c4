#!/usr/bin/env python3
"""Writes the robot interface specs of the arm's puzzles (config/robots/ur5e_puzzle_3x3.yaml,
ur5e_puzzle_4x4.yaml) from config/robots/ur5e_cube.yaml: its arm fields (the observation's first
19 numbers), goal and commands, with four fields per button in place of the cube's (the state
one-hot from the JointState effort, 120 x the cap's slide, its velocity). Run it after changing
ur5e_cube.yaml's arm part:  scripts/make_arm_specs.py
With --check it writes nothing and exits 1 when a shipped spec differs from what it would write.
"""
import os
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
ROBOTS = os.path.join(ROOT, "config", "robots")


def button_fields(k, first):
    joint = f"buttonbox_joint_{k}"
    common = f"    topic: buttons/joint_states\n    type: sensor_msgs/JointState\n"
    return (f"  - name: button_{k}_off          # [{first}] 1 in state 0 (1 - state)\n{common}"
            f"    field: effort\n    joints: [{joint}]\n    offset: 1.0\n    scale: -1.0\n"
            f"  - name: button_{k}_on           # [{first + 1}] 1 in state 1\n{common}"
            f"    field: effort\n    joints: [{joint}]\n"
            f"  - name: button_{k}_position     # [{first + 2}] 120 * the cap's slide (m)\n{common}"
            f"    field: position\n    joints: [{joint}]\n    scale: 120.0\n"
            f"  - name: button_{k}_velocity     # [{first + 3}] m/s\n{common}"
            f"    field: velocity\n    joints: [{joint}]\n")


def main():
    check = sys.argv[1:] == ["--check"]
    if sys.argv[1:] and not check:
        sys.exit("usage: make_arm_specs.py [--check]")
    stale = []
    cube = open(os.path.join(ROBOTS, "ur5e_cube.yaml")).read()
    body = cube[cube.index("control_rate:"):]
    arm = body[:body.index("  - name: cube_position")]
    rest = body[body.index("goal:\n"):]
    for side in (3, 4):
        n = side * side
        dim = 19 + 4 * n
        head = (f"# Robot interface spec (docs/bring_your_own_robot.md): the UR5e with its gripper at OGBench's\n"
                f"# puzzle-{side}x{side} (env puzzle-{side}x{side}: a {side} x {side} grid of push buttons), over standard\n"
                f"# messages only. Written by scripts/make_arm_specs.py from ur5e_cube.yaml: edit that, then run it.\n"
                f"# It assembles the {dim} numbers of the puzzle's observation from ur5e_cube.yaml's arm topics\n"
                f"# (joint_states, tf2 world -> pinch_controller, gripper/joint_states) and\n"
                f"#   buttons/joint_states    sensor_msgs/JointState of buttonbox_joint_0 .. _{n - 1} (row by row):\n"
                f"#                           the cap's slide (m, 0 up), its velocity and, as effort, the\n"
                f"#                           button's state 0 or 1.\n"
                f"# The goal is a full observation (std_msgs/Float64MultiArray, {dim} numbers) on goal_observation;\n"
                f"# the commands are ur5e_cube.yaml's (ee_twist, gripper_command). msspr_sim_node\n"
                f"# ~env puzzle-{side}x{side} publishes and takes all of these.\n"
                f"name: ur5e_puzzle_{side}x{side}\n")
        text = head + arm + "".join(button_fields(k, 19 + 4 * k) for k in range(n)) + rest
        path = os.path.join(ROBOTS, f"ur5e_puzzle_{side}x{side}.yaml")
        if check:
            old = open(path).read() if os.path.exists(path) else None
            if old != text:
                stale.append(os.path.relpath(path, ROOT))
            continue
        with open(path, "w") as f:
            f.write(text)
        print(f"wrote {os.path.relpath(path, ROOT)} ({dim} numbers)")
    if stale:
        sys.exit("make_arm_specs: " + ", ".join(stale) + " differ from ur5e_cube.yaml's arm part: "
                 "run scripts/make_arm_specs.py")
    if check:
        print("make_arm_specs: the puzzle specs match ur5e_cube.yaml")


if __name__ == "__main__":
    main()
