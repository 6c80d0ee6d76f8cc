#!/bin/sh
# The ctest readme_commands (examples/CMakeLists.txt):
#   run_readme_commands.sh README.md SOURCE_DIR BUILD_DIR WORK_DIR
# Takes the shell block that follows "<!-- readme-commands -->" in README.md
# and runs it, unchanged, with `sh -e` in WORK_DIR laid out like the
# repository after the README's first command (tools/net_demo.sh, which
# builds in build/net-demo): build/net-demo is BUILD_DIR, tests/, tools/
# and scenarios/ are SOURCE_DIR's. Fails if the block is missing, runs no dkf-run or
# no dkf_compare.py, or any of its commands fails (dkf_compare.py exits 1 on
# a mismatch, on nothing compared and on only integer arrays compared).
set -eu
readme=$1 src=$2 build=$3 work=$4
rm -rf "$work"
mkdir -p "$work/build"
ln -s "$build" "$work/build/net-demo"
ln -s "$src/tests" "$work/tests"
ln -s "$src/tools" "$work/tools"
ln -s "$src/scenarios" "$work/scenarios"
awk '/^<!-- readme-commands -->$/ {on = 1; next}
     on && /^```sh$/ {inb = 1; next}
     inb && /^```$/ {exit}
     inb {print}' "$readme" > "$work/commands.sh"
runs=$(grep -c 'dkf-run ' "$work/commands.sh" || true)
compares=$(grep -c 'dkf_compare.py ' "$work/commands.sh" || true)
if [ "$runs" -eq 0 ] || [ "$compares" -eq 0 ]; then
  echo "readme_commands: README.md has no <!-- readme-commands --> block with dkf-run and" \
       "dkf_compare.py commands" >&2
  exit 1
fi
cd "$work"
sh -ex ./commands.sh
echo "readme_commands: $runs dkf-run and $compares dkf_compare.py commands of README.md passed"
