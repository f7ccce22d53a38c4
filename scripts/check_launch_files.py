#!/usr/bin/env python3
"""Checks that every launch file and rostest file is well-formed XML whose
$(find msspr) paths exist: a malformed file fails only when someone launches
it. Usage: check_launch_files.py REPO_ROOT. Exit 1 naming each bad file."""
import glob
import os
import re
import sys
import xml.dom.minidom

root = sys.argv[1] if len(sys.argv) > 1 else "."
files = sorted(glob.glob(os.path.join(root, "launch", "*.launch")) + glob.glob(os.path.join(root, "tests", "ros", "*.test")))
bad = 0
for f in files:
    try:
        xml.dom.minidom.parse(f)
    except Exception as e:  # xml.parsers.expat.ExpatError
        print(f"{f}: not well-formed XML: {e}")
        bad += 1
        continue
    for rel in re.findall(r"\$\(find msspr\)/([^\"'\s)]+)", open(f).read()):
        if "$(" in rel:
            continue
        if not os.path.exists(os.path.join(root, rel)):
            print(f"{f}: $(find msspr)/{rel} does not exist")
            bad += 1
print(f"{len(files)} launch and test files checked, {bad} problem(s)")
sys.exit(1 if bad else 0)
