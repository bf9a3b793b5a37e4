#!/usr/bin/env python3
"""Lists the functions of the workspace's library code longer than a limit; exits 1 if any.

The charter: no function over 150 lines outside data literals and tests. This scans
`crates/*/src/**/*.rs` (not `tests/`, `benches/`, `examples/`), skips the bodies of
`#[cfg(test)]` modules and `#[test]` functions, and counts a function from its `fn` line to
the line of its closing brace. A function that is a data literal (a table written out) is
exempt when the line above its `fn` (or above its attributes and doc comments) says
`// fn-length: data literal`.

The scanner is a small lexer, not a parser: it knows line and block comments (nested), string
literals (also raw `r#"…"#` and byte strings), char literals and lifetimes, so braces inside
them are not counted.

Usage: scripts/fn-lengths.py [--limit N] [--top K] [--self-test] [ROOT]
  --limit N  longest allowed function in lines (default 150)
  --top K    also print the K longest functions (default 0)
"""

import argparse
import pathlib
import re
import sys

EXEMPT = "fn-length: data literal"


def tokens(text):
    """Yields (kind, value, line) for the tokens that matter: identifiers, `{`, `}`, `;`, `#`,
    `[`, `]`, `(`, `)`, and comments (kind "comment"). Strings and chars are skipped."""
    i, n, line = 0, len(text), 1
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif c.isspace():
            i += 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            yield "comment", text[i:j], line
            i = j
        elif text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            line += text.count("\n", i, j)
            i = j
        elif re.match(r'b?r#*"', text[i:i + 260]):
            m = re.match(r'(b?r)(#*)"', text[i:])
            close = '"' + m.group(2)
            j = text.find(close, i + len(m.group(0)))
            j = n if j < 0 else j + len(close)
            line += text.count("\n", i, j)
            i = j
        elif c == '"' or text.startswith('b"', i):
            j = i + (2 if c == "b" else 1)
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            j += 1
            line += text.count("\n", i, j)
            i = j
        elif c == "'" or text.startswith("b'", i):
            # A char literal ('x', '\n', '\u{..}', b'x') or a lifetime ('a).
            k = i + (2 if c == "b" else 1)
            m = re.match(r"(\\u\{[0-9a-fA-F]+\}|\\.|[^\\'])'", text[k:k + 12])
            if m:
                i = k + len(m.group(0))
            else:
                i = k  # a lifetime: the identifier follows
        elif c.isalpha() or c == "_":
            m = re.match(r"[A-Za-z_][A-Za-z0-9_]*", text[i:])
            yield "ident", m.group(0), line
            i += len(m.group(0))
        elif c in "{}();#[]":
            yield "punct", c, line
            i += 1
        else:
            i += 1


def functions(text):
    """Yields (name, first line, last line, exempt) of every function outside test code."""
    toks = list(tokens(text))
    depth = 0
    skip_until = None  # depth at which a skipped test item ends
    pending_test = False  # a #[cfg(test)] or #[test] attribute waits for its item
    last_comment_line = {}  # line -> comment text
    open_fns = []  # (name, start line, depth of its body, exempt)
    i = 0
    while i < len(toks):
        kind, v, line = toks[i]
        if kind == "comment":
            last_comment_line[line] = v
        elif v == "#" and i + 1 < len(toks) and toks[i + 1][1] == "[":
            # Attribute: read to its closing bracket.
            j, d, words = i + 1, 0, []
            while j < len(toks):
                if toks[j][1] == "[":
                    d += 1
                elif toks[j][1] == "]":
                    d -= 1
                    if d == 0:
                        break
                elif toks[j][0] == "ident":
                    words.append(toks[j][1])
                j += 1
            if words in (["cfg", "test"], ["test"]):
                pending_test = True
            i = j
        elif v == "{":
            depth += 1
        elif v == "}":
            if open_fns and open_fns[-1][2] == depth:
                name, start, _, exempt = open_fns.pop()
                if skip_until is None:
                    yield name, start, line, exempt
            depth -= 1
            if skip_until is not None and depth == skip_until:
                skip_until = None
        elif v in ("mod", "fn") and kind == "ident":
            is_fn = v == "fn"
            name = toks[i + 1][1] if i + 1 < len(toks) else "?"
            # Find the body's `{` or a `;` (declaration) at this nesting.
            j, paren = i + 1, 0
            while j < len(toks):
                t = toks[j][1]
                if t in "([":
                    paren += 1
                elif t in ")]":
                    paren -= 1
                elif paren == 0 and t in ("{", ";"):
                    break
                j += 1
            if j < len(toks) and toks[j][1] == "{":
                if pending_test and skip_until is None:
                    skip_until = depth
                if is_fn:
                    exempt = any(
                        EXEMPT in last_comment_line.get(k, "")
                        for k in range(max(1, line - 40), line)
                    ) and _marker_adjacent(text, line)
                    open_fns.append((name, line, depth + 1, exempt))
                depth += 1
                i = j
            pending_test = False
        elif kind == "ident" and v in ("struct", "enum", "impl", "trait", "const", "static", "use"):
            pending_test = False
        i += 1


