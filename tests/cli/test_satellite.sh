#!/usr/bin/env bash
# trompo-simulate with a satellite (docs/spacecraft.md): --case sat1|sat2 and the flags
# --gravity-gradient, --orbit-normal, --radial; the H column is the Jacobi integral E_J.
set -u
sim="$1"
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"

# sat1 with the order-4 splitting at its preset h = 1 s over its 10 orbits: E_J in a band
# of 1.3e-10 relative (measured 6e-11 absolute on E_J = 0.476).
"$sim" --case sat1 --scheme splitting --composition suzuki-5 --every 1000 >"$tmp/s1.csv" 2>"$tmp/s1.err"; rc=$?
check "sat1 splitting: exit 0" '[ $rc -eq 0 ]'
check "sat1: last row at 10 orbits (20 pi / n)" 'awk -F, "END{d=\$1-57119.866428905; if(d<0)d=-d; exit !(d<1e-6)}" "$tmp/s1.csv"'
check "sat1: H column is E_J = 0.47630823020033031 at t = 0" '[ "$(sed -n 2p "$tmp/s1.csv" | cut -d, -f14)" = "0.47630823020033031" ]'
check "sat1 suzuki-5: E_J within 1e-9 relative over 10 orbits" \
  'awk -F, "NR==2{h=\$14} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>1e-9) bad=1} END{exit bad}" "$tmp/s1.csv"'

# The projected splitting keeps E_J (measured 2.5e-12 absolute over 10 orbits at h = 2 s).
"$sim" --case sat1 --scheme splitting --composition strang --energy-projection --dt 2 --every 500 >"$tmp/sp.csv"; rc=$?
check "sat1 projected: E_J within 2e-11 relative" \
  '[ $rc -eq 0 ] && awk -F, "NR==2{h=\$14} NR>2{d=(\$14-h)/h; if(d<0)d=-d; if(d>2e-11) bad=1} END{exit bad}" "$tmp/sp.csv"'

# The preset is the flags it stands for (its rotation vector is the log of Lambda0: equal
# to round-off, so the rows agree to 1e-12, not bit for bit).
"$sim" --case sat1 --scheme rk4 --t-end 500 --every 100 >"$tmp/a.csv"; rc1=$?
"$sim" --inertia 100,120,80 --gravity-gradient 0.0011 --orbit-normal 0,0,5 --radial 2,0,0 --scheme rk4 \
  --rotation 0.29999999999999999,-0.20000000000000001,0.5 --omega 0.05,0.07,0.04 --dt 1 --t-end 500 --every 100 >"$tmp/b.csv"; rc2=$?
check "--case sat1 equals its flags (normal and radial normalised)" \
  '[ $rc1 -eq 0 ] && [ $rc2 -eq 0 ] && paste -d, "$tmp/a.csv" "$tmp/b.csv" | awk -F, "NR>1{for(i=1;i<=18;i++){d=\$i-\$(i+19); if(d<0)d=-d; if(d>1e-12) bad=1}} END{exit bad}"'

# sat2 librates about the local vertical: the body z axis (third column of Lambda) stays
# within 0.05 rad of the radial r(t) = (cos nt, sin nt, 0) over its 50 orbits.
"$sim" --case sat2 --scheme splitting --every 10 >"$tmp/s2.csv"; rc=$?
check "sat2: exit 0, z axis within 0.05 rad of the radial" \
  '[ $rc -eq 0 ] && awk -F, "NR>1{c=cos(0.0011*\$1)*\$4+sin(0.0011*\$1)*\$7; if(c<cos(0.05)) bad=1} END{exit bad}" "$tmp/s2.csv"'

for bad in "--case sat1 --mgl 1:--gravity-gradient" "--case sat1 --damping 0.1:--gravity-gradient" \
           "--case sat1 --radial 1,0,1:orthogonal" "--case sat1 --orbit-normal 0,0,0:orbit normal" \
           "--case sat1 --gravity-gradient -0.001:orbit rate" "--case sat1 --gravity-gradient nan:--gravity-gradient" \
           "--case ht1 --radial 1,0,0:--radial: only with --gravity-gradient" \
           "--case ht1 --orbit-normal 0,0,1:--orbit-normal: only with --gravity-gradient" \
           "--case sat1 --scheme exact:--scheme exact" "--case sat1 --scheme energy-decaying:--scheme energy-decaying" \
           "--case sat3:--case"; do
  flags=${bad%%:*}; want=${bad#*:}
  "$sim" $flags >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
  check "exit 2, one line naming the field: $flags ($want)" \
    '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ] && grep -qF -- "$want" "$tmp/bad.err"'
done

echo "$fails failure(s)"
[ "$fails" -eq 0 ]
