#!/usr/bin/env bash
# trompo-simulate --ensemble FILE: one row per member (its final state), each the same
# numbers as the last row of a single run with that member's flags; identical output for
# 1 and 2 threads; a failing member reported in its row and by exit 3 while the others
# finish; a bad file (or a flag that contradicts it) gives exit 2, one line, no rows.
set -u
sim="$1"
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
header='member,t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations,status'

cat >"$tmp/members.csv" <<'CSV'
rotation1,rotation2,rotation3,omega1,omega2,omega3,mgl
# HT1-like tops: tilt, spin and weight per member
0.05,0,0,0,0,50,20
0.1,0,0,0,0,40,25
0.2,0.01,0,0,1,30,0
0.3,-0.02,0.1,0.5,0,60,15
CSV
"$sim" --case ht1 --t-end 0.5 --ensemble "$tmp/members.csv" --threads 2 >"$tmp/e2.csv" 2>"$tmp/e2.err"; rc=$?
check "exit 0" '[ $rc -eq 0 ] && [ ! -s "$tmp/e2.err" ]'
check "header exactly" '[ "$(head -1 "$tmp/e2.csv")" = "$header" ]'
check "one row per member" '[ $(($(wc -l <"$tmp/e2.csv") - 1)) -eq 4 ]'
check "every member ok at t_end" 'awk -F, "NR>1 && (\$2 != 0.5 || \$21 != \"ok\") {bad=1} END{exit bad}" "$tmp/e2.csv"'
i=0
while IFS=, read -r r1 r2 r3 w1 w2 w3 mgl; do
  "$sim" --case ht1 --t-end 0.5 --rotation "$r1,$r2,$r3" --omega "$w1,$w2,$w3" --mgl "$mgl" >"$tmp/single.csv"
  check "member $i = last row of its single run, bit for bit" \
    '[ "$(sed -n "$((i + 2))p" "$tmp/e2.csv" | cut -d, -f2-19)" = "$(tail -1 "$tmp/single.csv" | cut -d, -f1-18)" ]'
  i=$((i + 1))
done < <(grep -v -e '^#' -e '^rotation' "$tmp/members.csv")
"$sim" --case ht1 --t-end 0.5 --ensemble "$tmp/members.csv" --threads 1 --csv "$tmp/e1.csv"; rc=$?
check "--threads 1 and 2 write the same bytes (--csv)" '[ $rc -eq 0 ] && cmp -s "$tmp/e1.csv" "$tmp/e2.csv"'

# Adaptive members (--rtol): each the last row of its single adaptive run, for 1 and 2
# threads; --t-eval has no place in one row per member and is refused.
"$sim" --case ht1 --t-end 0.5 --scheme simo-kappa --order 4 --rtol 1e-9 --atol 1e-9 --ensemble "$tmp/members.csv" --threads 2 >"$tmp/a2.csv" 2>"$tmp/a2.err"; rc=$?
"$sim" --case ht1 --t-end 0.5 --scheme simo-kappa --order 4 --rtol 1e-9 --atol 1e-9 --ensemble "$tmp/members.csv" --threads 1 >"$tmp/a1.csv"
check "adaptive members: exit 0, every member ok, 1 and 2 threads the same bytes" \
  '[ $rc -eq 0 ] && [ ! -s "$tmp/a2.err" ] && awk -F, "NR>1 && (\$2 != 0.5 || \$21 != \"ok\") {bad=1} END{exit bad}" "$tmp/a2.csv" && cmp -s "$tmp/a1.csv" "$tmp/a2.csv"'
"$sim" --case ht1 --t-end 0.5 --scheme simo-kappa --order 4 --rtol 1e-9 --atol 1e-9 --rotation 0.3,-0.02,0.1 --omega 0.5,0,60 --mgl 15 >"$tmp/asingle.csv" 2>/dev/null
check "adaptive member 3 = last row of its single adaptive run, bit for bit" \
  '[ "$(sed -n 5p "$tmp/a2.csv" | cut -d, -f2-19)" = "$(tail -1 "$tmp/asingle.csv" | cut -d, -f1-18)" ]'
