#!/usr/bin/env python3
"""Checks that package.xml and CMakeLists.txt's find_package(catkin COMPONENTS ...) name
exactly the ROS packages whose headers the package's code includes.

usage: check_ros_deps.py [PACKAGE_ROOT]

A header <p/...> is a ROS package's when p is declared in package.xml or when
/usr/share/p/package.xml exists (Debian's ROS installs each package's manifest there);
<ros/...> is roscpp's, <urdf_parser/...> urdfdom's. Fails (exit 1), naming each file, for a package that is included but
not declared (it builds only because Debian puts every header in /usr/include), and for one
that is declared but never included. message_generation and message_runtime are declared
for the messages in msgs/, not for a header.
"""
import os
import re
import sys
import xml.etree.ElementTree as ET

# The package's code: package.xml declares what any of it includes.
CODE_DIRS = ["msspr_core", "msspr_sim", "msspr_policy_node", "tests"]
# Headers whose folder is not their package's name.
HEADER_ALIASES = {"ros": "roscpp", "urdf_parser": "urdfdom", "urdf_model": "urdfdom"}
NOT_A_HEADER = {"message_generation", "message_runtime", "catkin"}
# Non-catkin libraries (found by CMake, not catkin): package.xml declares them, CMake
# does not list them among catkin's components.
SYSTEM_ONLY = {"urdfdom", "eigen", "yaml-cpp", "zlib", "bzip2", "libopencv-dev"}
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([A-Za-z0-9_]+)/', re.M)


def declared_in_package_xml(root):
    tree = ET.parse(os.path.join(root, "package.xml"))
    name = tree.getroot().findtext("name")
    deps = set()
    for tag in ("depend", "build_depend"):
        deps |= {e.text.strip() for e in tree.getroot().iter(tag)}
    return name, deps


def declared_in_cmake(root):
    text = open(os.path.join(root, "CMakeLists.txt")).read()
    m = re.search(r"find_package\(\s*catkin\s+REQUIRED\s+COMPONENTS\s+([^)]*)\)", text)
    if not m:
        return None
    return set(re.sub(r"#[^\n]*", "", m.group(1)).split())


def included(root, is_ros):
    found = {}
    for d in CODE_DIRS:
        for dirpath, _, files in os.walk(os.path.join(root, d)):
            for f in files:
                if not f.endswith((".h", ".hpp", ".cc", ".cpp")):
                    continue
                path = os.path.join(dirpath, f)
                with open(path, errors="replace") as fh:
                    for p in INCLUDE.findall(fh.read()):
                        p = HEADER_ALIASES.get(p, p)
                        if is_ros(p):
                            found.setdefault(p, []).append(os.path.relpath(path, root))
    return found


def main(argv):
    root = os.path.abspath(argv[1] if len(argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    name, xml_deps = declared_in_package_xml(root)
    cmake_deps = declared_in_cmake(root)
    if cmake_deps is None:
        print("check_ros_deps: CMakeLists.txt has no find_package(catkin REQUIRED COMPONENTS ...)")
        return 1

    def is_ros(p):
        return p != name and (p in xml_deps or os.path.exists(f"/usr/share/{p}/package.xml"))

    used = included(root, is_ros)
    problems = []
    for p in sorted(used):
        where = ", ".join(sorted(set(used[p]))[:3]) + (" ..." if len(set(used[p])) > 3 else "")
        if p not in xml_deps:
            problems.append(f"package.xml does not declare {p}, which {where} include(s)")
        if p not in cmake_deps and p not in SYSTEM_ONLY:
            problems.append(f"CMakeLists.txt's find_package(catkin COMPONENTS ...) lacks {p}, "
                            f"which {where} include(s)")
    for p in sorted((xml_deps | cmake_deps) - set(used) - NOT_A_HEADER):
        if os.path.exists(f"/usr/share/{p}/package.xml") or p in cmake_deps:
            if p not in cmake_deps and p in SYSTEM_ONLY:
                continue
            problems.append(f"{p} is declared ({'package.xml' if p in xml_deps else ''}"
                            f"{' and ' if p in xml_deps and p in cmake_deps else ''}"
                            f"{'CMakeLists.txt' if p in cmake_deps else ''}) but no header of it is included")
    for line in problems:
        print("check_ros_deps: " + line)
    print(f"check_ros_deps: {len(used)} ROS packages included by {', '.join(CODE_DIRS)}; "
          f"{len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
