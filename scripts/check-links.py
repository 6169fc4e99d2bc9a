#!/usr/bin/env python3
"""Checks the relative links and images of every Markdown file in the repository.

    scripts/check-links.py            # from anywhere; exit 1 when a link is broken

A link `[text](path)` or image `![alt](path)` must name an existing file or directory
relative to the Markdown file; `path#anchor` must also name a heading of that file (GitHub's
anchors: lower case, punctuation removed, spaces as hyphens, `-1`, `-2`… for repeats).
Links with a scheme (https:, mailto:) are not checked.
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SKIP_DIRS = {".git", "target", "node_modules", ".venv", "corpus", "artifacts"}
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^\s*(```|~~~)")


def markdown_files():
    for dirpath, dirnames, filenames in os.walk(ROOT):
        dirnames[:] = [d for d in dirnames if d not in SKIP_DIRS and not d.startswith(".venv")]
        for f in filenames:
            if f.endswith(".md"):
                yield os.path.join(dirpath, f)


def slug(heading):
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s, flags=re.UNICODE)
    return s.replace(" ", "-")


def anchors(path):
    """The anchors of a Markdown file's headings (outside code blocks)."""
    seen, found = {}, set()
    with open(path, encoding="utf-8") as f:
        inside = False
        for line in f:
            if FENCE.match(line):
                inside = not inside
                continue
            if inside:
                continue
            m = re.match(r"^(#{1,6})\s+(.*?)\s*#*\s*$", line.rstrip("\n"))
            if m:
                base = slug(m.group(2))
                n = seen.get(base, 0)
                seen[base] = n + 1
                found.add(base if n == 0 else f"{base}-{n}")
    return found


def main():
    broken = 0
    checked = 0
    for md in sorted(markdown_files()):
        with open(md, encoding="utf-8") as f:
            text = f.read()
        inside = False
        for number, line in enumerate(text.splitlines(), 1):
            if FENCE.match(line):
                inside = not inside
                continue
            if inside:
                continue
            for target in LINK.findall(line):
                if re.match(r"^[a-z][a-z0-9+.-]*:", target):
                    continue
                checked += 1
                path, _, anchor = target.partition("#")
                full = os.path.normpath(os.path.join(os.path.dirname(md), path)) if path else md
                where = f"{os.path.relpath(md, ROOT)}:{number}"
                if not os.path.exists(full):
                    print(f"{where}: {target}: no such file")
                    broken += 1
                elif anchor and full.endswith(".md") and anchor not in anchors(full):
                    print(f"{where}: {target}: no heading with anchor #{anchor}")
                    broken += 1
    print(f"{checked} relative links checked, {broken} broken", file=sys.stderr)
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