"$sim" --case ht1 --t-end 0.5 --rtol 1e-9 --t-eval 0.25 --ensemble "$tmp/members.csv" >"$tmp/bad.csv" 2>"$tmp/bad.err"; rc=$?
check "--t-eval with --ensemble FILE: exit 2, named" '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.csv" ] && grep -qF -- "--t-eval: not with --ensemble FILE" "$tmp/bad.err"'

# The processed composition: members run without an observer (one post-processing at the
# end), the single run post-processes every row; the output depends on the kernel alone.
"$sim" --case ht1 --t-end 0.5 --composition blanes-casas-murua-13 --ensemble "$tmp/members.csv" >"$tmp/p6.csv"; rc=$?
"$sim" --case ht1 --t-end 0.5 --composition blanes-casas-murua-13 --rotation 0.1,0,0 --omega 0,0,40 --mgl 25 >"$tmp/p6single.csv"
check "blanes-casas-murua-13: member 1 = last row of its single run, bit for bit" \
  '[ $rc -eq 0 ] && [ "$(sed -n 3p "$tmp/p6.csv" | cut -d, -f2-19)" = "$(tail -1 "$tmp/p6single.csv" | cut -d, -f1-18)" ]'

# Per-member inertia, composed scheme.
printf 'omega1,omega2,omega3,rotation1,rotation2,rotation3,J11,J22,J33\n0.01,2,0.01,0,0,0,1,2,3\n0.01,2,0.01,0,0,0,1,2,2.5\n' >"$tmp/fb.csv"
"$sim" --case fb1 --t-end 2 --order 4 --ensemble "$tmp/fb.csv" >"$tmp/fb.out"; rc=$?
"$sim" --case fb1 --t-end 2 --order 4 --inertia 1,2,2.5 >"$tmp/single.csv"
check "per-member inertia, any column order, order 4" '[ $rc -eq 0 ] && [ "$(sed -n 3p "$tmp/fb.out" | cut -d, -f2-19)" = "$(tail -1 "$tmp/single.csv" | cut -d, -f1-18)" ]'

# Splitting with per-member inertia: the default method of --order 4 is chosen for each
# member's own body (chin-4a on the symmetric top, suzuki-5 on the asymmetric one), as
# its single run chooses it, not for the Config's (HT1: symmetric).
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3,J11,J22,J33\n0.05,0,0,0,0,50,5,5,1\n0.05,0,0,0,0,50,4,6,2.5\n' >"$tmp/sp.csv"
"$sim" --case ht1 --t-end 0.5 --scheme splitting --order 4 --ensemble "$tmp/sp.csv" >"$tmp/sp.out"; rc=$?
i=0
for J in 5,5,1 4,6,2.5; do
  "$sim" --case ht1 --t-end 0.5 --scheme splitting --order 4 --rotation 0.05,0,0 --omega 0,0,50 --inertia "$J" >"$tmp/single.csv"
  check "splitting, per-member inertia $J: the method of its single run, bit for bit" \
    '[ $rc -eq 0 ] && [ "$(sed -n "$((i + 2))p" "$tmp/sp.out" | cut -d, -f2-19)" = "$(tail -1 "$tmp/single.csv" | cut -d, -f1-18)" ]'
  i=$((i + 1))
done

