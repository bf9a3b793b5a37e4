#!/usr/bin/env python3
"""Measures flexstage's speed and writes docs/performance.md's tables.

Every row is measured by this script: the divan benchmarks of every crate (medians, with the
fastest sample beside them) and the whole commands a user runs (wall time, CPU time and peak
resident memory of the child process). Each row names the command that produced it and the
load average of the machine while it ran (the 1-minute average, highest of before and after),
because on a shared machine the load decides the figure.

    python3 scripts/performance.py            # everything (about 15 minutes on 2 cores)
    python3 scripts/performance.py --benches  # the divan benchmarks only
    python3 scripts/performance.py --commands # the whole commands only
    python3 scripts/performance.py --self-test

The tables replace the text between the `performance:benches` and `performance:commands`
markers of docs/performance.md; the prose around them is kept.
"""

import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "performance.md")

# (crate, bench target): every divan benchmark of the workspace.
BENCHES = [
    ("flexstage-fem", "fem"),
    ("flexstage-mma", "update"),
    ("flexstage-topopt", "topopt"),
    ("flexstage-reduce", "reduce"),
    ("flexstage-verify", "verify"),
    ("flexstage-twin", "twin"),
    ("flexstage-piezo", "step"),
    ("flexstage-numerics", "numerics"),
    ("flexstage-identify", "identify"),
    ("flexstage-control", "control"),
    ("flexstage-control-core", "step"),
    ("flexstage-run", "run"),
]

# Targets the project set itself, by benchmark path (shown beside the measured median).
TARGETS = {
    "topopt · paper_preset_iteration": "≤ 0.6 s",
    "topopt · fine_preset_iteration": "≤ 2 s",
    "twin · twin_plant_one_second · Quick": "≤ 50 ms",
    "twin · twin_plant_one_second · Paper": "≤ 50 ms",
    "step · model_plus_compensation_step": "≤ 200 ns",
    "step · parallel_rls_sample": "≤ 300 ns",
    "control · learning_step": "≤ 1 µs",
}

# Whole commands: (what, argv after the flexstage binary). Run in a fresh temporary folder.
COMMANDS = [
    ("the README main job on the quick preset (all stages)", ["run", "--out", "{tmp}/quick"]),
    ("the paper preset's design", ["design", "--preset", "paper", "--out", "{tmp}/paper"]),
    ("export and body-fitted verification of the paper design",
     ["export", "--preset", "paper", "--out", "{tmp}/paper"]),
]

ROW = re.compile(r"^((?:[│ ]  )*)(?:├─|╰─) (\S.*?)(?:\s{2,}(.*))?$")


def parse_divan(text, binary):
    """Rows (path, fastest, median, samples) of divan's tree output."""
    rows, stack = [], []
    for line in text.splitlines():
        m = ROW.match(line)
        if not m:
            continue
        depth = len(m.group(1)) // 3
        name = m.group(2).strip()
        stack = stack[:depth] + [name]
        rest = m.group(3) or ""
        cols = [c.strip() for c in rest.split("│")]
        if len(cols) >= 5 and cols[0]:
            rows.append((" · ".join([binary] + stack), cols[0], cols[2], cols[4]))
    return rows


def load():
    return os.getloadavg()[0]


def run_benches():
    out = []
    for crate, bench in BENCHES:
        cmd = ["cargo", "bench", "-q", "-p", crate, "--bench", bench]
        subprocess.run(cmd + ["--no-run"], cwd=ROOT, check=True)
        before = load()
        res = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
        after = load()
        shown = f"cargo bench -p {crate} --bench {bench}"
        for path, fastest, median, samples in parse_divan(res.stdout, bench):
            out.append((path, median, fastest, samples, TARGETS.get(path, ""), shown,
                        max(before, after)))
        print(f"performance: {crate} done", file=sys.stderr)
    return out


