# What the CLI tests share (sourced by tests/cli/test_*.sh, which set `sim` first):
# a temporary directory removed on exit, and check NAME CONDITION, which prints "ok" or
# "FAIL" with the name and counts the failures in $fails.
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
check() { if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; fails=$((fails + 1)); fi; }
