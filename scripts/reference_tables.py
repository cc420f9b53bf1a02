#!/usr/bin/python3
"""Regenerates the reference tables of tests/data/reference_cases.hpp (HT0, HT1, FB1, FB2 at
21 times, HT2 at t = 0.5 and 2) in 50-digit arithmetic, independently of trompo and of the
closed forms the tables were first computed from: a Taylor-series integration of the rigid
body's equations, whose right-hand side is a quadratic polynomial, so that every Taylor
coefficient is exact (Cauchy products, no differencing):

    Λ' = Λ Ω̂,   J Ω' = JΩ × Ω + Mgl (Λᵀγ) × E      (γ = e3; Mgl = 0: the free bodies)

Steps of order 40, each sized so that the last coefficients are below 1e-44 of the state,
end exactly on the tables' times. Each value is rounded once to the nearest double.

    /usr/bin/python3 scripts/reference_tables.py            # print the tables (C++)
    /usr/bin/python3 scripts/reference_tables.py --check    # compare with the header

--check compares every double of the header with the generated one and fails if one is off
by more than 1 ulp (HT2: by more than 1e-20 relative to max(|x|, 1), or than its printed
digits where only 17 are printed). It takes a few minutes. Needs mpmath (Debian: python3-mpmath; `bash scripts/deps.sh python3-mpmath`): a tool
for regenerating the tables, not part of the test command.
"""
import argparse
import math
import os
import re
import sys

import mpmath as mp

mp.mp.dps = 50
ORDER = 40
TOL = mp.mpf("1e-44")
# HT2's published rows (RKF7(8) in 128-bit floats at tol 1e-26, 25 digits printed) are
# accurate to about 1e-24 (measured here: 7.5e-25); a wrong 21st digit fails.
HT2_AGREEMENT = mp.mpf("1e-20")

# Inputs, exact decimals (docs/theory.md §8; the header's comment).
CASES = {
    "ht0": dict(J=("5", "5", "1"), Mgl="196.2", E=(0, 0, 1), rot_x="0.3", omega=("0", "0", "50"),
                times=[mp.mpf(k) / 2 for k in range(21)], free=False),
    "ht1": dict(J=("5", "5", "1"), Mgl="20", E=(0, 0, 1), rot_x="0.05", omega=("0", "0", "50"),
                times=[mp.mpf(k) / 2 for k in range(21)], free=False),
    "fb1": dict(J=("1", "2", "3"), Mgl="0", E=(0, 0, 1), rot_x="0", omega=("0.01", "2", "0.01"),
                times=[mp.mpf(5 * k) for k in range(21)], free=True),
    # FB2: Π0 = JΩ0 = (cos 1.1, 0, sin 1.1), J = diag(2, 1, 2/3)
    "fb2": dict(J=("2", "1", "2/3"), Mgl="0", E=(0, 0, 1), rot_x="0", omega=None,
                times=[mp.mpf(5 * k) for k in range(21)], free=True),
    # HT2: M = 15, l = 1, g = 9.81, E = e2, J about the fixed point
    "ht2": dict(J=("15.234375", "0.46875", "15.234375"), Mgl="147.15", E=(0, 1, 0), rot_x="0",
                omega=("0", "150", "-4.61538"), times=[mp.mpf("0.5"), mp.mpf(2)], free=False),
}


def num(text):
    if "/" in text:
        a, b = text.split("/")
        return mp.mpf(a) / mp.mpf(b)
    return mp.mpf(text)


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


class Top:
    def __init__(self, c):
        self.J = [num(x) for x in c["J"]]
        self.Mgl = num(c["Mgl"])
        self.E = [mp.mpf(x) for x in c["E"]]

    def series(self, L, W):
        """Taylor coefficients [(L_k, W_k)] of order ORDER at (L, W)."""
        J, Mgl, E = self.J, self.Mgl, self.E
        Ls, Ws = [L], [W]
        for k in range(ORDER):
            # (Λ Ω̂)_k = Σ_m Λ_m Ω̂_{k−m}, (ΛΩ̂)_ij = Σ_l Λ_il Ω̂_lj, and (JΩ × Ω)_k likewise
            dL = [[mp.mpf(0)] * 3 for _ in range(3)]
            dP = [mp.mpf(0)] * 3  # (JΩ × Ω)_k
            for m in range(k + 1):
                Lm, Wn = Ls[m], Ws[k - m]
                for i in range(3):
                    a0, a1, a2 = Lm[i]
                    dL[i][0] += a1 * Wn[2] - a2 * Wn[1]
                    dL[i][1] += a2 * Wn[0] - a0 * Wn[2]
                    dL[i][2] += a0 * Wn[1] - a1 * Wn[0]
                Wm = Ws[m]
                JW = [J[0] * Wm[0], J[1] * Wm[1], J[2] * Wm[2]]
                c = cross(JW, Wn)
                for i in range(3):
                    dP[i] += c[i]
            Gk = Ls[k][2]  # Λᵀγ with γ = e3: the third row of Λ
            tau = cross(Gk, E)
            dW = [(dP[i] + Mgl * tau[i]) / J[i] for i in range(3)]
            Ls.append([[x / (k + 1) for x in row] for row in dL])
            Ws.append([x / (k + 1) for x in dW])
        return Ls, Ws

    def step(self, L, W, h_max):
        """One Taylor step of at most h_max; returns (L, W, h)."""
        Ls, Ws = self.series(L, W)
        size = max(max(abs(x) for row in L for x in row), max(abs(x) for x in W), mp.mpf(1))
        h = h_max
        for k in (ORDER - 1, ORDER):
            ck = max(max(abs(x) for row in Ls[k] for x in row), max(abs(x) for x in Ws[k]))
            if ck > 0:
                h = min(h, (TOL * size / ck) ** (mp.mpf(1) / k))
        # Horner
        Ln = [[mp.mpf(0)] * 3 for _ in range(3)]
        Wn = [mp.mpf(0)] * 3
        for k in range(ORDER, -1, -1):
            Ln = [[Ln[i][j] * h + Ls[k][i][j] for j in range(3)] for i in range(3)]
            Wn = [Wn[i] * h + Ws[k][i] for i in range(3)]
        return Ln, Wn, h


