#!/usr/bin/env bash
# Checks that every .h/.cc of the project is formatted as .clang-format says
# (Google style, as COLMAP). Lists the files that differ and exits non-zero.
#   scripts/check_format.sh          # check
#   scripts/check_format.sh --fix    # reformat in place
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v clang-format > /dev/null; then
  echo "clang-format not found (Debian: apt-get install clang-format)" >&2
  exit 2
fi
mapfile -t files < <(git ls-files '*.h' '*.cc')
if [ "${1:-}" = "--fix" ]; then
  clang-format -i "${files[@]}"
  exit 0
fi
bad=()
for file in "${files[@]}"; do
  if ! clang-format --dry-run --Werror "$file" > /dev/null 2>&1; then
    bad+=("$file")
  fi
done
if [ ${#bad[@]} -gt 0 ]; then
  echo "${#bad[@]} of ${#files[@]} files differ from clang-format $(clang-format --version | grep -o '[0-9][0-9.]*' | head -1):" >&2
  printf '  %s\n' "${bad[@]}" >&2
  echo "Run: bash scripts/check_format.sh --fix" >&2
  exit 1
fi
echo "clang-format: all ${#files[@]} files formatted"