def run_commands():
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "flexstage"], cwd=ROOT, check=True)
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    binary = os.path.join(target, "release", "flexstage")
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for what, argv in COMMANDS:
            args = [a.replace("{tmp}", tmp) for a in argv]
            before = load()
            t0 = time.monotonic()
            child = subprocess.Popen([binary] + args, cwd=tmp, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
            # This child's own usage (RUSAGE_CHILDREN would hold the largest of every child
            # so far, the benchmarks included).
            _, status, usage = os.wait4(child.pid, 0)
            child.returncode = os.waitstatus_to_exitcode(status)
            wall = time.monotonic() - t0
            after = load()
            if child.returncode != 0:
                raise SystemExit(f"performance: {' '.join(args)} exited {child.returncode}")
            cpu = usage.ru_utime + usage.ru_stime
            rss_mb = usage.ru_maxrss / 1024  # KiB on Linux
            shown = "flexstage " + " ".join(a.replace(tmp, "DIR") for a in args)
            out.append((what, f"{wall:.1f} s", f"{cpu:.1f} s", f"{rss_mb:.0f} MB", shown,
                        max(before, after)))
            print(f"performance: {what} done", file=sys.stderr)
    return out


def bench_table(rows):
    lines = ["| benchmark | median | fastest | samples | target | command | load |",
             "|---|---|---|---|---|---|---|"]
    for path, median, fastest, samples, target, cmd, ld in rows:
        lines.append(f"| `{path}` | {median} | {fastest} | {samples} | {target} | `{cmd}` | {ld:.1f} |")
    return lines


def command_table(rows):
    lines = ["| what | wall | CPU | peak RSS | command | load |", "|---|---|---|---|---|---|"]
    for what, wall, cpu, rss, cmd, ld in rows:
        lines.append(f"| {what} | {wall} | {cpu} | {rss} | `{cmd}` | {ld:.1f} |")
    return lines


def replace(text, name, lines, stamp):
    begin, end = f"<!-- performance:{name}:begin -->", f"<!-- performance:{name}:end -->"
    i, j = text.index(begin), text.index(end)
    body = "\n".join([f"Measured {stamp} by `python3 scripts/performance.py`.", ""] + lines)
    return text[: i + len(begin)] + "\n" + body + "\n" + text[j:]


def self_test():
    sample = """Timer precision: 18 ns
step                             fastest       │ slowest       │ median        │ mean          │ samples │ iters
├─ model_step                    73.85 ns      │ 2.829 µs      │ 75.85 ns      │ 103.5 ns      │ 100     │ 100
╰─ twin_plant_one_second                       │               │               │               │         │
   ├─ Quick                      18 ms         │ 19 ms         │ 18.5 ms       │ 18.6 ms       │ 10      │ 10
   ╰─ Paper                      19 ms         │ 20 ms         │ 19.2 ms       │ 19.3 ms       │ 10      │ 10
"""
    rows = parse_divan(sample, "twin")
    assert rows == [
        ("twin · model_step", "73.85 ns", "75.85 ns", "100"),
        ("twin · twin_plant_one_second · Quick", "18 ms", "18.5 ms", "10"),
        ("twin · twin_plant_one_second · Paper", "19 ms", "19.2 ms", "10"),
    ], rows
    text = "a\n<!-- performance:benches:begin -->\nold\n<!-- performance:benches:end -->\nb\n"
    new = replace(text, "benches", ["x"], "today")
    assert "old" not in new and "x" in new and new.startswith("a\n") and new.endswith("b\n")
    print("performance.py self-test passed")


def main():
    args = set(sys.argv[1:])
    if "--self-test" in args:
        self_test()
        return
    stamp = time.strftime("%Y-%m-%d") + f" on {os.cpu_count()} cores"
    text = open(DOC, encoding="utf-8").read()
    if "--commands" not in args:
        text = replace(text, "benches", bench_table(run_benches()), stamp)
    if "--benches" not in args:
        text = replace(text, "commands", command_table(run_commands()), stamp)
    tmp = DOC + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, DOC)
    print("performance: docs/performance.md updated", file=sys.stderr)


if __name__ == "__main__":
    main()
