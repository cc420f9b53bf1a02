"""python3 -m report REPORT_DIR: the whole report of one trompo-bench run.

Reads  REPORT_DIR/bench.json            (trompo-bench --benchmark_out, both families)
       REPORT_DIR/energy_series.csv     (trompo-bench --trompo_energy_series), optional
       REPORT_DIR/satellite_series.csv  (trompo-bench --trompo_satellite_series), optional
       REPORT_DIR/machine.txt           (lscpu), optional
Writes REPORT_DIR/report.md, sweep.csv, step.csv, frontier.csv, attitude_only.csv,
       splitting_targets.csv, families.md, accuracy.md (the docs page, whole) and the plots
       work_precision*.png, frontier.png, energy_vs_h.png, newton_vs_h.png,
       energy_over_time.png, satellite.png, invariants_families.png, large_step_ht0.png,
       adaptive_tolerance.png, adaptive_work_precision.png (report/adaptive.py)

With TROMPO_UPDATE_DOCS=1 in the environment it also copies accuracy.md over
docs/accuracy.md.
"""
import os
import sys

from . import accuracy, core, families, splitting
from .common import fmt, load, read_machine


def main():
    report_dir = sys.argv[1] if len(sys.argv) > 1 else "report"
    context, sweep, steps = load(report_dir)
    machine = read_machine(report_dir)
    core.write_csvs(report_dir, sweep, steps)
    st, fr, att = core.write_report(report_dir, context, sweep, steps, machine)

    # ---- families (families.py, docs/families.md) ------------------------------------------
    # The core figures keep the energy-momentum schemes and the baselines; the other families
    # get their own figures, and the main work-precision figure (work_precision.png) shows
    # each family's lower envelope.
    in_core = lambda m: families.family_of(m) in ("energy-momentum", "explicit")  # noqa: E731
    # The splittings in the core figure too: they are what the energy-momentum schemes compete with.
    core_wp = lambda m: in_core(m) or (families.family_of(m) == "splitting" and splitting.in_work_precision(m))  # noqa: E731
    core.plot_grid(report_dir, sweep, "work_precision_core.png", "cpu_ms", "err_rot", "CPU time per run [ms]",
                   "‖Λ − Λref‖ at the end", "Work–precision: end attitude error vs CPU time", yfloor=1e-16,
                   methods_filter=core_wp)
    core.plot_grid(report_dir, sweep, "energy_vs_h.png", "h", "max_dH", "h (dopri5: mean step)",
                   "max |ΔH/H| over the run", "Energy error vs step size", yfloor=1e-17, methods_filter=in_core)
    core.plot_grid(report_dir, sweep, "newton_vs_h.png", "h", "newton", "h", "Newton iterations per base step",
                   "Newton iterations vs step size",
                   methods_filter=lambda m: in_core(m) and m not in ("rk4", "odeint-rk4", "odeint-dopri5"),
                   transform=lambda r: r["newton"] / r["stages"], linear_y=True)
    families_md = families.write(report_dir, sweep, steps)
    with open(os.path.join(report_dir, "report.md"), "a") as f:
        f.write("\n" + families_md)
    # ---- end families ----------------------------------------------------------------------
    core.plot_frontier(report_dir, sweep, fr)
    core.plot_energy_series(report_dir)
    core.plot_satellite_series(report_dir)
    splitting.write_csv(report_dir, sweep, steps)
    page = accuracy.write(report_dir, sweep, steps, fr, core.FRONTIER_ROT, core.FRONTIER_DH)

    # A short summary on stdout.
    if st:
        print(f"step target: Simo-kappa {st['kappa_ns']:.0f} ns / RK4 {st['rk4_ns']:.0f} ns = {st['ratio']:.2f}x "
              f"(target <= {core.STEP_RATIO_TARGET}), Newton {st['newton']:.2f}/step"
              + (f", vs odeint rk4 {st['ratio_odeint']:.2f}x" if st["ratio_odeint"] else ""))
    for case, f in fr.items():
        parts = []
        for key in ("trompo", "dopri5", "rk4"):
            r = f[key]
            parts.append(f"{key} {fmt(r['cpu_ms'], 3)} ms [{core.config_text(r)}]" if r else f"{key}: not reached")
        print(f"frontier {case}: " + "; ".join(parts))
    print(f"wrote {report_dir}/report.md, {page} and plots")
    if os.environ.get("TROMPO_UPDATE_DOCS", "0") == "1":
        print(f"wrote the page over {accuracy.update_docs(report_dir)}")


if __name__ == "__main__":
    main()