def initial(c):
    a = num(c["rot_x"])
    L = [[mp.mpf(1), mp.mpf(0), mp.mpf(0)], [mp.mpf(0), mp.cos(a), -mp.sin(a)], [mp.mpf(0), mp.sin(a), mp.cos(a)]]
    if c["omega"] is None:  # FB2
        J = [num(x) for x in c["J"]]
        W = [mp.cos(mp.mpf("1.1")) / J[0], mp.mpf(0), mp.sin(mp.mpf("1.1")) / J[2]]
    else:
        W = [num(x) for x in c["omega"]]
    return L, W


def rows(name):
    c = CASES[name]
    top = Top(c)
    L, W = initial(c)
    t = mp.mpf(0)
    out = []
    for T in c["times"]:
        while t < T:
            L, W, h = top.step(L, W, T - t)
            t = T if h == T - t else t + h
        JW = [top.J[i] * W[i] for i in range(3)]
        H = sum(W[i] * JW[i] for i in range(3)) / 2 + top.Mgl * sum(L[2][i] * top.E[i] for i in range(3))
        m = [sum(L[i][j] * JW[j] for j in range(3)) for i in range(3)]  # ΛJΩ
        row = [T] + [L[i][j] for i in range(3) for j in range(3)] + W + [H, m[2]]
        if c["free"]:
            row += m
        out.append(row)
    return out


def header_tables(path):
    text = open(path, encoding="utf-8").read()
    tables = {}
    for m in re.finditer(r"inline constexpr double (\w+)\[\d+\]\[\d+\] = \{(.*?)\n\};", text, re.S):
        body = re.sub(r"//[^\n]*", "", m.group(2))
        rows_ = re.findall(r"\{([^{}]*)\}", body)
        tables[m.group(1)] = [[s.strip() for s in r.split(",") if s.strip()] for r in rows_]
    return tables


def ulps(a, b):
    if a == b:
        return 0
    if b == 0.0:  # an exact zero of the header (π2 of FB2): the generated value is ~1e-45
        return 0 if abs(a) < 1e-30 else math.inf
    return abs(a - b) / math.ulp(max(abs(a), abs(b)))


def half_last_digit(s):
    """Half a unit of the last printed digit of the decimal s (its rounding)."""
    mant = s.lower().split("e")[0].lstrip("+-")
    exp = int(s.lower().split("e")[1]) if "e" in s.lower() else 0
    digits = mant.replace(".", "").lstrip("0")
    decimals = len(mant.split(".")[1]) if "." in mant else 0
    if not digits:
        return mp.mpf("1e-30")
    return mp.mpf(10) ** (exp - decimals) / 2


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true", help="compare with tests/data/reference_cases.hpp")
    ap.add_argument("--cases", default="ht0,ht1,fb1,fb2,ht2")
    args = ap.parse_args()
    names = args.cases.split(",")
    if not args.check:
        for name in names:
            print("// %s: t, R00..R22, Omega1..3, H, momentum_map%s" % (name, ", m1..m3" if CASES[name]["free"] else ""))
            for r in rows(name):
                digits = 25 if name == "ht2" else 17
                print("    {" + ", ".join(mp.nstr(x, digits, strip_zeros=True) if name == "ht2" else repr(float(x)) for x in r) + "},")
        return 0
    here = os.path.dirname(os.path.abspath(__file__))
    tables = header_tables(os.path.join(here, "..", "tests", "data", "reference_cases.hpp"))
    bad = 0
    for name in names:
        got = rows(name)
        want = tables[name]
        worst = 0.0
        worst_rel = mp.mpf(0)
        exact = total = 0
        for r_got, r_want in zip(got, want):
            if len(r_got) != len(r_want):
                print("%s: row at t = %s has %d columns, the header %d" % (name, r_got[0], len(r_got), len(r_want)))
                bad += 1
                continue
            for x, s in zip(r_got, r_want):
                total += 1
                if name == "ht2":  # relative to max(|x|, 1), or to the printed digits where fewer (17)
                    y = mp.mpf(s)
                    rel = abs(x - y) / max(abs(y), mp.mpf(1))
                    if len(re.sub(r"[^0-9]", "", s.lower().split("e")[0]).lstrip("0")) > 20:
                        worst_rel = max(worst_rel, rel)  # the 25-digit values
                    if rel <= HT2_AGREEMENT or abs(x - y) <= half_last_digit(s):
                        exact += 1
                else:
                    u = ulps(float(x), float(s))
                    worst = max(worst, u)
                    if u == 0:
                        exact += 1
        if len(got) != len(want):
            print("%s: %d rows, the header %d" % (name, len(got), len(want)))
            bad += 1
        if name == "ht2":
            ok = exact == total
            print("%s: %d of %d values agree (the 25-digit ones to %s relative to max(|x|, 1))" %
                  (name, exact, total, mp.nstr(worst_rel, 3)))
        else:
            ok = worst <= 1
            print("%s: %d of %d doubles identical, the rest within %g ulp" % (name, exact, total, worst))
        bad += 0 if ok else 1
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
