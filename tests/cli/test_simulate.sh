#!/usr/bin/env bash
# trompo-simulate's contract: the CSV header, rows, --every, --csv, and exit codes
# 0 (done), 2 (invalid input: a one-line reason, no rows) and 3 (a step failed: rows
# up to the last good state, stderr names t and the reason).
set -u
sim="$1"
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
header='t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations'

"$sim" --case ht1 --scheme simo-kappa --t-end 1 --every 100 >"$tmp/ok.csv" 2>"$tmp/ok.err"; rc=$?
check "exit 0 on success" '[ $rc -eq 0 ]'
check "header exactly" '[ "$(head -1 "$tmp/ok.csv")" = "$header" ]'
check "t=0 plus every 100th of 1000 steps: 11 rows" '[ $(($(wc -l <"$tmp/ok.csv") - 1)) -eq 11 ]'
check "last row at t_end" '[ "$(tail -1 "$tmp/ok.csv" | cut -d, -f1)" = "1" ]'
check "t=0 row has 0 iterations" '[ "$(sed -n 2p "$tmp/ok.csv" | cut -d, -f19)" = "0" ]'
check "19 columns" '[ "$(tail -1 "$tmp/ok.csv" | awk -F, "{print NF}")" = "19" ]'
# Energy column constant to round-off for an energy-exact scheme.
check "H exact (simo-kappa)" 'awk -F, "NR==2{h=\$14} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>1e-12) bad=1} END{exit bad}" "$tmp/ok.csv"'

"$sim" --case fb1 --scheme rk4 --t-end 0.35 --dt 0.1 --every 100 --csv "$tmp/file.csv"; rc=$?
check "--csv writes a file; last step always written" '[ $rc -eq 0 ] && [ "$(tail -1 "$tmp/file.csv" | cut -d, -f1)" = "0.34999999999999998" ]'

for bad in "--case ht1 --inertia 1,1,5" "--case ht1 --dt 0" "--case ht1 --dt nan" "--case ht1 --omega 1,inf,0" \
           "--case ht1 --scheme euler" "--case ht1 --alpha 0.3" "--case ht1 --t-end -1" "--inertia 1,2,3 --dt 0.1" \
           "--case ht1 --com 0,0,0" "--case ht9" "--case ht1 --scheme simo-alpha --alpha 1.5" "--case ht1 --inertia 1,2,3,5,0,0" \
           "--case ht2 --scheme exact" "--case ht1 --scheme exact --damping 1" "--case ht1 --order 3" "--case ht1 --scheme rk4 --order 4" \
           "--case ht1 --damping nan" "--case ht1 --rotor 1,2" "--case ht1 --scheme simo-alpha --alpha 0.3 --order 4" \
           "--case ht1 --composition suzuki" "--case ht1 --composition suzuki-5 --order 6" \
           "--case ht1 --order 6 --composition suzuki-5" "--case ht1 --scheme rk4 --composition kahan-li-9"; do
  "$sim" $bad >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "exit 2, no rows, one-line reason: $bad" '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ]'
done

