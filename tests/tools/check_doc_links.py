#!/usr/bin/env python3
"""Every relative link in README.md, docs/*.md and models/README.md leads
somewhere: the file (or folder) exists, and an anchor (#name) is a heading of
the file it points into, by GitHub's rule for heading anchors (lower case,
punctuation other than '-' and '_' dropped, spaces to '-'). So a document
moved or a heading renamed without its links fails here.

usage: check_doc_links.py SOURCE_DIR"""
import os
import re
import sys

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^\s*(```|~~~)")


def anchors(path):
    """The anchors GitHub makes for the headings of a Markdown file."""
    seen, out = {}, set()
    fenced = False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if FENCE.match(line):
                fenced = not fenced
                continue
            m = re.match(r"^(#{1,6})\s+(.*?)\s*#*\s*$", line)
            if fenced or not m:
                continue
            slug = re.sub(r"[^\w\- ]", "", m.group(2).strip().lower()).replace(" ", "-")
            n = seen.get(slug, 0)
            seen[slug] = n + 1
            out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def links(path):
    fenced = False
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if FENCE.match(line):
                fenced = not fenced
                continue
            if fenced:
                continue
            # inline code spans are not links
            for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
                yield number, target


def main():
    src = sys.argv[1]
    docs = [os.path.join(src, "README.md"), os.path.join(src, "models", "README.md")]
    docs += sorted(os.path.join(src, "docs", n) for n in os.listdir(os.path.join(src, "docs")) if n.endswith(".md"))
    failures = checks = 0
    for doc in docs:
        for number, target in links(doc):
            if re.match(r"^[a-z]+:", target):  # http:, https:, mailto:
                continue
            checks += 1
            name, _, anchor = target.partition("#")
            dest = os.path.normpath(os.path.join(os.path.dirname(doc), name)) if name else doc
            where = f"{os.path.relpath(doc, src)}:{number}: {target}"
            if not os.path.exists(dest):
                print(f"FAIL: {where}: no such file", file=sys.stderr)
                failures += 1
            elif anchor and (not dest.endswith(".md") or anchor not in anchors(dest)):
                print(f"FAIL: {where}: no heading with that anchor", file=sys.stderr)
                failures += 1
    print(f"{checks} links checked, {failures} broken")
    return 1 if failures or checks == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
