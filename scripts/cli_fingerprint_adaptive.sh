#!/usr/bin/env bash
# The adaptive driver's fingerprint, for refactors of drivers/adaptive.hpp and its parts that
# must not change behaviour: one line per run, the md5 of its stdout + stderr + exit code,
# over HT0, HT1, HT2, FB1 x schemes (Simo-kappa and the splitting at orders 2/4/6, Simo
# collocation, compositions, RK4, schemes with carried memory) x tolerances 1e-4, 1e-7,
# 1e-10 x both step controls, then the estimates, --tol-scope, events, --t-eval, a given
# first step and the defaults-pick path (the method picked without --scheme). The invariant
# hold is on in every run (it is the driver's default). Events are written to stderr, so
# they enter the hash. Compare two builds with
#   diff <(bash scripts/cli_fingerprint_adaptive.sh OLD/trompo-simulate) <(bash scripts/cli_fingerprint_adaptive.sh NEW/trompo-simulate)
sim=$1
cases="ht0 ht1 ht2 fb1"
run() { local out; out=$( { "$sim" "$@" 2>&1; echo "rc=$?"; } | md5sum | cut -c1-32); echo "$out $*"; }
methods=(
  "--scheme simo-kappa --order 2"
  "--scheme simo-kappa --order 4"
  "--scheme simo-kappa --order 6"
  "--scheme simo-kappa --composition kahan-li-17"
  "--scheme simo-collocation --order 4"
  "--scheme splitting --order 2"
  "--scheme splitting --order 4"
  "--scheme splitting --order 6"
  "--scheme splitting --composition chin-4a"
  "--scheme splitting --order 4 --energy-projection"
  "--scheme rk4"
)
for c in $cases; do
  for m in "${methods[@]}"; do
    for tol in 1e-4 1e-7 1e-10; do
      for ctl in tolerance reversible; do
        # shellcheck disable=SC2086
        run --case $c $m --rtol $tol --atol $tol --control $ctl --t-end 2 --every 13
      done
    done
  done
  # Lie group generalized-alpha (order 2, its memory carried): loose tolerances, a short span
  for tol in 1e-3 1e-4; do
    for ctl in tolerance reversible; do run --case $c --scheme lie-gen-alpha --rtol $tol --atol $tol --control $ctl --t-end 0.5 --every 13; done
  done
  run --case $c --scheme lie-gen-alpha --rtol 1e-4 --atol 1e-4 --estimate richardson --substeps 3 --t-end 0.5 --every 13
  run --case $c --scheme lie-gen-alpha --rtol 1e-4 --atol 1e-4 --t-end 0.5 --t-eval 0.1,0.25,0.5 \
    --event axis-crossing --event-csv /dev/stderr
  for m in "--scheme simo-kappa --order 2" "--scheme simo-kappa --order 4" "--scheme splitting --order 4" "--scheme splitting --order 4 --energy-projection"; do
    for est in defect richardson doubling "richardson --substeps 3"; do
      # shellcheck disable=SC2086
      run --case $c $m --rtol 1e-8 --atol 1e-8 --estimate $est --t-end 2 --every 13
    done
    # shellcheck disable=SC2086
    run --case $c $m --rtol 1e-8 --atol 1e-8 --tol-scope time --t-end 2 --every 13
    # shellcheck disable=SC2086
    run --case $c $m --rtol 1e-8 --atol 1e-8 --t-end 2 --t-eval 0.1,0.5,0.77,1.3,1.9,2
    for ctl in tolerance reversible; do
      # shellcheck disable=SC2086
      run --case $c $m --rtol 1e-8 --atol 1e-8 --control $ctl --t-end 3 --every 29 \
        --event nutation-max --event nutation-min:terminal:3 --event-csv /dev/stderr
      # shellcheck disable=SC2086
      run --case $c $m --rtol 1e-7 --atol 1e-9 --control $ctl --t-end 3 --every 29 \
        --event axis-crossing --event nutation-min --event-csv /dev/stderr
      # shellcheck disable=SC2086
      run --case $c $m --rtol 1e-9 --atol 1e-9 --control $ctl --t-end 3 --t-eval 0.25,1,2.5 \
        --event axis-crossing:terminal:2 --event-csv /dev/stderr
    done
    # shellcheck disable=SC2086
    run --case $c $m --rtol 1e-6 --atol 1e-8 --dt 0.001 --t-end 2 --every 13
  done
  for tol in 1e-5 1e-8 1e-11; do
    run --case $c --rtol $tol --t-end 2 --every 13
    run --case $c --rtol $tol --atol $tol --t-end 2 --every 13 --event nutation-max --event-csv /dev/stderr
  done
done
for tol in 1e-5 1e-8 1e-11; do
  run --inertia 1,2,3 --omega 1,2,3 --rtol $tol --t-end 2 --every 13
  run --inertia 1,2,3 --omega 0.1,3,0.1 --rtol $tol --t-end 10 --every 13 --event flip:terminal:2 --event-csv /dev/stderr
  run --inertia 1,2,3 --omega 1,2,3 --damping 0.3 --rtol $tol --atol $tol --t-end 2 --every 13
  run --inertia 1,2,3 --omega 1,2,3 --scheme simo-kappa --order 4 --rtol $tol --atol $tol --t-end 2 --every 13
  run --inertia 1,2,3 --omega 1,2,3 --scheme simo-kappa --order 4 --rtol $tol --atol $tol --control reversible --t-end 2 --every 13
done