# A member that cannot be integrated: its row is its last good state, the others finish.
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3\n0,0,0,0.01,2,0.01\n0,0,0,0,1e6,0\n0,0,0,0.01,2,0.02\n' >"$tmp/fail.csv"
"$sim" --case fb1 --dt 1 --t-end 2 --ensemble "$tmp/fail.csv" >"$tmp/fail.out" 2>"$tmp/fail.err"; rc=$?
check "exit 3 when a member fails" '[ $rc -eq 3 ]'
check "failing member: t = 0, status names the reason" '[ "$(sed -n 3p "$tmp/fail.out" | cut -d, -f2)" = "0" ] && sed -n 3p "$tmp/fail.out" | grep -q "(wrong branch)$"'
check "the other members finish" '[ "$(sed -n 2p "$tmp/fail.out" | cut -d, -f2,21)" = "2,ok" ] && [ "$(sed -n 4p "$tmp/fail.out" | cut -d, -f2,21)" = "2,ok" ]'
check "stderr names the member" 'grep -q "1 of 3 member(s) failed.*first: member 1 at t = 0: .*wrong branch" "$tmp/fail.err"'

# Closed loops (the control flags): each member is its own control run from its row (wheels
# started at its state, its own controller memory), its row the last row of that single run
# with the wheels' speeds and held torques; 1 and 2 threads write the same bytes; a member's
# inertia column is the whole spacecraft's; --rtol runs adaptive holds, --max-step-angle
# fixed steps that follow the rate.
printf 'gx,gy,gz,Js,speed0,max_torque,max_speed\n1,0,0,0.0796,10.47,0.2,628.3\n0,1,0,0.0796,20.94,0.2,628.3\n0,0,1,0.0796,31.4,0.2,628.3\n' >"$tmp/rw.csv"
cat >"$tmp/craft.csv" <<'CSV'
rotation1,rotation2,rotation3,omega1,omega2,omega3,J11,J22,J33
0.5,0,0,0.001,-0.01,0.03,900,800,600
0.2,0.3,-0.1,0.01,0,0,900,800,600
0,0,1,0,0,0.02,700,800,900
CSV
ctl="--wheels $tmp/rw.csv --controller mrp-pd:3.5,30 --control-period 0.1 --t-end 30"
cheader='member,t,R00,R01,R02,R10,R11,R12,R20,R21,R22,W1,W2,W3,H,mu,pi1,pi2,pi3,iterations,wheel1,wheel2,wheel3,u1,u2,u3,status'
for between in "--dt 0.1" "--dt 0.1 --scheme splitting --composition suzuki-5 --max-step-angle 0.001" "--rtol 1e-9 --atol 1e-9 --order 4"; do
  "$sim" --inertia 900,800,600 $ctl $between --ensemble "$tmp/craft.csv" --threads 2 >"$tmp/c2.csv" 2>"$tmp/c2.err"; rc=$?
  "$sim" --inertia 900,800,600 $ctl $between --ensemble "$tmp/craft.csv" --threads 1 >"$tmp/c1.csv" 2>/dev/null
  check "closed loops ($between): exit 0, the header with wheel1..3 and u1..3, every member ok, 1 and 2 threads the same bytes" \
    '[ $rc -eq 0 ] && [ "$(head -1 "$tmp/c2.csv")" = "$cheader" ] && awk -F, "NR>1 && (\$2 != 30 || \$27 != \"ok\") {bad=1} END{exit bad}" "$tmp/c2.csv" && cmp -s "$tmp/c1.csv" "$tmp/c2.csv"'
  i=0
  while IFS=, read -r r1 r2 r3 w1 w2 w3 j1 j2 j3; do
    "$sim" --inertia "$j1,$j2,$j3" $ctl $between --rotation "$r1,$r2,$r3" --omega "$w1,$w2,$w3" --every 1000000 >"$tmp/csingle.csv" 2>/dev/null
    check "closed-loop member $i ($between) = last row of its single control run (state, H, pi, wheels, u), bit for bit" \
      '[ "$(sed -n "$((i + 2))p" "$tmp/c2.csv" | cut -d, -f2-19,21-26)" = "$(tail -1 "$tmp/csingle.csv" | cut -d, -f1-18,20-25)" ]'
    i=$((i + 1))
  done < <(grep -v -e '^#' -e '^rotation' "$tmp/craft.csv")
