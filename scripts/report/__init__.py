"""The accuracy-cost report of trompo-bench's run (docs/accuracy.md, docs/families.md).

Run from scripts/ (scripts/report.sh does: PYTHONPATH=scripts):
    /usr/bin/python3 -m report REPORT_DIR            everything (__main__.py)
    /usr/bin/python3 -m report.families REPORT_DIR   the families' part alone

Modules: common (reading bench.json, the shared predicates, formatting, a method's cost at
a bound), core (the energy-momentum schemes and the baselines: report.md, the CSVs, the
core plots), splitting, implicit and families (their sections and plots), accuracy (the
whole docs page). Every module imports common; none imports __main__, and no two import
each other both ways.

Uses only the standard library and matplotlib (Debian's python3-matplotlib).
"""
