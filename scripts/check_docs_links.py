#!/usr/bin/env python3
"""Checks the user-facing documentation (README.md and docs/**/*.md).

- Every relative link or image, [text](target) or ![alt](target), points to an
  existing file or folder (resolved from the linking file's folder); a
  #fragment into a Markdown file must name one of its headings (GitHub's
  anchors). Links to http(s)://, mailto: and the like are not checked; links
  inside code spans and fenced code blocks are not links.
- README.md has at most 250 lines.
- README.md still gives the two set-up commands, and .ci/run and
  scripts/test.sh still are what the test command runs.

Usage: /usr/bin/python3 scripts/check_docs_links.py [-v]
Exit code 0 when everything holds, 1 otherwise (each problem printed).
"""
import os
import re
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
README_MAX_LINES = 250
DEMO_CMD = "bash scripts/demo.sh"
TEST_CMD = "bash scripts/test.sh"

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^\s*(```|~~~)")
SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def doc_files():
    files = [os.path.join(ROOT, "README.md")]
    for d, _, names in os.walk(os.path.join(ROOT, "docs")):
        files += [os.path.join(d, n) for n in sorted(names) if n.endswith(".md")]
    return files


def prose_lines(text):
    """(line number, line) outside fenced code blocks, with code spans blanked."""
    in_fence = False
    for no, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            in_fence = not in_fence
            continue
        if not in_fence:
            yield no, re.sub(r"`[^`]*`", lambda m: " " * len(m.group(0)), line)


def slug(heading):
    """GitHub's anchor of a heading."""
    s = heading.strip().lower()
    s = re.sub(r"[`*_~]", "", s)
    s = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", s)
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        seen, out = {}, set()
        text = open(path, encoding="utf-8").read()
        in_fence = False
        for line in text.splitlines():
            if FENCE.match(line):
                in_fence = not in_fence
                continue
            m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
            if m and not in_fence:
                base = slug(m.group(1))
                n = seen.get(base, 0)
                seen[base] = n + 1
                out.add(base if n == 0 else f"{base}-{n}")
        cache[path] = out
    return cache[path]


def check_links(verbose):
    problems, count = [], 0
    for f in doc_files():
        text = open(f, encoding="utf-8").read()
        rel = os.path.relpath(f, ROOT)
        for no, line in prose_lines(text):
            for m in LINK.finditer(line):
                target = m.group(1)
                if SCHEME.match(target):
                    continue
                count += 1
                path, _, frag = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(f), path)) if path else f
                if not os.path.exists(dest):
                    problems.append(f"{rel}:{no}: link target does not exist: {target}")
                    continue
                if frag and dest.endswith(".md") and frag not in anchors(dest):
                    problems.append(f"{rel}:{no}: no heading #{frag} in {os.path.relpath(dest, ROOT)}")
                elif verbose:
                    print(f"ok {rel}:{no}: {target}")
    return problems, count


def check_readme_and_commands():
    problems = []
    readme = open(os.path.join(ROOT, "README.md"), encoding="utf-8").read()
    n = len(readme.splitlines())
    if n > README_MAX_LINES:
        problems.append(f"README.md: {n} lines (at most {README_MAX_LINES})")
    code = "\n".join(re.findall(r"```[^\n]*\n(.*?)```", readme, re.S))
    for cmd in (DEMO_CMD, TEST_CMD):
        if not re.search(rf"^{re.escape(cmd)}\s*$", code, re.M):
            problems.append(f"README.md: the set-up command `{cmd}` is not in a code block")
    ci = open(os.path.join(ROOT, ".ci", "run"), encoding="utf-8").read()
    if not re.search(rf"^(exec\s+)?{re.escape(TEST_CMD)}\s*$", ci, re.M):
        problems.append(f".ci/run: does not run `{TEST_CMD}` (the README's test command)")
    test = open(os.path.join(ROOT, "scripts", "test.sh"), encoding="utf-8").read()
    if "scripts/setup.sh" not in test or "ctest" not in test:
        problems.append("scripts/test.sh: no longer runs scripts/setup.sh and ctest (the README says it does)")
    demo = open(os.path.join(ROOT, "scripts", "demo.sh"), encoding="utf-8").read()
    if "scripts/setup.sh" not in demo:
        problems.append("scripts/demo.sh: no longer runs scripts/setup.sh (the README says it does)")
    return problems, n


def main():
    verbose = "-v" in sys.argv[1:]
    link_problems, count = check_links(verbose)
    other, n = check_readme_and_commands()
    problems = link_problems + other
    for p in problems:
        print(p)
    print(f"check_docs_links: {len(doc_files())} files, {count} relative links, README {n} lines, "
          f"{len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