done
# Wheels with viscous friction [W17] (split around the fixed steps): each member its single run.
printf 'gx,gy,gz,Js,speed0,max_torque,max_speed,friction\n1,0,0,0.0796,10.47,0.2,628.3,0.01\n0,1,0,0.0796,20.94,0.2,628.3,0\n0,0,1,0.0796,31.4,0.2,628.3,0.02\n' >"$tmp/rwc.csv"
cfr="--wheels $tmp/rwc.csv --controller mrp-pd:3.5,30 --control-period 0.1 --t-end 30 --dt 0.1"
"$sim" --inertia 900,800,600 $cfr --ensemble "$tmp/craft.csv" --threads 2 >"$tmp/cf2.csv" 2>/dev/null; rc=$?
"$sim" --inertia 900,800,600 $cfr --ensemble "$tmp/craft.csv" --threads 1 >"$tmp/cf1.csv" 2>/dev/null
check "closed loops with wheel friction: exit 0, every member ok, 1 and 2 threads the same bytes" \
  '[ $rc -eq 0 ] && awk -F, "NR>1 && (\$2 != 30 || \$27 != \"ok\") {bad=1} END{exit bad}" "$tmp/cf2.csv" && cmp -s "$tmp/cf1.csv" "$tmp/cf2.csv"'
i=0
while IFS=, read -r r1 r2 r3 w1 w2 w3 j1 j2 j3; do
  "$sim" --inertia "$j1,$j2,$j3" $cfr --rotation "$r1,$r2,$r3" --omega "$w1,$w2,$w3" --every 1000000 >"$tmp/csingle.csv" 2>/dev/null
  check "closed-loop member $i with wheel friction = last row of its single run, bit for bit" \
    '[ "$(sed -n "$((i + 2))p" "$tmp/cf2.csv" | cut -d, -f2-19,21-26)" = "$(tail -1 "$tmp/csingle.csv" | cut -d, -f1-18,20-25)" ]'
  i=$((i + 1))
done < <(grep -v -e '^#' -e '^rotation' "$tmp/craft.csv")
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3\n0,0,0,0.5,0.5,0.5\n0.1,0.2,0.3,0.2,-0.4,0.1\n' >"$tmp/tumble.csv"
"$sim" --inertia 0.035,0.034,0.01 --scheme splitting --dt 0.25 --t-end 60 --controller bdot:1e5 --control-period 0.25 \
  --orbit-radius 6771e3 --orbit-inclination 51.6 --max-dipole 0.2 --max-step-angle 0.05 --ensemble "$tmp/tumble.csv" >"$tmp/bd.csv" 2>&1; rc=$?
"$sim" --inertia 0.035,0.034,0.01 --scheme splitting --dt 0.25 --t-end 60 --controller bdot:1e5 --control-period 0.25 \
  --orbit-radius 6771e3 --orbit-inclination 51.6 --max-dipole 0.2 --max-step-angle 0.05 --omega 0.5,0.5,0.5 --every 1000000 >"$tmp/bds.csv" 2>&1
check "B-dot members with --max-step-angle: exit 0, no wheel columns, member 0 its single run" \
  '[ $rc -eq 0 ] && [ "$(head -1 "$tmp/bd.csv")" = "$header" ] && [ "$(sed -n 2p "$tmp/bd.csv" | cut -d, -f2-19)" = "$(tail -1 "$tmp/bds.csv" | cut -d, -f1-18)" ]'
# A member whose command comes back non-finite stops at its sample (its row says why); the others finish.
# (Members 0 and 2 at rest at the target command 0; member 1's rate times 1e308 overflows.)
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3\n0,0,0,0,0,0\n0,0,0,10,0,0\n0,0,0,0,0,0\n' >"$tmp/cbad.csv"
"$sim" --inertia 900,800,600 --wheels "$tmp/rw.csv" --controller mrp-pd:1e308,1e308 --control-period 0.1 --dt 0.1 --t-end 1 \
  --ensemble "$tmp/cbad.csv" >"$tmp/cbad.out" 2>"$tmp/cbad.err"; rc=$?
