#!/usr/bin/env python3
"""Every relative link and image in README.md and docs/*.md must resolve.

Usage: check_links.py [REPO_ROOT]          (default: two levels above this file)

Checks, outside fenced code blocks and inline code:
  - [text](path) and ![alt](path): the file or directory exists, relative to the page;
  - path#anchor and #anchor into a Markdown page: the page has a heading with that anchor,
    computed as GitHub does (lower case, punctuation dropped, spaces to hyphens, -1, -2 …
    for repeated headings);
  - no link or image points outside the repository.
External links (http:, https:, mailto:) are not fetched. Exit status 1 lists the failures.
"""
import os
import re
import sys

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
IMG_TAG = re.compile(r"<img\s[^>]*src=\"([^\"]+)\"", re.I)
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
FENCE = re.compile(r"^\s*(```|~~~)")
INLINE_CODE = re.compile(r"`[^`]*`")


def prose_lines(path):
    """(line number, text) of the lines outside fenced code blocks."""
    inside = False
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if FENCE.match(line):
                inside = not inside
                continue
            if not inside:
                yield number, line.rstrip("\n")


def slug(text):
    """GitHub's anchor for a heading's text."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link renders as its text
    text = text.replace("`", "").replace("*", "")
    text = re.sub(r"<[^>]+>", "", text).strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


_anchors = {}


def anchors(path):
    if path not in _anchors:
        seen = {}
        found = set()
        for _, line in prose_lines(path):
            m = HEADING.match(line)
            if not m:
                continue
            base = slug(m.group(2))
            n = seen.get(base, 0)
            seen[base] = n + 1
            found.add(base if n == 0 else f"{base}-{n}")
        _anchors[path] = found
    return _anchors[path]


def check_page(page, root):
    failures = []
    here = os.path.dirname(page)
    for number, line in prose_lines(page):
        targets = [m.group(1) for m in LINK.finditer(INLINE_CODE.sub("", line))]
        targets += IMG_TAG.findall(line)
        for target in targets:
            if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):  # http:, https:, mailto:, …
                continue
            where = f"{os.path.relpath(page, root)}:{number}: {target}"
            path, _, anchor = target.partition("#")
            resolved = os.path.normpath(os.path.join(here, path)) if path else page
            if os.path.isabs(path) or os.path.relpath(resolved, root).startswith(os.pardir):
                failures.append(f"{where}: points outside the repository")
                continue
            if not os.path.exists(resolved):
                failures.append(f"{where}: no such file")
                continue
            if anchor and resolved.endswith(".md") and anchor.lower() not in anchors(resolved):
                failures.append(f"{where}: no heading with anchor #{anchor} in {os.path.relpath(resolved, root)}")
    return failures


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))
    pages = [os.path.join(root, "README.md")]
    docs = os.path.join(root, "docs")
    pages += sorted(os.path.join(docs, f) for f in os.listdir(docs) if f.endswith(".md"))
    failures = []
    links = 0
    for page in pages:
        failures += check_page(page, root)
        links += sum(len(LINK.findall(INLINE_CODE.sub("", l))) for _, l in prose_lines(page))
    for f in failures:
        print(f)
    print(f"checked {links} links in {len(pages)} pages: {len(failures)} broken")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
