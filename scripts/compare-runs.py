#!/usr/bin/env python3
"""Compare the values of two run folders by name, whatever their file formats.

    python3 scripts/compare-runs.py RUN_A RUN_B [--ignore REGEX] [--details N]

Every CSV, JSON and TOML file present in both folders is read into named values: a CSV cell
is named by its column header and its row (the row's text cells plus a counter when the file
has text columns, else its index); a JSON or TOML value by its path of keys and indices. Two
values with the same file and name are compared: numbers as IEEE doubles (the run files print
every double in its shortest round-trip form, so equal text means bitwise equal), text as
text with each folder's own path replaced by `<run>`. Figures and other files (SVG, PNG, VTU,
DXF, STL, HTML, TXT) are compared byte for byte; when the bytes differ, the numbers in their
text are compared in order (the same count and equal values means the drawing is the same
but its markup changed).

Prints the files compared, the values equal bitwise, the values that differ with the largest
relative difference and where, values and files found on one side only. Keys matching
--ignore (default: wall-clock times and hashes) are counted apart. Exit status 0 when no
compared value differs, 1 otherwise.
"""

import argparse
import csv
import difflib
import hashlib
import json
import math
import os
import re
import sys
import tomllib

# Wall-clock times, hashes and the typed files' format version: not results.
DEFAULT_IGNORE = (
    r"(^|[./\]])(time|time_s|seconds|seconds_per_iteration|build_seconds|reference_seconds"
    r"|sha256|scenario_hash|options_hash)$|^version$"
)
# DXF header variables that stamp the file's creation (Julian dates, GUIDs), not its drawing.
DXF_STAMPS = {b"$TDCREATE", b"$TDUCREATE", b"$TDUPDATE", b"$TDUUPDATE", b"$FINGERPRINTGUID", b"$VERSIONGUID"}
NUMBER = re.compile(rb"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
STRUCTURED = (".csv", ".json", ".toml")


def as_number(text):
    """The text as a float when it is one number, else None."""
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def flatten(value, prefix, out):
    """Named leaves of a JSON or TOML value."""
    if isinstance(value, dict):
        for key, item in value.items():
            flatten(item, f"{prefix}.{key}" if prefix else str(key), out)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            flatten(item, f"{prefix}[{i}]", out)
    elif isinstance(value, bool):
        out[prefix] = str(value).lower()
    elif isinstance(value, (int, float)):
        out[prefix] = float(value)
    elif value is None:
        out[prefix] = "null"
    else:
        out[prefix] = str(value)


def read_csv(path, root):
    """Named cells of a CSV file: row name / column header."""
    with open(path, newline="") as f:
        rows = [[c.replace(root, "<run>") for c in r] for r in csv.reader(f) if r and not r[0].startswith("#")]
    if not rows:
        return {}
    header = rows[0]
    if all(as_number(c) is not None for c in header if c != ""):
        header = [f"col{i}" for i in range(len(header))]
    else:
        rows = rows[1:]
    text_columns = [
        i for i in range(len(header))
        if any(i < len(r) and r[i] != "" and as_number(r[i]) is None for r in rows)
    ]
    out = {}
    seen = {}
    for index, row in enumerate(rows):
        if text_columns:
            label = "|".join(row[i] if i < len(row) else "" for i in text_columns)
            count = seen.get(label, 0)
            seen[label] = count + 1
            name = f"{label}#{count}"
        else:
            name = str(index)
        for i, cell in enumerate(row):
            column = header[i] if i < len(header) and header[i] != "" else f"col{i}"
            number = as_number(cell)
            out[f"{name}/{column}"] = number if number is not None else cell
    return out


def read_values(path, root):
    """Named values of a structured run file, the run folder's own path replaced by <run>."""
    if path.endswith(".csv"):
        values = read_csv(path, root)
    elif path.endswith(".json"):
        values = {}
        with open(path) as f:
            flatten(json.load(f), "", values)
    else:
        values = {}
        with open(path, "rb") as f:
            flatten(tomllib.load(f), "", values)
    for key, value in values.items():
        if isinstance(value, str):
            values[key] = value.replace(root, "<run>")
    return values


def relative(a, b):
    """|a − b| / max(|a|, |b|), 0 for two equal values, inf when one is not finite."""
    if a == b or (math.isnan(a) and math.isnan(b)):
        return 0.0
    if not (math.isfinite(a) and math.isfinite(b)):
        return math.inf
    return abs(a - b) / max(abs(a), abs(b))


def same_number(a, b):
    """Equal as doubles (NaN equals NaN)."""
    return a == b or (math.isnan(a) and math.isnan(b))


def files(root):
    """Relative paths of every file in a run folder."""
    out = set()
    for folder, _, names in os.walk(root):
        for name in names:
            out.add(os.path.relpath(os.path.join(folder, name), root))
    return out


def compare_structured(rel, a_root, b_root, ignore, totals, report):
    """Compare the named values of one CSV/JSON/TOML file present in both folders."""
    try:
        a = read_values(os.path.join(a_root, rel), a_root)
        b = read_values(os.path.join(b_root, rel), b_root)
    except (ValueError, tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        report.append((rel, f"unreadable: {e}", []))
        totals["unreadable"] += 1
        return
    equal = differ = 0
    ignored = {k for k in a.keys() | b.keys() if ignore.search(k)}
    worst = (0.0, None, None, None)
    diffs = []
    for key in sorted((a.keys() & b.keys()) - ignored):
        x, y = a[key], b[key]
        if isinstance(x, float) and isinstance(y, float):
            same = same_number(x, y)
            rel_diff = relative(x, y)
        else:
            same = x == y
            rel_diff = math.inf
        if same:
            equal += 1
        else:
            differ += 1
            diffs.append((rel_diff, key, x, y))
            if rel_diff >= worst[0]:
                worst = (rel_diff, key, x, y)
    only_a = sorted(a.keys() - b.keys() - ignored)
    only_b = sorted(b.keys() - a.keys() - ignored)
    ignored = len(ignored)
    totals["values"] += equal + differ
    totals["equal"] += equal
    totals["differ"] += differ
    totals["ignored"] += ignored
    totals["only_a"] += len(only_a)
    totals["only_b"] += len(only_b)
    if differ:
        totals["files_differ"] += 1
        totals["max_rel"] = max(totals["max_rel"], worst[0])
    line = f"{equal} equal"
    if differ:
        line += f", {differ} differ (max rel {worst[0]:.3g} at {worst[1]}: {worst[2]!r} vs {worst[3]!r})"
    if ignored:
        line += f", {ignored} ignored"
    if only_a or only_b:
        line += f", names only in A: {len(only_a)} {only_a[:4]}, only in B: {len(only_b)} {only_b[:4]}"
    diffs.sort(reverse=True)
    report.append((rel, line, diffs))


def without_dxf_stamps(data):
    """A DXF file's text without the values of its creation stamps (group code/value pairs)."""
    lines = data.split(b"\n")
    out, skip = [], 0
    for line in lines:
        if skip:
            skip -= 1
            continue
        out.append(line)
        if line.strip() in DXF_STAMPS:
            skip = 2
    return b"\n".join(out)


def html_parts(text):
    """An HTML page's embedded figures (inline SVG, PNG data URIs) and its text lines without them."""
    svg = re.findall(r"<svg\b.*?</svg>", text, flags=re.S)
    png = re.findall(r"data:image/png;base64,[A-Za-z0-9+/=]+", text)
    text = re.sub(r"<svg\b.*?</svg>", "<svg/>", text, flags=re.S)
    text = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "PNG", text)
    text = re.sub(r"<style>.*?</style>", "", text, flags=re.S)
    return svg + png, re.sub(r">\s*<", ">\n<", text).split("\n")


def compare_html(rel, a_text, b_text, report):
    """A report page: its embedded figures compared as a set, then its text line by line."""
    a_figs, a_lines = html_parts(a_text.decode())
    b_figs, b_lines = html_parts(b_text.decode())
    same = len(set(a_figs) & set(b_figs))
    lines = [
        (math.inf, "text", x, "")
        for x in difflib.unified_diff(a_lines, b_lines, lineterm="", n=0)
        if x[:1] in "+-" and not x.startswith(("+++", "---"))
    ]
    report.append((rel, f"bytes differ; embedded figures {len(a_figs)} vs {len(b_figs)}, {same} equal; "
                        f"{len(lines)} text lines differ", lines))


def compare_bytes(rel, a_root, b_root, totals, report):
    """Compare a figure or other file byte for byte, then by the numbers in its text."""
    with open(os.path.join(a_root, rel), "rb") as f:
        a = f.read()
    with open(os.path.join(b_root, rel), "rb") as f:
        b = f.read()
    if a == b:
        totals["bytes_equal"] += 1
        report.append((rel, "bytes equal", []))
        return
    totals["bytes_differ"] += 1
    a_text = a.replace(a_root.encode(), b"<run>")
    b_text = b.replace(b_root.encode(), b"<run>")
    if a_text == b_text:
        report.append((rel, "bytes differ only by the run folder's path", []))
        return
    if rel.endswith(".dxf"):
        a_text, b_text = without_dxf_stamps(a_text), without_dxf_stamps(b_text)
        if a_text == b_text:
            report.append((rel, "bytes differ only in the creation date and GUIDs of the header", []))
            return
    if rel.endswith(".html"):
        compare_html(rel, a_text, b_text, report)
        return
    if rel.endswith(".png"):
        digest = lambda data: hashlib.sha256(data).hexdigest()[:12]
        report.append((rel, f"bytes differ (png {digest(a)} vs {digest(b)})", []))
        return
    na = [float(t) for t in NUMBER.findall(a_text)]
    nb = [float(t) for t in NUMBER.findall(b_text)]
    if len(na) != len(nb):
        report.append((rel, f"bytes differ; {len(na)} vs {len(nb)} numbers in the text", []))
        return
    diffs = [(relative(x, y), f"number {i}", x, y) for i, (x, y) in enumerate(zip(na, nb)) if not same_number(x, y)]
    if not diffs:
        report.append((rel, f"bytes differ, all {len(na)} numbers equal (markup changed)", []))
        return
    diffs.sort(reverse=True)
    report.append((rel, f"bytes differ; {len(diffs)} of {len(na)} numbers differ, max rel {diffs[0][0]:.3g}", diffs))


def compare(a_root, b_root, ignore):
    """Totals and per-file lines of the comparison of two run folders (absolute paths)."""
    a_files, b_files = files(a_root), files(b_root)
    totals = dict.fromkeys(
        ["values", "equal", "differ", "ignored", "only_a", "only_b", "files_differ",
         "bytes_equal", "bytes_differ", "unreadable"], 0)
    totals["max_rel"] = 0.0
    report = []
    common = sorted(a_files & b_files)
    for rel in common:
        if rel.endswith(STRUCTURED):
            compare_structured(rel, a_root, b_root, ignore, totals, report)
        else:
            compare_bytes(rel, a_root, b_root, totals, report)
    totals["common"] = common
    totals["files_only_a"] = sorted(a_files - b_files)
    totals["files_only_b"] = sorted(b_files - a_files)
    return totals, report


def self_test():
    """Two small run folders with known differences give the known counts: a one-ulp change
    in a CSV cell named by its row's text (each folder's path as <run>), a text change in TOML,
    a JSON key on one side, wall-clock time and version ignored, an SVG with one number
    changed, a file on one side."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        a_root, b_root = os.path.join(tmp, "a"), os.path.join(tmp, "b")
        x = 0.1 + 0.2
        next_x = math.nextafter(x, 1.0)
        content = {
            "a": {
                "t.csv": f"name,v,path\nk,{x!r},{a_root}/f\nk,2,{a_root}/f\n",
                "s.json": '{"version": 1, "time": 3.5, "m": {"f": [1.5, 2.5]}}',
                "p.toml": 'x = 1.0\n[s]\ny = "a"\n',
                "f.svg": "<svg><path d='M0 0L1 2'/></svg>",
                "g.svg": "<svg><path d='M0 0L1 2'/></svg>",
                "only_a.csv": "v\n1\n",
            },
            "b": {
                "t.csv": f"name,v,path\nk,{next_x!r},{b_root}/f\nk,2,{b_root}/f\n",
                "s.json": '{"version": 2, "time": 9.0, "m": {"f": [1.5, 2.5], "g": 1}}',
                "p.toml": 'x = 1.0\n[s]\ny = "b"\n',
                "f.svg": "<svg><path d='M0 0L1 2'/></svg>",
                "g.svg": "<svg><path d='M0 0 L1 2.5'/></svg>",
            },
        }
        for side, named in content.items():
            os.makedirs(os.path.join(tmp, side))
            for name, text in named.items():
                with open(os.path.join(tmp, side, name), "w") as f:
                    f.write(text)
        totals, report = compare(a_root, b_root, re.compile(DEFAULT_IGNORE))
    lines = dict((rel, line) for rel, line, _ in report)
    expected = {
        "values": 10, "equal": 8, "differ": 2, "ignored": 2, "only_a": 0, "only_b": 1,
        "files_differ": 2, "bytes_equal": 1, "bytes_differ": 1,
        "files_only_a": ["only_a.csv"], "files_only_b": [],
    }
    failed = [(k, totals[k], v) for k, v in expected.items() if totals[k] != v]
    rel = (next_x - x) / next_x
    if totals["max_rel"] != math.inf or f"1 differ (max rel {rel:.3g} at k|<run>/f#0/v" not in lines["t.csv"]:
        failed.append(("t.csv", lines["t.csv"], f"one ulp, rel {rel:.3g}"))
    if "1 of 4 numbers differ" not in lines["g.svg"]:
        failed.append(("g.svg", lines["g.svg"], "1 of 4 numbers differ"))
    for item in failed:
        print("self-test failed: %s is %r, expected %r" % item)
    print("self-test:", "failed" if failed else "ok")
    return 1 if failed else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("a", nargs="?", help="first run folder (before)")
    parser.add_argument("b", nargs="?", help="second run folder (after)")
    parser.add_argument("--ignore", default=DEFAULT_IGNORE, help="regex of value names counted apart")
    parser.add_argument("--details", type=int, default=0, help="print the N largest differences per file")
    parser.add_argument("--self-test", action="store_true", help="check the script on two small folders")
    args = parser.parse_args()
    if args.self_test:
        return self_test()
    if not (args.a and args.b):
        parser.error("two run folders are needed")
    totals, report = compare(os.path.abspath(args.a), os.path.abspath(args.b), re.compile(args.ignore))
    for rel, line, diffs in report:
        print(f"{rel}: {line}")
        for rel_diff, key, x, y in diffs[: args.details]:
            if key == "text":
                print(f"    {x[:160]}")
            else:
                print(f"    {key}: {x!r} vs {y!r} (rel {rel_diff:.3g})")
    common = totals["common"]
    structured = sum(1 for r in common if r.endswith(STRUCTURED))
    print()
    print(f"files in both: {len(common)} ({structured} CSV/JSON/TOML compared by value, "
          f"{len(common) - structured} other compared by bytes)")
    print(f"values compared: {totals['values']}; equal bitwise: {totals['equal']}; "
          f"differ: {totals['differ']} in {totals['files_differ']} files "
          f"(max relative difference {totals['max_rel']:.3g}); ignored by name: {totals['ignored']}")
    print(f"names only in A: {totals['only_a']}; only in B: {totals['only_b']}; unreadable: {totals['unreadable']}")
    print(f"other files: {totals['bytes_equal']} bytes equal, {totals['bytes_differ']} differ")
    print(f"files only in A: {totals['files_only_a']}")
    print(f"files only in B: {totals['files_only_b']}")
    return 1 if totals["differ"] else 0


if __name__ == "__main__":
    sys.exit(main())
