#!/usr/bin/env python3
"""Which tests of one commit were kept, moved or deleted at another.

    python3 scripts/test-names.py BEFORE AFTER [--list]

Reads the Rust sources under crates/ at both commits (git show, no checkout) and finds every
test function: `#[test]` functions and the functions of `proptest!` blocks. A test of BEFORE
is kept when a test of that name is in the same file at AFTER, moved when it is only in other
files (printed with its files), deleted when no test has its name. Tests new at AFTER are
counted. With --list the moved and deleted tests are printed one a line as `name  before ->
after`, the moved ones' names usable as `cargo test` filters.
"""

import argparse
import re
import subprocess
import sys
from collections import defaultdict

TEST_ATTR = re.compile(r"#\[(?:\w+::)*test\]\s*(?:#\[[^\]]*\]\s*)*(?:pub\s+)?(?:async\s+)?fn\s+(\w+)")
PROPTEST = re.compile(r"proptest!\s*\{")
FN = re.compile(r"\bfn\s+(\w+)\s*\(")


def git(*args):
    return subprocess.run(["git", *args], check=True, capture_output=True, text=True).stdout


def proptest_names(text):
    """Function names inside proptest! { ... } blocks."""
    names = []
    for m in PROPTEST.finditer(text):
        depth, i = 1, m.end()
        while i < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[i], 0)
            i += 1
        names += FN.findall(text[m.end():i])
    return names


def tests(rev):
    """Test name -> set of files at a commit."""
    out = defaultdict(set)
    paths = [p for p in git("ls-tree", "-r", "--name-only", rev, "crates").split() if p.endswith(".rs")]
    for path in paths:
        text = git("show", f"{rev}:{path}")
        for name in TEST_ATTR.findall(text) + proptest_names(text):
            out[name].add(path)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("--list", action="store_true", help="print the moved and deleted tests")
    args = parser.parse_args()
    before, after = tests(args.before), tests(args.after)
    kept, moved, deleted = [], [], []
    for name, paths in sorted(before.items()):
        if name not in after:
            deleted.append((name, paths, set()))
        elif paths & after[name]:
            kept.append(name)
        else:
            moved.append((name, paths, after[name]))
    new = sorted(set(after) - set(before))
    count = lambda t: sum(len(p) for p in t.values())
    print(f"tests at {args.before}: {count(before)} ({len(before)} names); at {args.after}: {count(after)} ({len(after)} names)")
    print(f"kept in place: {len(kept)}; moved: {len(moved)}; deleted: {len(deleted)}; new names: {len(new)}")
    if args.list:
        for label, rows in (("moved", moved), ("deleted", deleted)):
            for name, old, now in rows:
                print(f"{label}  {name}  {','.join(sorted(old))} -> {','.join(sorted(now)) or '-'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
