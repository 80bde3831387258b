#!/usr/bin/env python3
"""Lists the function bodies longer than a limit (default 150 lines) in the project's C++ sources.

A body is a brace block opened at namespace or class level after a closing parenthesis (a
function or lambda at file scope); its length counts the lines from the signature's line to the
closing brace. Comments, strings and character literals are skipped. Declarative tables (a brace
block opened after '=') are not functions and are not counted.

  python3 scripts/long_functions.py [--limit N] [--budget FILE] [DIR ...]
      exit 1 when any function is longer, except those FILE lists, each at most as long as listed

The test command runs it with --budget scripts/long_functions.budget: the functions over the limit
today, each with its length then. A new long function, or a listed one grown, fails the test; one
that shrinks or is split is taken off the list (or given its new length) by hand.
"""
import argparse
import pathlib
import re
import sys

ROOTS = ["core", "harness", "algorithms", "scanner-sim", "metrics", "bench"]


def strip(text):
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            seg = text[i : (n if j < 0 else j + 2)]
            out.append("\n" * seg.count("\n"))
            i = n if j < 0 else j + 2
        elif text.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i) if m else -1
            seg = text[i : (n if end < 0 else end + len(m.group(1)) + 2)]
            out.append('""' + "\n" * seg.count("\n"))
            i = n if end < 0 else end + len(m.group(1)) + 2
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(c + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(path):
    text = strip(path.read_text(errors="replace"))
    stack = []  # (kind, start_line, name)
    line = 1
    last = []  # significant text since the last ; { or }
    found = []
    for c in text:
        if c == "\n":
            line += 1
        if c == "{":
            head = "".join(last).strip()
            in_function = any(k == "fn" for k, _, _ in stack)
            if in_function:
                kind = "block"
            elif head.endswith("=") or head.endswith("= "):
                kind = "table"
            elif re.search(r"\)\s*(const|noexcept|override|final|mutable|->[^{]*|:[^{]*|\s)*$", head) and not re.match(
                r"^\s*(namespace|struct|class|union|enum)\b", head
            ):
                kind = "fn"
            else:
                kind = "scope"
            start = line - "".join(last).rstrip().count("\n") if kind == "fn" else line
            name = ""
            if kind == "fn":
                m = re.search(r"([\w:~<>]+)\s*\([^()]*(\([^()]*\)[^()]*)*\)[^()]*$", head)
                name = m.group(1) if m else head[-60:]
            stack.append((kind, start, name))
            last = []
        elif c == "}":
            if stack:
                kind, start, name = stack.pop()
                if kind == "fn":
                    found.append((name, start, line))
            last = []
        elif c == ";":
            last = []
        else:
            last.append(c)
    return found


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--limit", type=int, default=150)
    ap.add_argument("--budget", help="file of 'LENGTH PATH NAME' lines: allowed long functions")
    ap.add_argument("dirs", nargs="*")
    args = ap.parse_args()
    budget = {}
    if args.budget:
        for ln in pathlib.Path(args.budget).read_text().splitlines():
            ln = ln.split("#", 1)[0].strip()
            if ln:
                n, path, name = ln.split()
                budget[(path, name)] = int(n)
    root = pathlib.Path(__file__).resolve().parent.parent
    dirs = [pathlib.Path(d) for d in args.dirs] or [root / r for r in ROOTS]
    long = []
    for d in dirs:
        for p in sorted(d.rglob("*")):
            if p.suffix in (".cpp", ".h", ".hpp", ".cc") and p.is_file():
                for name, a, b in functions(p):
                    if b - a + 1 > args.limit:
                        long.append((b - a + 1, p.relative_to(root) if p.is_relative_to(root) else p, a, name))
    bad = []
    for n, p, a, name in sorted(long, reverse=True):
        allowed = budget.get((str(p), name))
        note = "" if allowed is None else (f"  (budget {allowed})" if n <= allowed else f"  (OVER its budget {allowed})")
        print(f"{n:5d}  {p}:{a}  {name}{note}")
        if allowed is None or n > allowed:
            bad.append(name)
    print(f"{len(long)} functions over {args.limit} lines, {len(bad)} of them not within a budget")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
