#!/usr/bin/env python3
"""Fails when a Rust source outside crates/run spells a file name of a run folder.

The run folder's files are named in one place, `crates/run/src/layout.rs` (flexstage-run);
every other crate uses its constants. This script takes the file names from the string
literals of that module (placeholders such as `{n}` match any text) and searches the string
literals of every other `.rs` file under `crates/` (comments are not code and are skipped).
It prints each hit as `path:line: "literal" names <file>` and exits 1 if there is one.

    python3 scripts/run-file-names.py              # the check (CI)
    python3 scripts/run-file-names.py --self-test  # shows that the check can fail
"""

import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
LAYOUT = ROOT / "crates" / "run" / "src" / "layout.rs"
EXTENSIONS = ("json", "toml", "csv", "svg", "png", "vtu", "dxf", "stl", "bin", "html", "lock", "txt")
STRING = re.compile(r'"((?:[^"\\]|\\.)*)"')


def code_lines(text):
    """(line number, text) of each line with `//` comments removed (not inside strings)."""
    for n, line in enumerate(text.splitlines(), 1):
        out, in_str, i = [], False, 0
        while i < len(line):
            c = line[i]
            if in_str:
                out.append(c)
                if c == "\\" and i + 1 < len(line):
                    out.append(line[i + 1])
                    i += 1
                elif c == '"':
                    in_str = False
            elif c == '"':
                in_str = True
                out.append(c)
            elif line.startswith("//", i):
                break
            else:
                out.append(c)
            i += 1
        yield n, "".join(out)


def names(layout_text):
    """Regular expressions of the file names the layout spells."""
    found = set()
    for _, line in code_lines(layout_text):
        for lit in STRING.findall(line):
            last = lit.rsplit("/", 1)[-1]
            if "." not in last or last.rsplit(".", 1)[-1] not in EXTENSIONS:
                continue
            parts = re.split(r"\{[^}]*\}", last)
            # A name that is all placeholder but its extension or a separator names nothing.
            if sum(len(p) for p in parts) - len(last.rsplit(".", 1)[-1]) - 1 < 2:
                continue
            pattern = "[^/\"]*".join(re.escape(p) for p in parts)
            found.add(pattern)
    return sorted(found)


def hits(patterns, files):
    rx = re.compile(r"(?:^|/)(?:" + "|".join(patterns) + r")$")
    for path in files:
        for n, line in code_lines(path.read_text(encoding="utf-8", errors="replace")):
            for lit in STRING.findall(line):
                if rx.search(lit):
                    yield path, n, lit


def main():
    patterns = names(LAYOUT.read_text(encoding="utf-8"))
    if len(patterns) < 20:
        sys.exit(f"found only {len(patterns)} file names in {LAYOUT}: is it still the layout?")
    if "--self-test" in sys.argv:
        import tempfile

        with tempfile.TemporaryDirectory() as d:
            bad = pathlib.Path(d) / "bad.rs"
            bad.write_text(
                '// "design/design.json" in a comment is fine\n'
                'let a = run.path("identify/stage/table.csv");\n'
                'let b = format!("pea{n}.csv");\n'
                'let c = "flexstage.toml";\n'
            )
            got = [(n, lit) for _, n, lit in hits(patterns, [bad])]
            assert got == [(2, "identify/stage/table.csv"), (3, "pea{n}.csv")], got
        print(f"run-file-names self-test: ok ({len(patterns)} names)")
        return
    files = [
        p
        for p in sorted((ROOT / "crates").rglob("*.rs"))
        if not p.is_relative_to(ROOT / "crates" / "run") and "target" not in p.parts
    ]
    found = list(hits(patterns, files))
    for path, n, lit in found:
        print(f'{path.relative_to(ROOT)}:{n}: "{lit}" names a run file; use flexstage_run::layout')
    if found:
        sys.exit(f"{len(found)} run-file name literal(s) outside crates/run")
    print(f"run-file names: none outside crates/run ({len(files)} files, {len(patterns)} names)")


if __name__ == "__main__":
    main()
