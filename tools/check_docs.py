#!/usr/bin/env python3
"""Checks that the documentation's links lead somewhere. Standard library only.

(a) Every relative link and image in README.md, CONTRIBUTING.md, CHANGELOG.md and docs/**/*.md
    (inline `[text](target)`, `![alt](target)`, reference definitions `[ref]: target`, and HTML
    `href=`/`src=`) names a file or folder that exists; where the target is a Markdown page and the
    link has a `#anchor`, the page has a heading with that anchor. Links into the web (`http:`,
    `https:`, `mailto:`) are not followed.
(b) Every pointer into the handbook written anywhere else in the tree (code comments, tests,
    scripts, YAML: any file git tracks or would track), in the form docs/<page>.md or
    docs/<page>.md#<anchor> (also docs/studies/<page>.md#<anchor>), names a page that exists and,
    with an anchor, a heading of that page.

Anchors follow GitHub's rule: a heading's text without its Markdown (code spans, emphasis, links),
lowercased, every character dropped that is not a letter, digit, space, `-` or `_`, spaces turned
into `-`; a second heading with the same anchor gets `-1`, a third `-2`, and so on.

Prints each broken link as `file:line: link: why` and exits 1; otherwise prints one line with the
counts and exits 0. Usage: tools/check_docs.py (from anywhere inside the repository).
"""
import re
import subprocess
import sys
import urllib.parse
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGES = ["README.md", "CONTRIBUTING.md", "CHANGELOG.md"]

FENCE = re.compile(r"^ {0,3}(```|~~~)")
HEADING = re.compile(r"^ {0,3}(#{1,6})[ \t]+(.*?)[ \t]*#*[ \t]*$")
CODE_SPAN = re.compile(r"(`+)((?:(?!\n[ \t]*\n).)+?)\1", re.S)  # not across paragraphs
INLINE_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]*)>?(?:\s+[\"'(][^)]*)?\)")
REFERENCE_DEF = re.compile(r"^ {0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s.*)?$")
HTML_ATTR = re.compile(r"""\b(?:href|src)\s*=\s*["']([^"']+)["']""")
HTML_ID = re.compile(r"""<a\s[^>]*\b(?:name|id)\s*=\s*["']([^"']+)["']""")
# docs/<page>.md, optionally #anchor, not as the tail of a longer path (build/docs/..., x.docs/...)
POINTER = re.compile(r"(?<![\w./-])(docs/[\w./-]*?\.md)(#[\w-]+)?")
EXTERNAL = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def slug(heading):
    """The anchor GitHub gives a heading's text (before de-duplication)."""
    text = CODE_SPAN.sub(lambda m: m.group(2), heading)
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # links and images: their text
    text = re.sub(r"<[^>]+>", "", text)  # HTML tags
    text = text.replace("*", "").strip().lower()
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


def markdown_lines(path):
    """(line number, text) of a Markdown file's lines outside fenced code blocks."""
    fenced = None
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        match = FENCE.match(line)
        if match:
            if fenced is None:
                fenced = match.group(1)
            elif match.group(1) == fenced:
                fenced = None
            continue
        if fenced is None:
            yield number, line


ANCHOR_CACHE = {}


def anchors(path):
    """The set of anchors a Markdown page's headings (and explicit <a id/name>) define."""
    if path not in ANCHOR_CACHE:
        found, seen = set(), {}
        for _, line in markdown_lines(path):
            found.update(HTML_ID.findall(line))
            match = HEADING.match(line)
            if not match:
                continue
            base = slug(match.group(2))
            count = seen.get(base, 0)
            seen[base] = count + 1
            found.add(base if count == 0 else f"{base}-{count}")
        ANCHOR_CACHE[path] = found
    return ANCHOR_CACHE[path]


def check_target(target, anchor, source):
    """Why the link from `source` to `target`#`anchor` is broken, or None. `target` is a path
    already resolved against the repository; an empty anchor means none."""
    if not target.exists():
        return "no such file"
    try:
        target.relative_to(ROOT)
    except ValueError:
        return "leads outside the repository"
    if anchor and target.is_file() and target.suffix == ".md":
        if anchor not in anchors(target):
            return f"no heading with anchor #{anchor} in {target.relative_to(ROOT)}"
    return None


def page_links(path):
    """(line, link) of every link and image in a Markdown page, outside code. A link's text may
    run over several lines; the line reported is the one its target is on."""
    lines = dict(markdown_lines(path))
    count = max(lines, default=0)
    text = "\n".join(lines.get(n, "") for n in range(1, count + 1))
    text = CODE_SPAN.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)
    for pattern in (INLINE_LINK, HTML_ATTR):
        for match in pattern.finditer(text):
            yield text.count("\n", 0, match.start(1)) + 1, match.group(1)
    for number, line in enumerate(text.split("\n"), 1):
        match = REFERENCE_DEF.match(line)
        if match:
            yield number, match.group(1)


def check_pages(pages):
    broken, count = [], 0
    for page in pages:
        for number, link in page_links(page):
            if not link or EXTERNAL.match(link):
                continue
            count += 1
            path_part, _, anchor = link.partition("#")
            path_part = urllib.parse.unquote(path_part)
            if not path_part:
                target = page
            elif path_part.startswith("/"):
                target = ROOT / path_part.lstrip("/")
            else:
                target = (page.parent / path_part).resolve()
            why = check_target(target, anchor, page)
            if why:
                broken.append((page.relative_to(ROOT), number, link, why))
    return broken, count


def tracked_files():
    try:
        out = subprocess.run(
            ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
            cwd=ROOT, check=True, capture_output=True).stdout
        names = sorted({n for n in out.decode().split("\0") if n})
    except (OSError, subprocess.CalledProcessError):
        names = [str(p.relative_to(ROOT)) for p in ROOT.rglob("*")
                 if p.is_file() and ".git" not in p.parts and "build" not in p.parts[:1]]
    return [ROOT / n for n in names]


def check_pointers(files):
    broken, count = [], 0
    for path in files:
        if not path.is_file() or path.stat().st_size > 4_000_000:
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue  # binary files (images, data)
        if "docs/" not in text:
            continue
        for number, line in enumerate(text.splitlines(), 1):
            for page, anchor in POINTER.findall(line):
                count += 1
                why = check_target(ROOT / page, anchor.lstrip("#"), path)
                if why:
                    broken.append((path.relative_to(ROOT), number, page + anchor, why))
    return broken, count


def main():
    docs = ROOT / "docs"
    pages = [ROOT / p for p in PAGES if (ROOT / p).is_file()]
    pages += sorted(docs.rglob("*.md")) if docs.is_dir() else []
    page_broken, page_count = check_pages(pages)
    pointer_broken, pointer_count = check_pointers(tracked_files())
    broken, seen = [], set()
    for item in page_broken + pointer_broken:
        if item[:3] not in seen:  # a page's link can also read as a pointer: report it once
            seen.add(item[:3])
            broken.append(item)
    for file, number, link, why in broken:
        print(f"{file}:{number}: {link}: {why}")
    if broken:
        print(f"check_docs: {len(broken)} broken link(s)", file=sys.stderr)
        return 1
    print(f"check_docs: {page_count} links in {len(pages)} pages and {pointer_count} pointers "
          f"into docs/ elsewhere resolve")
    return 0


if __name__ == "__main__":
    sys.exit(main())