check "closed loops, a refused command: exit 3, its row at t = 0 names the command, the others finish" \
  '[ $rc -eq 3 ] && sed -n 3p "$tmp/cbad.out" | grep -q "^1,0,.*non-finite command wheel_torques at t = 0" && [ "$(sed -n 2p "$tmp/cbad.out" | cut -d, -f2,27)" = "1,ok" ] && [ "$(sed -n 4p "$tmp/cbad.out" | cut -d, -f2,27)" = "1,ok" ] && grep -q "1 of 3 member(s) failed" "$tmp/cbad.err"'
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3,mgl\n0,0,0,0,0,0.01,1\n' >"$tmp/cmgl.csv"
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3,J11,J22,J33\n0,0,0,0,0,0.01,0.05,0.05,0.05\n' >"$tmp/chub.csv"
for bad in "--ensemble $tmp/cmgl.csv|column mgl: a control run's scene has no gravity" \
           "--ensemble $tmp/chub.csv|chub.csv:2: wheels: J - sum Js g g^T (the hub" \
           "--ensemble $tmp/craft.csv --rotation 0,0,1|drop --rotation"; do
  flags=${bad%%|*}; want=${bad#*|}
  "$sim" --inertia 900,800,600 --wheels "$tmp/rw.csv" --controller mrp-pd:1,5 --control-period 0.1 --dt 0.1 --t-end 1 $flags >"$tmp/bad.out" 2>"$tmp/bad.err"; rc=$?
  check "closed loops: exit 2, one line naming the reason: $want" \
    '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.out" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ] && grep -qF -- "$want" "$tmp/bad.err"'
done

# Bad files and contradicting flags: exit 2, one line, nothing on stdout.
printf 'rotation1,rotation2,rotation3,omega1,omega2\n' >"$tmp/b1.csv"
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3\n1,2,x,4,5,6\n' >"$tmp/b2.csv"
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3\n1,2,3,4,5\n' >"$tmp/b3.csv"
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3,spin\n' >"$tmp/b4.csv"
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3\n' >"$tmp/b5.csv"
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3,J11,J22,J33\n0,0,0,1,1,1,1,1,5\n' >"$tmp/b6.csv"
printf 'rotation1,rotation2,rotation3,omega1,omega2,omega3,mgl\n0,0,0,1,1,1,inf\n' >"$tmp/b7.csv"
for bad in "--ensemble $tmp/b1.csv:missing column 'omega3'" "--ensemble $tmp/b2.csv:b2.csv:2: rotation3: not a number" \
           "--ensemble $tmp/b3.csv:expected 6 fields, got 5" "--ensemble $tmp/b4.csv:unknown column 'spin'" \
           "--ensemble $tmp/b5.csv:no members" "--ensemble $tmp/b6.csv:b6.csv:2: " "--ensemble $tmp/b7.csv:mgl" \
           "--ensemble $tmp/none.csv:cannot open" "--ensemble $tmp/members.csv --omega 1,2,3:drop --omega" \
           "--ensemble $tmp/members.csv --every 10:drop --every" "--ensemble $tmp/members.csv --scheme exact:not with --scheme exact" \
           "--threads 2:--threads: only with --ensemble" "--ensemble $tmp/members.csv --threads -1:--threads: must be"; do
  flags=${bad%%:*}; want=${bad#*:}
  "$sim" --case ht1 --t-end 0.1 $flags >"$tmp/bad.out" 2>"$tmp/bad.err"; rc=$?
  check "exit 2, one line naming the reason: $flags ($want)" \
    '[ $rc -eq 2 ] && [ ! -s "$tmp/bad.out" ] && [ "$(wc -l <"$tmp/bad.err")" -eq 1 ] && grep -qF -- "$want" "$tmp/bad.err"'
done

echo "trompo-simulate --ensemble: $fails failed"
[ $fails -eq 0 ]
