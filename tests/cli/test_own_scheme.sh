#!/usr/bin/env bash
# One registry line puts a scheme into every tool: the scheme of examples/own_scheme.hpp,
# appended to trompo::RegisteredSchemes in a test build (tests/support/register_own_scheme.hpp),
# runs in that build's CLI (plain, composed, processed; refused on the heavy top, as its
# entry says: free body only) and in the generic property suite (built so), with no other edit.
#   test_own_scheme.sh <trompo-simulate built so> <test_properties_numbers> <test_properties_contracts>
set -u
sim="$1"
numbers="$2"
contracts="$3"
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

check "--help lists my-midpoint" '"$sim" --help | grep -q "|my-midpoint|"'
"$sim" --case fb1 --scheme my-midpoint --t-end 5 --every 100 >"$tmp/own.csv" 2>"$tmp/own.err"; rc=$?
check "--scheme my-midpoint on FB1: exit 0, 6 rows" '[ $rc -eq 0 ] && [ $(($(wc -l <"$tmp/own.csv") - 1)) -eq 6 ]'
check "my-midpoint keeps H on the free body (1e-12)" 'awk -F, "NR==2{h=\$14} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>1e-12) bad=1} END{exit bad}" "$tmp/own.csv"'
for comp in suzuki-5 blanes-casas-murua-13; do
  "$sim" --case fb1 --scheme my-midpoint --composition $comp --t-end 1 --every 10 >"$tmp/own_$comp.csv" 2>&1; rc=$?
  check "--scheme my-midpoint --composition $comp: exit 0, 11 rows" '[ $rc -eq 0 ] && [ $(($(wc -l <"$tmp/own_$comp.csv") - 1)) -eq 11 ]'
done
"$sim" --case ht1 --scheme my-midpoint >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
check "--scheme my-midpoint on the heavy top: exit 2, the free body only" '[ $rc -eq 2 ] && grep -q "free body only" "$tmp/bad.err"'

for what in order invariants; do
  check "the generic suite ran my-midpoint: [$what]" '"$numbers" -s "[$what]" | grep -q "scheme my-midpoint"'
done
for what in failure backward no_alloc; do
  check "the generic suite ran my-midpoint: [$what]" '"$contracts" -s "[$what]" | grep -q "scheme my-midpoint"'
done
echo "own scheme: $fails failed"
[ $fails -eq 0 ]
