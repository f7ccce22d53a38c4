#!/usr/bin/env bash
# Fails if a C++ file of the package (every folder with C++: msspr_core, msspr_sim,
# msspr_policy_node, tests) differs from what clang-format makes of it with
# the repository's .clang-format. `make format` reformats every C++ file;
# `scripts/check_format.sh DIR...` checks other directories.
set -u
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root" || exit 1
if ! command -v clang-format >/dev/null 2>&1; then
  echo "check_format: clang-format is not installed (make deps installs it)" >&2
  exit 1
fi
dirs=("$@")
[ ${#dirs[@]} -eq 0 ] && dirs=(msspr_core msspr_sim msspr_policy_node tests)
bad=()
n=0
while IFS= read -r f; do
  n=$((n + 1))
  clang-format --dry-run -Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done < <(find "${dirs[@]}" \( -name '*.h' -o -name '*.cc' \) -not -path '*/build*' | sort)
if [ ${#bad[@]} -gt 0 ]; then
  echo "check_format: ${#bad[@]} of $n files are not clang-formatted (run: clang-format -i FILE):" >&2
  printf '  %s\n' "${bad[@]}" >&2
  exit 1
fi
echo "check_format: $n files in ${dirs[*]} are clang-formatted"
