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
