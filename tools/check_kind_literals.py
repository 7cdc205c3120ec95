#!/usr/bin/env python3
"""Fails when the name of an event, fault or expectation kind is written as a string literal
outside the one table that maps the kinds to their names (sim/core/vocabulary.h), so that code
compares the typed kinds (EventKind::kGrant; in the report's JavaScript, EVENT.GRANT from the table
generated at build time) and a typo cannot compile or pass. Reads the C++ and JavaScript sources;
tests are left out (they check the files' text), and so are Python scripts, which read
events.jsonl as the file format it is. A key spelt like a kind (a config key in a Describe,
`v("collision", ...)`; a JSON key, `j["lap"]`, `j.value("lap", ...)`) is not a kind; any other
literal that is not one says so with the comment `not a kind` on its line.
"""
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TABLE = "sim/core/vocabulary.h"


def kind_names():
    text = (ROOT / TABLE).read_text(encoding="utf-8")
    names = set(re.findall(r'\{K::k\w+, "(\w+)"\}', text))
    if len(names) < 40:  # 20 events, 11 faults, 12 expectations
        sys.exit(f"check_kind_literals: found only {len(names)} kind names in {TABLE}")
    return names


def main():
    names = kind_names()
    files = subprocess.run(["git", "ls-files", "*.cc", "*.h", "*.js"], cwd=ROOT,
                           capture_output=True, text=True, check=True).stdout.split()
    literal = re.compile(r'(?<!\bv\()(?<!\[)(?<!\.value\()(?<!\.contains\()"(\w+)"|\'(\w+)\'')
    found = []
    for f in files:
        if f == TABLE or "/tests/" in f or "/vendor/" in f or "/fuzz/" in f or f.startswith("tools/check_"):
            continue
        for number, line in enumerate((ROOT / f).read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("//")[0]
            if "not a kind" in line:
                continue
            for match in literal.finditer(code):
                name = match.group(1) or match.group(2)
                if name in names:
                    found.append(f"{f}:{number}: the kind '{name}' as a string: {line.strip()}")
    for line in found:
        print(line, file=sys.stderr)
    if found:
        print(f"check_kind_literals: {len(found)} kind name(s) written outside {TABLE}; use the "
              "typed kind (EventKind::..., FaultKind::..., ExpectKind::...; EVENT./FAULT. in "
              "the report's JavaScript)", file=sys.stderr)
        return 1
    print(f"check_kind_literals: the {len(names)} kind names appear only in {TABLE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