# The message names the flag at fault: an unknown scheme before the flags that need a
# particular one, and the flag that asked for the composition.
for bad in "--case ht1 --scheme simo-alfa --alpha 0.3:--scheme: unknown scheme 'simo-alfa'" \
           "--case ht1 --scheme lie-gen-alfa --rho-inf 0.5:--scheme: unknown scheme 'lie-gen-alfa'" \
           "--case ht1 --scheme energy-decay --chi 0.1:--scheme: unknown scheme 'energy-decay'" \
           "--case ht1 --scheme lie-gen-alpha --composition triple-jump:--composition triple-jump: order 4" \
           "--case ht1 --scheme energy-decaying --composition kahan-li-17:--composition kahan-li-17: order 8" \
           "--case ht1 --scheme rk4 --composition suzuki-5:--composition suzuki-5: order 4" \
           "--case ht1 --scheme lie-gen-alpha --order 4:--order: order 4"; do
  flags=${bad%%:*}; want=${bad#*:}
  "$sim" $flags >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "exit 2, one line naming the flag: $flags ($want)" \
    '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ] && grep -qF -- "$want" "$tmp/bad.err"'
done

# ---- splitting (--scheme splitting) ----
for bad in "--case ht1 --scheme splitting --composition triple-jump" "--case ht1 --scheme splitting --composition strang --order 4" \
           "--case ht1 --scheme splitting --damping 0.1 --composition chin-4a" "--case ht1 --scheme splitting --rotor 0,0,1 --energy-projection" \
           "--case ht1 --scheme simo-kappa --composition chin-4a" "--case ht1 --scheme simo-kappa --energy-projection" \
           "--case ht1 --scheme splitting --order 5"; do
  "$sim" $bad >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "exit 2, no rows, one-line reason: $bad" '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ]'
done
"$sim" --case ht1 --scheme splitting --order 4 --dt 0.01 --every 100000 >"$tmp/sp4.csv"; rc=$?
check "splitting order 4 (chin-4a): R00(10) within 1e-7 of the reference" '[ $rc -eq 0 ] && awk -F, "END{d=\$2+0.88035320824679323; if(d<0)d=-d; exit !(d<1e-7)}" "$tmp/sp4.csv"'
check "splitting: mu exact" 'awk -F, "NR==2{m=\$15} NR>2{d=\$15-m; if(d<0)d=-d; if(d>1e-12) bad=1} END{exit bad}" "$tmp/sp4.csv"'
"$sim" --case ht1 --scheme splitting --composition chin-triple-jump --energy-projection --dt 0.02 >"$tmp/spp.csv"; rc=$?
check "splitting --energy-projection: H exact" '[ $rc -eq 0 ] && awk -F, "NR==2{h=\$14} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>1e-14) bad=1} END{exit bad}" "$tmp/spp.csv"'
"$sim" --case ht1 --scheme splitting --damping 0.1 --order 6 --dt 0.01 >"$tmp/spd.csv"; rc=$?
check "splitting with damping (kahan-li-9 by default): runs" '[ $rc -eq 0 ] && [ $(wc -l <"$tmp/spd.csv") -eq 1002 ]'
# ---- end splitting ----

# ---- the compensated state (--compensated, docs/theory.md §18) ----
# HT0 over t = 10 in 10^6 steps: H and mu at the end within a few eps with it, far off without.
for mode in plain compensated; do
  extra=""; [ "$mode" = compensated ] && extra="--compensated"
  "$sim" --case ht0 --scheme simo-kappa $extra --dt 1e-5 --t-end 10 --every 1000000 >"$tmp/$mode.csv"; rc=$?
  check "--case ht0 $extra, 10^6 steps: runs" '[ $rc -eq 0 ] && [ $(wc -l <"$tmp/$mode.csv") -eq 3 ]'
done
dH() { awk -F, 'NR==2{h=$14; m=$15} NR==3{a=($14-h)/h; b=($15-m)/m; if(a<0)a=-a; if(b<0)b=-b; print (a>b?a:b)}' "$1"; }
check "--compensated: H and mu at t = 10 within 4e-15 ($(dH "$tmp/compensated.csv"))" \
  'awk -v d="$(dH "$tmp/compensated.csv")" "BEGIN{exit !(d <= 4e-15)}"'
check "plain: 10x further off ($(dH "$tmp/plain.csv"))" \
  'awk -v a="$(dH "$tmp/plain.csv")" -v b="$(dH "$tmp/compensated.csv")" "BEGIN{exit !(a >= 10 * b)}"'
# The LGVI carries the residue too: pi over 10^6 steps of FB1 within 1e-14 (issue 36's bound).
"$sim" --case fb1 --scheme lgvi --compensated --dt 0.01 --t-end 10000 --every 1000000 >"$tmp/lgvi.csv"; rc=$?
dpi() { awk -F, 'NR==2{a=$16; b=$17; c=$18} NR==3{d=sqrt(($16-a)^2+($17-b)^2+($18-c)^2)/sqrt(a*a+b*b+c*c); print d}' "$1"; }
check "--scheme lgvi --compensated, 10^6 steps of FB1: pi within 1e-14 ($(dpi "$tmp/lgvi.csv"))" \
  '[ $rc -eq 0 ] && awk -v d="$(dpi "$tmp/lgvi.csv")" "BEGIN{exit !(d <= 1e-14)}"'
"$sim" --case ht1 --scheme rk4 --compensated >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
check "--compensated with rk4: exit 2 naming the flag" '[ $rc -eq 2 ] && grep -qF -- "--compensated: only with --scheme simo-kappa" "$tmp/bad.err"'

# A step that sub-stepping cannot save: |Θ| = 1e6 rad even at h/1024.
"$sim" --case fb1 --omega 0,1e6,0 --dt 1 --t-end 2 >"$tmp/fail.csv" 2>"$tmp/fail.err"; rc=$?
check "exit 3 on a failed step" '[ $rc -eq 3 ]'
check "rows up to the last good state (t = 0)" '[ "$(head -1 "$tmp/fail.csv")" = "$header" ] && [ $(wc -l <"$tmp/fail.csv") -eq 2 ]'
check "stderr names t and the reason" 'grep -q "t = 0 .*wrong branch" "$tmp/fail.err"'

# HT0 at h = 0.2 (|Θ| ≈ 10 rad a step): recovered by sub-stepping, said on stderr.
"$sim" --case ht0 --dt 0.2 --t-end 1 --scheme simo-kappa >"$tmp/sub.csv" 2>"$tmp/sub.err"; rc=$?
check "sub-stepping recovers HT0 at h = 0.2" '[ $rc -eq 0 ] && [ $(wc -l <"$tmp/sub.csv") -eq 7 ]'
check "sub-stepping reported on stderr" 'grep -q "recovered by sub-stepping" "$tmp/sub.err"'
check "H exact through recovered steps" 'awk -F, "NR==2{h=\$14} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>1e-12) bad=1} END{exit bad}" "$tmp/sub.csv"'

# --scheme exact: the closed forms against the independent references at the final time.
"$sim" --case ht1 --scheme exact --every 100000 >"$tmp/exact.csv"; rc=$?
check "exact HT1 R00(10) = -0.88035320824679323 (reference)" '[ $rc -eq 0 ] && awk -F, "END{d=\$2+0.88035320824679323; if(d<0)d=-d; exit !(d<1e-12)}" "$tmp/exact.csv"'
"$sim" --case fb1 --scheme exact --every 100000 >"$tmp/exact.csv"; rc=$?
check "exact FB1 W2(100) = -1.9999933436136818 (reference)" '[ $rc -eq 0 ] && awk -F, "END{d=\$12+1.9999933436136818; if(d<0)d=-d; exit !(d<1e-11)}" "$tmp/exact.csv"'
check "exact rows have 0 iterations" 'awk -F, "NR>1 && \$19 != 0 {bad=1} END{exit bad}" "$tmp/exact.csv"'

# --order 4: closer to the closed form than order 2 at the same h.
"$sim" --case ht1 --scheme simo-kappa --dt 0.01 --every 100000 >"$tmp/o2.csv"
"$sim" --case ht1 --scheme simo-kappa --order 4 --dt 0.01 --every 100000 >"$tmp/o4.csv"
check "order 4 beats order 2 against the exact R00(10)" 'awk -F, -v a="$(tail -1 "$tmp/o2.csv" | cut -d, -f2)" -v b="$(tail -1 "$tmp/o4.csv" | cut -d, -f2)" "BEGIN{x=a+0.88035320824679323; y=b+0.88035320824679323; if(x<0)x=-x; if(y<0)y=-y; exit !(y < x/100)}"'
# --composition suzuki-5 (order 4, 5 sub-steps): closer again than the triple jump.
"$sim" --case ht1 --scheme simo-kappa --composition suzuki-5 --order 4 --dt 0.01 --every 100000 >"$tmp/o4s.csv"; rc=$?
check "suzuki-5 beats the triple jump against the exact R00(10)" '[ $rc -eq 0 ] && awk -F, -v a="$(tail -1 "$tmp/o4.csv" | cut -d, -f2)" -v b="$(tail -1 "$tmp/o4s.csv" | cut -d, -f2)" "BEGIN{x=a+0.88035320824679323; y=b+0.88035320824679323; if(x<0)x=-x; if(y<0)y=-y; exit !(y < x/10)}"'
# --composition kahan-li-17 (order 8, 17 sub-steps): closer than suzuki-5 at 2.5x the step.
"$sim" --case ht1 --scheme simo-kappa --composition kahan-li-17 --dt 0.025 --every 100000 >"$tmp/o8.csv"; rc=$?
check "kahan-li-17 at dt 0.025 beats suzuki-5 at dt 0.01 against the exact R00(10)" '[ $rc -eq 0 ] && awk -F, -v a="$(tail -1 "$tmp/o4s.csv" | cut -d, -f2)" -v b="$(tail -1 "$tmp/o8.csv" | cut -d, -f2)" "BEGIN{x=a+0.88035320824679323; y=b+0.88035320824679323; if(x<0)x=-x; if(y<0)y=-y; exit !(y < x)}"'
# --composition blanes-casas-murua-13 (processed order 6, 13 sub-steps per step): closer than
# kahan-li-9 (order 6, 9 sub-steps) at the same number of base steps per unit time.
"$sim" --case ht1 --scheme simo-kappa --composition kahan-li-9 --dt 0.02 --every 100000 >"$tmp/o6.csv"; rc=$?
"$sim" --case ht1 --scheme simo-kappa --composition blanes-casas-murua-13 --dt 0.025 --every 50 >"$tmp/p6.csv"; rc2=$?
check "blanes-casas-murua-13 at dt 0.025 beats kahan-li-9 at dt 0.02 against the exact R00(10)" '[ $rc -eq 0 ] && [ $rc2 -eq 0 ] && awk -F, -v a="$(tail -1 "$tmp/o6.csv" | cut -d, -f2)" -v b="$(tail -1 "$tmp/p6.csv" | cut -d, -f2)" "BEGIN{x=a+0.88035320824679323; y=b+0.88035320824679323; if(x<0)x=-x; if(y<0)y=-y; exit !(y < x/3)}"'
check "blanes-casas-murua-13 keeps H to 1e-13 on every row" 'awk -F, "NR==2{h0=\$14} NR>2{d=(\$14-h0)/h0; if(d<0)d=-d; if(d>1e-13) bad=1} END{exit bad}" "$tmp/p6.csv"'
"$sim" --case ht1 --scheme splitting --composition blanes-casas-murua-13 >/dev/null 2>"$tmp/err.txt"; rc=$?
check "blanes-casas-murua-13 is not a splitting method" '[ $rc -ne 0 ] && grep -q "not a splitting method" "$tmp/err.txt"'

# Effects: damping loses energy at every row; a rotor enters pi but not H.
"$sim" --case ht1 --damping 1 --t-end 1 --every 100 >"$tmp/damp.csv"; rc=$?
check "damping: H decreases monotonically" '[ $rc -eq 0 ] && awk -F, "NR>2 && \$14 >= prev {bad=1} NR>1{prev=\$14} END{exit bad}" "$tmp/damp.csv"'
"$sim" --case fb1 --rotor 0,0,0.5 --t-end 10 --every 100 >"$tmp/rotor.csv"; rc=$?
check "rotor: H and pi3 exact (free body with rotor)" '[ $rc -eq 0 ] && awk -F, "NR==2{h=\$14; p=\$18} NR>2{d=(\$14-h)/h; e=\$18-p; if(d<0)d=-d; if(e<0)e=-e; if(d>1e-12||e>1e-12) bad=1} END{exit bad}" "$tmp/rotor.csv"'
check "rotor: pi includes h_r at t = 0 (pi3 = 3*0.01 + 0.5)" 'awk -F, "NR==2{d=\$18-0.53; if(d<0)d=-d; exit !(d<1e-15)}" "$tmp/rotor.csv"'

# ---- families (docs/families.md) -------------------------------------------------------
for bad in "--case ht1 --scheme lie-gen-alpha --rho-inf 1.5" "--case ht1 --scheme lie-gen-alpha --rho-inf -0.1" \
           "--case ht1 --scheme lie-gen-alpha --rho-inf nan" "--case ht1 --rho-inf 0.5" \
           "--case ht1 --scheme energy-decaying --chi 2" "--case ht1 --scheme energy-decaying --chi -1" \
           "--case ht1 --scheme energy-decaying --chi 0.1 --chi-schedule smooth" "--case ht1 --chi 0.1" \
           "--case ht1 --scheme lie-gen-alpha --chi-schedule sensor" "--case ht1 --scheme constrained-trapezoid --damping 1" \
           "--case ht1 --scheme energy-decaying --rotor 0,0,1" "--case ht1 --scheme lie-gen-alpha --order 4"; do
  "$sim" $bad >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "exit 2, no rows, one-line reason: $bad" '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ]'
done
"$sim" --case ht1 --scheme constrained-trapezoid --t-end 1 --every 10 >"$tmp/ct.csv"; rc=$?
check "constrained-trapezoid: H exact" '[ $rc -eq 0 ] && awk -F, "NR==2{h=\$14} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>1e-12) bad=1} END{exit bad}" "$tmp/ct.csv"'
"$sim" --case ht0 --scheme energy-decaying --chi 0.2 --chi-schedule sensor --dt 0.01 --t-end 2 >"$tmp/ed.csv"; rc=$?
check "energy-decaying: H non-increasing, mu exact" '[ $rc -eq 0 ] && awk -F, "NR==2{m=\$15} NR>2{if(\$14 > prev*(1+1e-14)) bad=1; d=\$15-m; if(d<0)d=-d; if(d>1e-11) bad=1} NR>1{prev=\$14} END{exit bad}" "$tmp/ed.csv"'
"$sim" --case ht1 --scheme lie-gen-alpha --rho-inf 0.5 --t-end 1 --every 100 >"$tmp/ga.csv"; rc=$?
check "lie-gen-alpha: runs, R00(1) near the closed form (0.96475)" '[ $rc -eq 0 ] && awk -F, "END{d=\$2-0.96475241867653013; if(d<0)d=-d; exit !(d<1e-3)}" "$tmp/ga.csv"'
"$sim" --case ht1 --scheme lie-gen-alpha --damping 1 --t-end 0.1 >"$tmp/gad.csv"; rc=$?
check "lie-gen-alpha with effects" '[ $rc -eq 0 ]'

# ---- the fourth family (docs/theory.md §18) ---------------------------------------------
"$sim" --case ht1 --scheme lgvi --t-end 1 --every 10 >"$tmp/lgvi.csv"; rc=$?
check "lgvi: mu exact, H bounded (1e-6)" '[ $rc -eq 0 ] && awk -F, "NR==2{h=\$14; m=\$15} NR>2{d=(\$14-h)/h; e=\$15-m; if(d<0)d=-d; if(e<0)e=-e; if(d>1e-6||e>1e-12) bad=1} END{exit bad}" "$tmp/lgvi.csv"'
"$sim" --case fb1 --scheme lgvi --order 4 --dt 0.05 --t-end 10 --every 10 >"$tmp/lgvi4.csv"; rc=$?
check "lgvi --order 4 (Suzuki-5 of a symmetric scheme): H and pi3 exact on the free body" '[ $rc -eq 0 ] && awk -F, "NR==2{h=\$14; p=\$18} NR>2{d=(\$14-h)/h; e=\$18-p; if(d<0)d=-d; if(e<0)e=-e; if(d>1e-12||e>1e-12) bad=1} END{exit bad}" "$tmp/lgvi4.csv"'
"$sim" --case fb1 --scheme dmv --t-end 1 --every 10 >"$tmp/dmv.csv"; rc=$?
check "dmv: runs on the free body, H exact" '[ $rc -eq 0 ] && awk -F, "NR==2{h=\$14} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>1e-12) bad=1} END{exit bad}" "$tmp/dmv.csv"'
for s in rkmk4 crouch-grossman; do
  "$sim" --case ht1 --scheme $s --t-end 1 >"$tmp/$s.csv"; rc=$?
  check "$s: runs, R00(1) near the closed form (0.96475)" '[ $rc -eq 0 ] && awk -F, "END{d=\$2-0.96475241867653013; if(d<0)d=-d; exit !(d<1e-3)}" "$tmp/$s.csv"'
done
"$sim" --case ht1 --scheme lgvi --damping 1 --rotor 0,0,0.5 --t-end 0.1 >"$tmp/lgvie.csv"; rc=$?
check "lgvi with effects (damping, rotor)" '[ $rc -eq 0 ]'
for bad in "--case ht1 --scheme dmv" "--case fb1 --scheme dmv --rotor 0,0,1" "--case ht1 --scheme rkmk4 --order 4"; do
  "$sim" $bad >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "exit 2, no rows, one-line reason: $bad" '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ]'
done

# ---- bad input a new user tries (issue 18, item 7): exit 2 naming the field, no rows ----
for bad in "--case ht1 --damping -1:--damping: negative coefficient -1" \
           "--case ht1 --omega 1e200,0,0:--omega: the initial energy H is not finite" \
           "--case fb1 --omega 0,1e200,0:--omega: the initial energy H is not finite" \
           "--case ht1 --rotation 1e300,0,0:--rotation: the rotation vector's length overflows" \
           "--case ht1 --damping 0.5 --allow-negative-damping 1:unexpected argument '1'"; do
  flags=${bad%%:*}; want=${bad#*:}
  "$sim" $flags >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "exit 2, one line naming the field: $flags ($want)" \
    '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ] && grep -qF -- "$want" "$tmp/bad.err"'
done
# ---- the command line itself (CLI11, tools/simulate/flags.cpp): its errors in the CLI's words ----
for bad in "--case ht1 --spin-rate 3:unknown option '--spin-rate' (see --help)" \
           "ht1:unexpected argument 'ht1'" \
           "--case ht1 --dt:--dt: missing value" \
           "--case ht1 --dt 0.1 --dt 0.2:--dt: given twice" \
           "--case ht1 --scheme splitting --energy-projection --energy-projection:--energy-projection: given twice" \
           "--case ht1 --allow-negative-damping=0:--allow-negative-damping: a switch, it takes no value (got '0')" \
           "--case ht1 --dt abc:--dt: not a number: 'abc'"; do
  flags=${bad%%:*}; want=${bad#*:}
  "$sim" $flags >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "command line: exit 2, one line: $flags ($want)" \
    '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(cat "$tmp/bad.err")" = "trompo-simulate: $want" ]'
done
"$sim" --case ht1 --dt=0.01 --t-end 0.02 --omega -1,2,3 --every 1 >"$tmp/eq.csv"; rc=$?
check "--flag=value and negative values: runs" '[ $rc -eq 0 ] && [ $(wc -l <"$tmp/eq.csv") -eq 4 ] && [ "$(sed -n 2p "$tmp/eq.csv" | cut -d, -f11)" = "-1" ]'
"$sim" --help >"$tmp/help.txt"; rc=$?
check "--help: exit 0, generated: every flag with its value and help line" \
  '[ $rc -eq 0 ] && [ $(grep -cE "^  --[a-z-]+" "$tmp/help.txt") -ge 45 ] && grep -qE "^  --dt H +the step" "$tmp/help.txt" && grep -qE "^  --rtol R +adaptive steps" "$tmp/help.txt"'

printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3\n0,0,0,1,2,3\n0,0,0,1e200,0,0\n' >"$tmp/huge.csv"
"$sim" --case ht1 --ensemble "$tmp/huge.csv" >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
check "ensemble: a member whose energy overflows is exit 2, named by line" \
  '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && grep -qF "huge.csv:3: omega1,2,3: the initial energy H is not finite" "$tmp/bad.err"'
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3\n0,0,0,1,2,3\n1e300,0,0,1,2,3\n' >"$tmp/far.csv"
"$sim" --case ht1 --ensemble "$tmp/far.csv" >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
check "ensemble: a member whose rotation vector overflows is exit 2, named by line" \
  '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && grep -qF "far.csv:3: rotation1,2,3: the rotation vector" "$tmp/bad.err" && grep -qF "length overflows" "$tmp/bad.err"'
# Asked for by name, a negative damping runs and feeds energy in (H grows at every row).
"$sim" --case ht1 --damping -1 --allow-negative-damping --t-end 1 --every 100 >"$tmp/pump.csv" 2>"$tmp/pump.err"; rc=$?
check "--allow-negative-damping: runs, H increases monotonically" \
  '[ $rc -eq 0 ] && [ ! -s "$tmp/pump.err" ] && awk -F, "NR>2 && \$14 <= prev {bad=1} NR>1{prev=\$14} END{exit bad}" "$tmp/pump.csv"'

# A run of more than 1e8 steps (here 1e12) states its estimated time before it starts; with
# stderr not a terminal nothing else is printed on it (no progress lines), and with stderr a
# terminal (script(1) gives the run a pseudo-terminal) progress lines follow. Timing-free:
# --progress-after 0 shows them from the first 4096 steps (default: after 3 s), so neither
# check depends on how long the run lasts; timeout only stops the two runs (after 5 s, side by
# side), long after the estimate (a probe of <= 50 ms) and the first progress line.
long="--case fb1 --scheme rk4 --dt 1e-9 --t-end 1000 --progress-after 0"
timeout 5 "$sim" $long >/dev/null 2>"$tmp/long.err" &
pid_plain=$!
have_script=0
if command -v script >/dev/null 2>&1; then
  have_script=1
  script -qec "timeout 5 $sim $long 2>&1 >/dev/null" /dev/null >"$tmp/long_tty.txt" 2>&1 </dev/null &
  pid_tty=$!
fi
wait $pid_plain; rc=$?
check "long run: stopped by the timeout (exit 124), not refused" '[ $rc -eq 124 ]'
check "long run: the estimate line first, naming steps, h and the timed probe" \
  'head -1 "$tmp/long.err" | grep -qE "^trompo-simulate: 1e\+12 steps of h = 1.0000000000000001e-09: estimated [0-9.e+]+ (s|min|h|days|years) \([0-9.e+-]+ s a step, timed on a probe of [0-9]+ steps\)$"'
check "long run, stderr not a terminal: nothing but the estimate (no progress lines)" \
  '[ "$(wc -l <"$tmp/long.err")" -eq 1 ] && ! grep -q "elapsed" "$tmp/long.err"'
if [ $have_script -eq 1 ]; then
  wait $pid_tty
  check "long run, stderr a terminal: the estimate, then progress lines (t, %, elapsed, left)" \
    'grep -q "estimated" "$tmp/long_tty.txt" && grep -qE "t = [0-9.e+-]+ of 1000 \([0-9.]+%\), [0-9.]+ s elapsed, about .* left" "$tmp/long_tty.txt"'
else
  # Not a skip that passes: script(1) is in bsdutils (essential on Debian), so its absence
  # leaves the terminal path untested, and that fails.
  check "script(1) (bsdutils) found, so that the terminal path (progress lines) is tested" 'false'
fi

# ---- control in the loop (--wheels, --controller, --control-period, field flags) ----
wh='gx,gy,gz,Js,speed0,max_torque,max_speed'
printf '%s\n1,0,0,0.05,10,0.2,600\n0,1,0,0.05,-5,0.2,600\n0,0,1,0.05,0,0.2,inf\n' "$wh" >"$tmp/rw3.csv"
base="--rotation 0.5,0.2,0 --dt 0.1 --t-end 60"
ctl="--inertia 10,12,8 --omega 0.02,-0.01,0.03 $base"
"$sim" $ctl --wheels "$tmp/rw3.csv" --controller mrp-pd:1,5 --control-period 0.5 --every 10 >"$tmp/rw.csv" 2>"$tmp/rw.err"; rc=$?
check "wheels + mrp-pd: exit 0, nothing on stderr" '[ $rc -eq 0 ] && [ ! -s "$tmp/rw.err" ]'
check "wheels: header with wheel1..3 and u1..3" '[ "$(head -1 "$tmp/rw.csv")" = "$header,wheel1,wheel2,wheel3,u1,u2,u3" ]'
check "wheels: 25 columns in every row, t=0 plus every 10th of 600 steps: 61 rows" \
  'awk -F, "NF!=25{bad=1} END{exit bad}" "$tmp/rw.csv" && [ $(($(wc -l <"$tmp/rw.csv") - 1)) -eq 61 ]'
check "wheels: initial relative speeds at t = 0" '[ "$(sed -n 2p "$tmp/rw.csv" | cut -d, -f20-22)" = "10,-5,0" ]'
check "wheels: motor torques within max_torque 0.2, and not all zero" \
  'awk -F, "NR>1{for(i=23;i<=25;i++){a=\$i<0?-\$i:\$i; if(a>0.2+1e-15) bad=1; if(a>0) nz=1}} END{exit bad || !nz}" "$tmp/rw.csv"'
check "wheels: total momentum pi exact (internal torques only, simo-kappa)" \
  'awk -F, "NR==2{for(i=16;i<=18;i++)p[i]=\$i; n=sqrt(p[16]^2+p[17]^2+p[18]^2)} NR>2{for(i=16;i<=18;i++){d=\$i-p[i]; if(d<0)d=-d; if(d>1e-13*n) bad=1}} END{exit bad}" "$tmp/rw.csv"'
check "wheels + mrp-pd: the attitude reaches the target (Lambda = I: R00 > 0.999 at the end)" \
  'awk -F, "END{exit !(\$2 > 0.999 && \$6 > 0.999 && \$10 > 0.999)}" "$tmp/rw.csv"'
"$sim" $ctl --wheels "$tmp/rw3.csv" --scheme rk4 --every 600 >"$tmp/gyro.csv" 2>&1; rc=$?
check "wheels without a controller (a gyrostat, rk4): exit 0, 25 columns, u = 0" \
  '[ $rc -eq 0 ] && [ "$(tail -1 "$tmp/gyro.csv" | cut -d, -f23-25)" = "0,0,0" ] && [ "$(tail -1 "$tmp/gyro.csv" | awk -F, "{print NF}")" = "25" ]'
"$sim" $ctl --wheels "$tmp/rw3.csv" --every 20 >"$tmp/gyro_k.csv" 2>&1; rc=$?
check "free wheels (a gyrostat, simo-kappa): H (wheels' energy included) and pi exact to round-off" \
  '[ $rc -eq 0 ] && awk -F, "NR==2{h=\$14; for(i=16;i<=18;i++)p[i]=\$i; n=sqrt(p[16]^2+p[17]^2+p[18]^2)} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>1e-12) bad=1; for(i=16;i<=18;i++){d=\$i-p[i]; if(d<0)d=-d; if(d>1e-13*n) bad=1}} END{exit bad}" "$tmp/gyro_k.csv"'
"$sim" $ctl --wheels "$tmp/rw3.csv" --controller mrp-pd:1,5 --control-period 0.5 --scheme splitting --every 10 >"$tmp/rws.csv" 2>&1; rc=$?
check "wheels + mrp-pd, the splitting (rotor flow [W14]): exit 0, pi exact, the same attitude as simo-kappa to 1e-3" \
  '[ $rc -eq 0 ] && awk -F, "NR==2{for(i=16;i<=18;i++)p[i]=\$i; n=sqrt(p[16]^2+p[17]^2+p[18]^2)} NR>2{for(i=16;i<=18;i++){d=\$i-p[i]; if(d<0)d=-d; if(d>1e-13*n) bad=1}} END{exit bad}" "$tmp/rws.csv" && paste -d, "$tmp/rw.csv" "$tmp/rws.csv" | awk -F, "NR>1{for(i=2;i<=10;i++){d=\$i-\$(i+25); if(d<0)d=-d; if(d>1e-3) bad=1}} END{exit bad}"'
"$sim" $ctl --wheels "$tmp/rw3.csv" --controller mrp-pd:1,5 --control-period 0.5 --scheme splitting --composition saba2c --every 10 >"$tmp/rwsa.csv" 2>&1; rc=$?
check "wheels + mrp-pd, --composition saba2c (the hub's exact flow and the rotor flow [W18]): exit 0, pi exact, the same attitude as simo-kappa to 1e-3" \
  '[ $rc -eq 0 ] && awk -F, "NR==2{for(i=16;i<=18;i++)p[i]=\$i; n=sqrt(p[16]^2+p[17]^2+p[18]^2)} NR>2{for(i=16;i<=18;i++){d=\$i-p[i]; if(d<0)d=-d; if(d>1e-13*n) bad=1}} END{exit bad}" "$tmp/rwsa.csv" && paste -d, "$tmp/rw.csv" "$tmp/rwsa.csv" | awk -F, "NR>1{for(i=2;i<=10;i++){d=\$i-\$(i+25); if(d<0)d=-d; if(d>1e-3) bad=1}} END{exit bad}" && ! cmp -s "$tmp/rws.csv" "$tmp/rwsa.csv"'
# Viscous wheel friction [W17]: the optional eighth column; split around the fixed steps, it
# keeps pi and only takes energy out (mrp-pd:0,0 commands nothing: H never rises, and falls).
printf '%s,friction\n1,0,0,0.05,10,0.2,600,0.002\n0,1,0,0.05,-5,0.2,600,0.001\n0,0,1,0.05,0,0.2,inf,0\n' "$wh" >"$tmp/rw3c.csv"
"$sim" $ctl --wheels "$tmp/rw3c.csv" --controller mrp-pd:1,5 --control-period 0.5 --every 10 >"$tmp/rwc.csv" 2>"$tmp/rwc.err"; rc=$?
check "wheels with friction + mrp-pd: exit 0, 25 columns, pi exact, wheel speeds other than without friction" \
  '[ $rc -eq 0 ] && [ ! -s "$tmp/rwc.err" ] && awk -F, "NF!=25{bad=1} NR==2{for(i=16;i<=18;i++)p[i]=\$i; n=sqrt(p[16]^2+p[17]^2+p[18]^2)} NR>2{for(i=16;i<=18;i++){d=\$i-p[i]; if(d<0)d=-d; if(d>1e-13*n) bad=1}} END{exit bad}" "$tmp/rwc.csv" && [ "$(tail -1 "$tmp/rwc.csv" | cut -d, -f20-21)" != "$(tail -1 "$tmp/rw.csv" | cut -d, -f20-21)" ]'
"$sim" $ctl --wheels "$tmp/rw3c.csv" --controller mrp-pd:0,0 --control-period 0.5 --every 10 >"$tmp/rwc0.csv" 2>&1; rc=$?
check "wheels with friction, no command: H never rises and falls by more than 1 %" \
  '[ $rc -eq 0 ] && awk -F, "NR==2{h0=\$14; h=\$14} NR>2{if(\$14>h*(1+1e-15)) bad=1; h=\$14} END{exit bad || !(h < 0.99*h0)}" "$tmp/rwc0.csv"'
# A composition keeps its order with friction (the flows split around each sub-step): --order 4
# at --dt 0.1 within 1e-10 of --order 6 at 0.025 (measured 5e-12), where one Simo-kappa step
# is 1.7e-7 off.
"$sim" $ctl --wheels "$tmp/rw3c.csv" --controller mrp-pd:1,5 --control-period 0.5 --order 4 --every 600 >"$tmp/rwc4.csv" 2>&1; rc=$?
"$sim" --inertia 10,12,8 --omega 0.02,-0.01,0.03 --rotation 0.5,0.2,0 --t-end 60 --wheels "$tmp/rw3c.csv" --controller mrp-pd:1,5 \
  --control-period 0.5 --order 6 --dt 0.025 --every 2400 >"$tmp/rwc6.csv" 2>&1
check "wheels with friction, --order 4: within 1e-10 of the converged run, where order 2 is beyond 1e-8" \
  '[ $rc -eq 0 ] && paste -d, <(tail -1 "$tmp/rwc4.csv") <(tail -1 "$tmp/rwc6.csv") | awk -F, "{for(i=2;i<=10;i++){d=\$i-\$(i+25); if(d<0)d=-d; if(d>1e-10) bad=1}} END{exit bad}" && paste -d, <(tail -1 "$tmp/rwc.csv") <(tail -1 "$tmp/rwc6.csv") | awk -F, "{m=0; for(i=2;i<=10;i++){d=\$i-\$(i+25); if(d<0)d=-d; if(d>m) m=d} exit !(m>1e-8)}"'
# --rtol with friction: each hold adapts the split step [W17] (Richardson's estimate, doubling),
# rows at its steps, each with its own wheels; pi exact in every row, the end within 3e-7 of the
# converged --order 6 run (measured 6.4e-8 over 120 holds), and far from the same run without
# friction (the friction's effect, measured 0.12).
"$sim" --inertia 10,12,8 --omega 0.02,-0.01,0.03 --rotation 0.5,0.2,0 --t-end 60 --wheels "$tmp/rw3c.csv" --controller mrp-pd:1,5 \
  --control-period 0.5 --rtol 1e-9 --atol 1e-9 >"$tmp/rwca.csv" 2>"$tmp/rwca.err"; rc=$?
check "wheels with friction, --rtol 1e-9: exit 0, the summary line, pi exact, the end within 3e-7 of the converged run" \
  '[ $rc -eq 0 ] && grep -qE "accepted, .*; reached t_end; method simo-kappa \(order 2\)$" "$tmp/rwca.err" && awk -F, "NR==2{for(i=16;i<=18;i++)p[i]=\$i; n=sqrt(p[16]^2+p[17]^2+p[18]^2)} NR>2{for(i=16;i<=18;i++){d=\$i-p[i]; if(d<0)d=-d; if(d>1e-13*n) bad=1}} END{exit bad}" "$tmp/rwca.csv" && paste -d, <(tail -1 "$tmp/rwca.csv") <(tail -1 "$tmp/rwc6.csv") | awk -F, "{for(i=2;i<=10;i++){d=\$i-\$(i+25); if(d<0)d=-d; if(d>3e-7) bad=1}} END{exit bad}" && paste -d, <(tail -1 "$tmp/rwca.csv") <(tail -1 "$tmp/rw.csv") | awk -F, "{m=0; for(i=2;i<=10;i++){d=\$i-\$(i+25); if(d<0)d=-d; if(d>m) m=d} exit !(m>1e-2)}"'
# --rtol with friction, --t-eval and --event: the nodes' rates and the wheels between them see
# the friction (W17.a-b). A body turning at 0.37 rad/s under a weak mrp-pd, so that its z axis
# crosses the plane normal to pi (one axis-crossing event, at t = 4.28). Rows inside the holds
# within 1e-6 of the converged run at the same times (attitude, rates, wheel speeds; measured
# 2.2e-7 at t = 59.9, the order-2 run's own error over 120 holds), pi at them and at the event
# within 1e-12 of pi0 (measured 1.4e-14 and 2.4e-15; with the wheels' line at the step's end
# moved by u alone, the friction left out, 2e-4: tests/test_wheel_friction.cpp).
"$sim" --inertia 10,12,8 --omega 0.3,-0.1,0.2 --rotation 0.5,0.2,0 --t-end 60 --wheels "$tmp/rw3c.csv" --controller mrp-pd:0.2,2 \
  --control-period 0.5 --order 6 --dt 0.025 >"$tmp/rwc6all.csv" 2>&1
"$sim" --inertia 10,12,8 --omega 0.3,-0.1,0.2 --rotation 0.5,0.2,0 --t-end 60 --wheels "$tmp/rw3c.csv" --controller mrp-pd:0.2,2 \
  --control-period 0.5 --rtol 1e-10 --atol 1e-10 --t-eval 0,0.3,7.65,30.1,59.9 --event axis-crossing \
  --event-csv "$tmp/rwct_ev.csv" >"$tmp/rwct.csv" 2>"$tmp/rwct.err"; rc=$?
check "wheels with friction, --rtol 1e-10 --t-eval --event: rows at the 5 times within 1e-6 of the converged run (wheel speeds too), pi within 1e-12 there and at every event" \
  '[ $rc -eq 0 ] && [ "$(tail -n +2 "$tmp/rwct.csv" | awk -F, "{printf \"%g \", \$1}")" = "0 0.3 7.65 30.1 59.9 " ] && awk -F, -v b=1e-6 "NR==FNR{if(FNR>1) for(i=2;i<=22;i++) r[sprintf(\"%.6f\",\$1),i]=\$i; next} FNR>1{k=sprintf(\"%.6f\",\$1); n++; if(!((k,2) in r)) bad=1; for(i=2;i<=22;i++){if(i>=14&&i<=19) continue; d=\$i-r[k,i]; if(d<0)d=-d; if(d>b) bad=1}} END{exit bad || n!=5}" "$tmp/rwc6all.csv" "$tmp/rwct.csv" && awk -F, -v b=1e-12 "NR==2{for(i=16;i<=18;i++)p[i]=\$i; m=sqrt(p[16]^2+p[17]^2+p[18]^2)} NR>2{for(i=16;i<=18;i++){d=\$i-p[i]; if(d<0)d=-d; if(d>b*m) bad=1}} END{exit bad}" "$tmp/rwct.csv" && [ "$(wc -l <"$tmp/rwct_ev.csv")" -eq 2 ] && p0=$(sed -n 2p "$tmp/rwct.csv" | cut -d, -f16-18) && awk -F, -v b=1e-12 -v p="$p0" "BEGIN{split(p,q,\",\"); m=sqrt(q[1]^2+q[2]^2+q[3]^2)} NR>1{n++; for(i=17;i<=19;i++){d=\$i-q[i-16]; if(d<0)d=-d; if(d>b*m) bad=1}} END{exit bad || n<1}" "$tmp/rwct_ev.csv"'
# --rtol: adaptive steps over each hold (a new run each hold), rows at every sample and at
# every accepted step; against the fixed-step run at dt 0.1 and a converged one (order 4, dt 0.01).
"$sim" --inertia 10,12,8 --omega 0.02,-0.01,0.03 --rotation 0.5,0.2,0 --t-end 60 --wheels "$tmp/rw3.csv" --controller mrp-pd:1,5 \
  --control-period 0.5 --order 4 --dt 0.01 --every 6000 >"$tmp/rwref.csv" 2>&1
"$sim" --inertia 10,12,8 --omega 0.02,-0.01,0.03 --rotation 0.5,0.2,0 --t-end 60 --wheels "$tmp/rw3.csv" --controller mrp-pd:1,5 \
  --control-period 0.5 --rtol 1e-9 --atol 1e-9 >"$tmp/rwa.csv" 2>"$tmp/rwa.err"; rc=$?
check "wheels + mrp-pd, --rtol 1e-9 without --dt: exit 0, the summary line, pi exact, u within 0.2" \
  '[ $rc -eq 0 ] && grep -qE "^trompo-simulate: adaptive \(tolerance, rtol 1e-09, atol 1e-09\): [0-9]+ accepted, .*; reached t_end; method simo-kappa \(order 2\)$" "$tmp/rwa.err" && awk -F, "NR==2{for(i=16;i<=18;i++)p[i]=\$i; n=sqrt(p[16]^2+p[17]^2+p[18]^2)} NR>2{for(i=16;i<=18;i++){d=\$i-p[i]; if(d<0)d=-d; if(d>1e-13*n) bad=1}; for(i=23;i<=25;i++){a=\$i<0?-\$i:\$i; if(a>0.2+1e-15) bad=1}} END{exit bad}" "$tmp/rwa.csv"'
check "wheels + mrp-pd, --rtol 1e-9: a row at each of the 120 samples, the end within 1e-6 of the converged run" \
  '[ "$(awk -F, "NR>1{k=\$1/0.5; if(k==int(k)) n++} END{print n}" "$tmp/rwa.csv")" -ge 121 ] && paste -d, <(tail -1 "$tmp/rwa.csv") <(tail -1 "$tmp/rwref.csv") | awk -F, "{for(i=2;i<=10;i++){d=\$i-\$(i+25); if(d<0)d=-d; if(d>1e-6) bad=1}} END{exit bad}"'
"$sim" --inertia 10,12,8 --omega 0.02,-0.01,0.03 --rotation 0.5,0.2,0 --t-end 60 --wheels "$tmp/rw3.csv" --controller mrp-pd:1,5 \
  --control-period 0.5 --rtol 1e-9 --atol 1e-9 --t-eval 0,0.25,0.5,30,59.75,60 --event axis-crossing --event-csv "$tmp/rwa_ev.csv" >"$tmp/rwt.csv" 2>/dev/null; rc=$?
check "wheels + mrp-pd, --rtol with --t-eval across samples: exit 0, rows at exactly the 6 times, the end as the run without --t-eval" \
  '[ $rc -eq 0 ] && [ "$(tail -n +2 "$tmp/rwt.csv" | cut -d, -f1 | tr "\n" " ")" = "0 0.25 0.5 30 59.75 60 " ] && [ "$(tail -1 "$tmp/rwt.csv" | cut -d, -f2-10)" = "$(tail -1 "$tmp/rwa.csv" | cut -d, -f2-10)" ] && [ -s "$tmp/rwa_ev.csv" ]'
"$sim" $ctl --wheels "$tmp/rw3.csv" --controller mrp-pd:1,5 --control-period 0.5 --order 4 --every 600 >"$tmp/rw4.csv" 2>&1; rc=$?
check "wheels + mrp-pd, --order 4 (composed simo-kappa): exit 0" '[ $rc -eq 0 ] && [ $(($(wc -l <"$tmp/rw4.csv") - 1)) -eq 2 ]'
"$sim" $ctl --controller mrp-pd:1,5 --control-period 0.5 --target-rotation 0,0,0.3 --every 600 >"$tmp/pd.csv" 2>&1; rc=$?
check "mrp-pd without wheels (a body torque): exit 0, 19 columns" \
  '[ $rc -eq 0 ] && [ "$(head -1 "$tmp/pd.csv")" = "$header" ] && [ "$(tail -1 "$tmp/pd.csv" | awk -F, "{print NF}")" = "19" ]'
"$sim" --inertia 0.035,0.035,0.01 --omega 0.17,0.17,0.17 --dt 0.25 --t-end 600 --every 2400 --controller bdot:1e5 \
  --control-period 0.25 --orbit-radius 6771e3 --orbit-inclination 51.6 --max-dipole 0.2 >"$tmp/bdot.csv" 2>&1; rc=$?
check "bdot with the field flags: exit 0, the rate falls" \
  '[ $rc -eq 0 ] && awk -F, "NR==2{w=\$11^2+\$12^2+\$13^2} END{exit !(\$11^2+\$12^2+\$13^2 < w)}" "$tmp/bdot.csv"'
# --max-step-angle: |Omega| = 0.866 rad/s turns 0.2165 rad in a 0.25 s hold, so 0.05 rad a step
# is 5 steps a sample (ceil 4.33): 8 samples of the splitting give 40 step rows and the first.
"$sim" --inertia 0.035,0.034,0.01 --omega 0.5,0.5,0.5 --scheme splitting --dt 0.25 --t-end 2 --every 1 --controller bdot:1e5 \
  --control-period 0.25 --orbit-radius 6771e3 --orbit-inclination 51.6 --max-dipole 0.2 --max-step-angle 0.05 >"$tmp/bdot_angle.csv" 2>&1; rc=$?
check "bdot with --max-step-angle 0.05: exit 0, 5 steps a sample (41 rows), every sample a row" \
  '[ $rc -eq 0 ] && [ $(($(wc -l <"$tmp/bdot_angle.csv") - 1)) -eq 41 ] && [ "$(cut -d, -f1 "$tmp/bdot_angle.csv" | grep -cE "^(0|0.25|0.5|0.75|1|1.25|1.5|1.75|2)$")" -eq 9 ]'
printf '%s\n0,0,0,0.05,0,0.2,600\n' "$wh" >"$tmp/rw_zero.csv"
printf '%s\n1,nan,0,0.05,0,0.2,600\n' "$wh" >"$tmp/rw_nan.csv"
printf '%s\n1,0,0,0,0,0.2,600\n' "$wh" >"$tmp/rw_js.csv"
printf '%s\n1,0,0,0.05,0,0.2,600\n0,1,0,0.05,0,0.2,600\n' "$wh" >"$tmp/rw2.csv"
printf 'gx,gy,gz,Js\n1,0,0,0.05\n' >"$tmp/rw_head.csv"
printf '%s,friction\n1,0,0,0.05,0,0.2,600,-1e-3\n' "$wh" >"$tmp/rw_cneg.csv"
pd="--controller mrp-pd:1,5 --control-period 0.5"
for bad in "--wheels $tmp/rw_zero.csv|axis must be finite and non-zero" \
           "--wheels $tmp/rw_nan.csv|rw_nan.csv:2: gy: must be finite" \
           "--wheels $tmp/rw_js.csv|Js (axial inertia) must be finite and > 0" \
           "--wheels $tmp/rw_head.csv|expected the header gx,gy,gz,Js,speed0,max_torque,max_speed" \
           "--wheels $tmp/rw3.csv --controller mrp-pd:1,5 --control-period 0|--control-period: must be > 0" \
           "--wheels $tmp/rw3.csv --controller mrp-pd:1,5 --control-period -1|--control-period: must be > 0" \
           "--wheels $tmp/rw3.csv --controller mrp-pd:1,5 --control-period 0.05|--control-period: 0.05 is shorter than the step --dt" \
           "--wheels $tmp/rw3.csv --controller mrp-pd:1,5 --control-period nan|--control-period: must be finite" \
           "--wheels $tmp/rw2.csv $pd|rank of G_s < 3" \
           "--wheels $tmp/rw3.csv --controller bdot:1 --control-period 1|--controller bdot: needs the magnetic field" \
           "--controller bdot:1 --control-period 1|--controller bdot: needs the magnetic field" \
           "--wheels $tmp/rw3.csv --scheme geradin-bauchau|--scheme geradin-bauchau: cannot carry reaction wheels" \
           "--wheels $tmp/rw3.csv --scheme splitting --composition chin-4a|needs an exact free flow or a conservative load" \
           "--wheels $tmp/rw3.csv --scheme splitting --composition saba2c --order 4|--order: 4 contradicts --composition saba2c (order 2)" \
           "--wheels $tmp/rw3.csv --scheme exact|--scheme exact: cannot carry reaction wheels" \
           "$pd --scheme lie-gen-alpha|--scheme lie-gen-alpha: cannot carry reaction wheels" \
           "--controller mrp-pd:1 --control-period 1|--controller mrp-pd: expected mrp-pd:K,P" \
           "--controller pid:1,2 --control-period 1|--controller: unknown controller 'pid'" \
           "--controller mrp-pd:1,2|--controller: needs --control-period" \
           "--target-rotation 0,0,1 --wheels $tmp/rw3.csv|--target-rotation: only with --controller mrp-pd" \
           "--max-dipole 0.2 $pd|--max-dipole: only with --orbit-radius" \
           "--max-step-angle 0.1|--max-step-angle: needs --controller" \
           "--max-step-angle -0.1 $pd|--max-step-angle: must be > 0" \
           "--max-step-angle 0.1 $pd --rtol 1e-8|--max-step-angle: fixed steps only, not with --rtol" \
           "--orbit-radius 0 $pd|--orbit-radius: must be > 0" \
           "--wheels $tmp/rw3.csv --mgl 1|a control run's scene has wheels" \
           "--wheels $tmp/rw3.csv --rtol 1e-6 --event nutation-max:terminal|--event nutation-max:terminal: not in a control run" \
           "--wheels $tmp/rw_cneg.csv $pd|rw_cneg.csv:2: wheels: wheel 1: friction must be finite and >= 0" \
           "--wheels $tmp/rw3c.csv $pd --rtol 1e-8 --estimate defect|Richardson's rule: not with --estimate defect" \
           "--wheels $tmp/rw3c.csv $pd --rtol 1e-8 --control reversible|Richardson's rule: not with --control reversible" \
           "--wheels $tmp/rw3c.csv|--wheels: a wheel has viscous friction, which the sampled driver applies: give --controller"; do
  flags=${bad%%|*}; want=${bad#*|}
  "$sim" $ctl $flags >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "control: exit 2, no rows, one line naming the field: $want" \
    '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ] && grep -qF -- "$want" "$tmp/bad.err"'
done
"$sim" $base --wheels "$tmp/rw3.csv" --inertia 0.04,0.06,0.05 >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
check "control: exit 2 naming the hub's inertia (wheels' Js exceed the spacecraft's)" \
  '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && grep -qF -- "J - sum Js g g^T (the hub" "$tmp/bad.err" && grep -qF "must be positive definite" "$tmp/bad.err"'
# A command that comes back non-finite stops the run (exit 3) naming the command and t.
"$sim" $base --inertia 10,12,8 --omega 10,0,0 --controller mrp-pd:1e308,1e308 --control-period 0.5 >"$tmp/inf.csv" 2>"$tmp/inf.err"; rc=$?
check "non-finite command: exit 3, stderr names the command and t" \
  '[ $rc -eq 3 ] && grep -qF "non-finite command body_torque at t = 0" "$tmp/inf.err"'
"$sim" $base --inertia 10,12,8 --omega 10,0,0 --wheels "$tmp/rw3.csv" --controller mrp-pd:1e308,1e308 --control-period 0.5 >"$tmp/inf.csv" 2>"$tmp/inf.err"; rc=$?
check "non-finite wheel command: exit 3, stderr names wheel_torques and t" \
  '[ $rc -eq 3 ] && grep -qF "non-finite command wheel_torques at t = 0" "$tmp/inf.err"'

"$sim" --case ht1 --progress-after -1 >/dev/null 2>"$tmp/bad.err"; rc=$?
check "--progress-after -1: exit 2, named" '[ $rc -eq 2 ] && grep -q "^trompo-simulate: --progress-after: must be a finite number of seconds >= 0, got -1" "$tmp/bad.err"'

# Backward integration.
"$sim" --case ht1 --dt -0.001 --t-end -0.01 >"$tmp/back.csv"; rc=$?
check "negative dt integrates backward" '[ $rc -eq 0 ] && [ "$(tail -1 "$tmp/back.csv" | cut -d, -f1)" = "-0.01" ]'

echo "trompo-simulate: $fails failed"
[ $fails -eq 0 ]