def _marker_adjacent(text, fn_line):
    """True if the exemption marker stands in the run of comment and attribute lines directly
    above line `fn_line`."""
    lines = text.splitlines()
    k = fn_line - 2
    while k >= 0:
        s = lines[k].strip()
        if EXEMPT in s:
            return True
        if s.startswith("//") or s.startswith("#[") or s.startswith("#!["):
            k -= 1
            continue
        return False
    return False


SELF_TEST = r"""
fn short() {
    let s = "{ not a brace }";
    let r = r#"}}}"#;
    let c = '{';
    let l: &'static str = "x";
    // }
    /* { /* nested } */ */
}

// fn-length: data literal
#[rustfmt::skip]
fn table() -> [u8; 2] {
    [1, 2]
}

trait T { fn declared(&self); fn provided(&self) { } }

#[cfg(test)]
mod tests {
    fn helper() {
    }
    #[test]
    fn case() {}
}

fn outer() {
    fn inner() {
    }
}
"""


def self_test():
    """The scanner on a fixture whose answer is known (each function's span by hand)."""
    got = sorted(functions(SELF_TEST))
    want = sorted([("short", 2, 9, False), ("table", 13, 15, True), ("provided", 17, 17, False),
                   ("outer", 27, 30, False), ("inner", 28, 29, False)])
    if got != want:
        print(f"self-test FAILED:\n  got  {got}\n  want {want}", file=sys.stderr)
        return 1
    print("self-test ok")
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root", nargs="?", default=".")
    ap.add_argument("--self-test", action="store_true", help="check the scanner on a fixture")
    ap.add_argument("--limit", type=int, default=150)
    ap.add_argument("--top", type=int, default=0)
    a = ap.parse_args()
    if a.self_test:
        return self_test()
    root = pathlib.Path(a.root)
    found = []
    for path in sorted(root.glob("crates/*/src/**/*.rs")):
        text = path.read_text(encoding="utf-8")
        for name, start, end, exempt in functions(text):
            found.append((end - start + 1, str(path.relative_to(root)), start, name, exempt))
    found.sort(reverse=True)
    for length, path, start, name, exempt in found[: a.top]:
        note = " (data literal, exempt)" if exempt else ""
        print(f"{length:5} {path}:{start} {name}{note}")
    over = [f for f in found if f[0] > a.limit and not f[4]]
    if over:
        print(f"{len(over)} function(s) over {a.limit} lines:", file=sys.stderr)
        for length, path, start, name, _ in over:
            print(f"  {path}:{start} fn {name}: {length} lines", file=sys.stderr)
        return 1
    counted = [f for f in found if not f[4]]
    longest = f"longest {counted[0][0]} lines, {counted[0][1]}:{counted[0][2]}" if counted else "none"
    print(f"ok: {len(found)} functions, none over {a.limit} lines outside data literals "
          f"({longest})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
