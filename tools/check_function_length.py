#!/usr/bin/env python3
"""Lists functions longer than a limit in the project's C++ (.cc and .h outside tests/), counted
from the signature's first line to the closing brace, and fails when one is not a named exception.

A named exception is a hot-path function that a benchmark shows cannot be split without cost: the
line right above its signature (or its first body line) is a comment starting `// long:` that says
why. Usage: tools/check_function_length.py [--limit 80] [--list N] [--report]
"""
import argparse
import re
import subprocess
import sys
from pathlib import Path

CONTROL = re.compile(r"\b(if|for|while|switch|catch|do|else)\b\s*(\(|$|\{)")
SCOPE = re.compile(r"\b(namespace|class|struct|union|enum)\b")


def strip_code(text):
    """The text with comments, strings and character literals blanked (newlines kept)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            k = text.find("(", i)
            delim = ")" + text[i + 2:k] + '"'
            j = text.find(delim, k)
            j = n if j < 0 else j + len(delim)
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum():
                out.append(c)  # a digit separator (1'000)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + " " * (j - i - 2) + c if j - i >= 2 else text[i:j])
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(path):
    """(name, first line, last line) of each outermost function body in the file."""
    raw = path.read_text(encoding="utf-8")
    code = strip_code(raw)
    lines_raw = raw.split("\n")
    result = []
    stack = []  # per open brace: 'scope' or 'body' or 'other'
    start = 0  # index after the last ; { } at the current level
    for i, c in enumerate(code):
        if c == "{":
            head = code[start:i]
            in_body = any(entry[0] == "body" for entry in stack)
            kind = "other"
            if not in_body:
                compact = " ".join(head.split())
                if SCOPE.search(compact) and ")" not in compact.split(SCOPE.search(compact).group(0))[-1][:1]:
                    kind = "scope" if not compact.rstrip().endswith(")") or "namespace" in compact else "scope"
                    if re.search(r"\)\s*(const|noexcept|override|final|->[^{]*|mutable|\s)*$", compact) and not re.match(r"^(template\s*<.*>\s*)?(class|struct|union|enum|namespace)\b", compact.strip()):
                        kind = "body"
                elif ")" in compact and not CONTROL.search(compact) and not compact.rstrip().endswith("="):
                    if re.search(r"\)\s*(const|noexcept(\([^)]*\))?|override|final|mutable|->\s*[\w:<>,\s&*]+|\s|:\s*.*)*$", compact) or ") :" in compact or "):" in compact:
                        kind = "body"
                elif compact.endswith("extern \"C\"") or compact.startswith("extern"):
                    kind = "scope"
            if kind == "body":
                first = code.count("\n", 0, start) + 1
                # skip blank lines and leading whitespace before the signature
                while first <= len(lines_raw) and not code.split("\n")[first - 1].strip():
                    first += 1
                stack.append(("body", first, head))
            else:
                stack.append((kind, None, None))
            start = i + 1
        elif c == "}":
            if stack:
                kind, first, head = stack.pop()
                if kind == "body":
                    last = code.count("\n", 0, i) + 1
                    name = re.findall(r"([~\w:]+(?:operator\W+)?)\s*\(", head)
                    result.append((name[0] if name else "?", first, last))
            start = i + 1
        elif c == ";":
            start = i + 1
    return result, lines_raw


def is_exception(lines, first):
    for idx in (first - 2, first - 1, first):
        if 0 <= idx < len(lines) and lines[idx].strip().startswith("// long:"):
            return True
    # a signature over several lines: look at the first body line
    return False


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--limit", type=int, default=80)
    ap.add_argument("--list", type=int, default=0, help="print the N longest functions")
    args = ap.parse_args()
    root = Path(__file__).resolve().parent.parent
    files = subprocess.run(["git", "ls-files", "*.cc", "*.h"], cwd=root, capture_output=True,
                           text=True, check=True).stdout.split()
    files = [f for f in files if "/tests/" not in f and not f.startswith("tests/")]
    found = []
    for f in files:
        funcs, lines = functions(root / f)
        for name, first, last in funcs:
            length = last - first + 1
            found.append((length, f, first, name, is_exception(lines, first)))
    found.sort(reverse=True)
    for length, f, first, name, exc in found[: args.list]:
        print(f"{length:5d}  {f}:{first}  {name}{'  (named exception)' if exc else ''}")
    over = [x for x in found if x[0] > args.limit and not x[4]]
    if over:
        for length, f, first, name, _ in over:
            print(f"{f}:{first}: {name} is {length} lines (limit {args.limit})", file=sys.stderr)
        print(f"check_function_length: {len(over)} functions over {args.limit} lines", file=sys.stderr)
        return 1
    print(f"check_function_length: no function over {args.limit} lines in {len(files)} files "
          f"({sum(1 for x in found if x[4])} named exceptions)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
