#!/usr/bin/env python3
"""Markdown table of the controllers a run's `track` measured, for docs/verification.md.

Reads <run>/track/margins.csv, metrics.csv and montecarlo.csv (the files `flexstage track`
writes) and prints one row per controller: loop-at-a-time margins of q1 and q2 with one sample
of delay (gain margin, phase margin, gain crossover), the RMS error of the chosen trajectory
against the true output, and the Monte-Carlo pass rate. Usage:

    python3 scripts/controller-table.py RUN [--trajectory lissajous-3]
"""
import argparse
import csv
import sys
from pathlib import Path


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def margins_cell(m):
    if m is None:
        return "—"
    gm = m["gain_margin_dB"]
    gm = "unstable" if gm in ("", "nan") else f"{float(gm):.1f} dB"
    return f"{gm}, {float(m['phase_margin_deg']):.0f}° ({float(m['gain_crossover_Hz']):.0f} Hz)"


def table(run, trajectory):
    track = Path(run) / "track"
    margins = {}
    for m in rows(track / "margins.csv"):
        if m["delay_samples"] == "1":
            margins.setdefault(m["controller"], {})[m["loop"]] = m
    metrics = {
        m["variant"]: m for m in rows(track / "metrics.csv") if m["trajectory"] == trajectory
    }
    passed = {}
    mc = track / "montecarlo.csv"
    if mc.exists():
        for r in rows(mc):
            n, k = passed.get(r["controller"], (0, 0))
            passed[r["controller"]] = (n + 1, k + (r["pass"] == "true"))
    out = [
        f"| controller | margins q1 / q2 (1 sample of delay) | RMS q1/q2, {trajectory} | Monte-Carlo pass |",
        "|---|---|---|---|",
    ]
    for name, m in metrics.items():
        base = name.split("+")[0]
        loops = margins.get(base, {})
        rms = f"{float(m['rms1_nm']):.1f}/{float(m['rms2_nm']):.1f} nm"
        n, k = passed.get(name, (0, 0))
        mc_cell = f"{100 * k / n:.0f} % of {n}" if n else "—"
        out.append(
            f"| `{name}` | {margins_cell(loops.get('q1'))} / {margins_cell(loops.get('q2'))} "
            f"| {rms} | {mc_cell} |"
        )
    return "\n".join(out)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run")
    p.add_argument("--trajectory", default="lissajous-3")
    a = p.parse_args()
    try:
        print(table(a.run, a.trajectory))
    except (OSError, KeyError, ValueError) as e:
        sys.exit(f"error: {e}")


if __name__ == "__main__":
    main()
