#!/usr/bin/env bash
# The CLI's fingerprint, for refactors that must not change behaviour: one line per run,
# the md5 of its stdout + stderr + exit code, over HT0, HT1, HT2, FB1 x every scheme, order
# and composition (359 runs, ~30 s). Compare two builds with
#   diff <(bash scripts/cli_fingerprint.sh OLD/trompo-simulate) <(bash scripts/cli_fingerprint.sh NEW/trompo-simulate)
sim=$1
cases="ht0 ht1 ht2 fb1"
run() { local out; out=$( { "$sim" "$@" 2>&1; echo "rc=$?"; } | md5sum | cut -c1-32); echo "$out $*"; }
for c in $cases; do
  for s in simo-kappa simo-collocation geradin-bauchau geradin-bauchau-paper lie-gen-alpha constrained-trapezoid energy-decaying; do
    for o in 2 4 6; do run --case $c --scheme $s --order $o --t-end 0.3 --every 7; done
    for comp in triple-jump suzuki-5 kahan-li-9 mclachlan-15 kahan-li-17 blanes-casas-murua-13; do run --case $c --scheme $s --composition $comp --t-end 0.3 --every 7; done
  done
  run --case $c --scheme simo-alpha --t-end 0.3 --every 7
  run --case $c --scheme simo-alpha --alpha 0.7 --t-end 0.3 --every 7
  run --case $c --scheme rk4 --t-end 0.3 --every 7
  run --case $c --scheme exact --t-end 0.3 --every 7
  run --case $c --scheme lie-gen-alpha --rho-inf 0.5 --t-end 0.3 --every 7
  run --case $c --scheme energy-decaying --chi 0.3 --t-end 0.3 --every 7
  run --case $c --scheme energy-decaying --chi-schedule sensor --t-end 0.3 --every 7
  for o in 2 4 6; do run --case $c --scheme splitting --order $o --t-end 0.3 --every 7; run --case $c --scheme splitting --order $o --energy-projection --t-end 0.3 --every 7; done
  for comp in strang chin-4a chin-triple-jump suzuki-5 kahan-li-9; do run --case $c --scheme splitting --composition $comp --t-end 0.3 --every 7; run --case $c --scheme splitting --composition $comp --energy-projection --t-end 0.3 --every 7; done
  run --case $c --scheme simo-kappa --damping 0.3 --t-end 0.3 --every 7
  run --case $c --scheme simo-kappa --torque 0.1,0.2,0.3 --rotor 0,0,1 --t-end 0.3 --every 7
  run --case $c --scheme splitting --damping 0.3 --t-end 0.3 --every 7
done
run --case ht1 --scheme simo-kappa --dt 0 --t-end 1
run --inertia 1,2,3 --omega 1,2,3 --dt 0.01 --t-end 0.5 --scheme simo-kappa
run --inertia 1,2,3,0.1,0.05,0.02 --omega 1,2,3 --dt 0.01 --t-end 0.5 --scheme splitting --composition chin-4a
