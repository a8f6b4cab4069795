#!/usr/bin/env python3
"""Keeps docs/guide.md's code true: every C++, C or Python block in it must be an excerpt of a
file that is built and tested, named by a line `<!-- excerpt: PATH -->` (PATH from the source
root) just before the block's fence. The block's lines must appear in that file in the same
order and next to each other, compared without their leading and trailing blanks and skipping
empty lines; a line that is only `// ...`, `/* ... */` or `# ...` stands for lines left out
(the pieces either side of it must still come in order).

   guide_excerpts.py SOURCE_DIR     check SOURCE_DIR/docs/guide.md: exit 0 with a count, or 1
                                    naming each block that is not in its file
   guide_excerpts.py --selftest     the checker on made-up guides: a true excerpt passes, an
                                    edited one, a missing marker and a missing file fail"""
import os
import re
import sys

MARKER = re.compile(r"^\s*<!--\s*excerpt:\s*(\S+)\s*-->\s*$")
FENCE = re.compile(r"^\s*```(\w*)\s*$")
ELISION = {"// ...", "/* ... */", "# ..."}
CHECKED_LANGUAGES = {"cpp", "c", "python"}


def blocks(guide_text):
    """(line number, language, excerpt path or None, code lines) for each fenced block."""
    lines = guide_text.split("\n")
    found, i, marker = [], 0, None
    while i < len(lines):
        m = MARKER.match(lines[i])
        if m:
            marker = (m.group(1), i + 1)
            i += 1
            continue
        f = FENCE.match(lines[i])
        if f:
            start, language, code = i + 1, f.group(1), []
            i += 1
            while i < len(lines) and not FENCE.match(lines[i]):
                code.append(lines[i])
                i += 1
            # A marker belongs to the block right after it (only empty lines between).
            path = marker[0] if marker and all(not l.strip() for l in lines[marker[1]:start - 1]) else None
            found.append((start, language, path, code))
            marker = None
        i += 1
    return found


def pieces(code):
    """The block's non-empty stripped lines, split at elision lines."""
    out, current = [], []
    for line in code:
        s = line.strip()
        if not s:
            continue
        if s in ELISION:
            if current:
                out.append(current)
            current = []
            continue
        current.append(s)
    if current:
        out.append(current)
    return out


def find_in_order(source_lines, parts):
    """Index of the first piece that is not found after the previous one, or None if all are."""
    at = 0
    for n, part in enumerate(parts):
        k = len(part)
        hit = next((j for j in range(at, len(source_lines) - k + 1) if source_lines[j:j + k] == part), None)
        if hit is None:
            return n
        at = hit + k
    return None


def check(guide_text, read_source):
    """Problems (one line each) and how many excerpts were checked. read_source(path) returns the
    file's text or None."""
    problems, checked = [], 0
    for line, language, path, code in blocks(guide_text):
        if path is None:
            if language in CHECKED_LANGUAGES:
                problems.append(f"guide.md:{line}: a {language} block with no <!-- excerpt: FILE --> line before it")
            continue
        text = read_source(path)
        if text is None:
            problems.append(f"guide.md:{line}: excerpt of {path}, which does not exist")
            continue
        source = [s.strip() for s in text.split("\n") if s.strip()]
        parts = pieces(code)
        if not parts:
            problems.append(f"guide.md:{line}: an empty excerpt of {path}")
            continue
        missing = find_in_order(source, parts)
        if missing is not None:
            problems.append(f"guide.md:{line}: not in {path} (in order), from the line {parts[missing][0]!r}")
            continue
        checked += 1
    if checked == 0 and not problems:
        problems.append("guide.md has no excerpts to check")
    return problems, checked


def selftest():
    source = {"ex/a.cpp": "int main() {\n    int x = 1;\n    x += 2;\n\n    return x;\n}\n"}
    read = source.get
    cases = [
        ("a true excerpt", "<!-- excerpt: ex/a.cpp -->\n```cpp\n  int x = 1;\n  x += 2;\n```\n", True),
        ("elided lines", "<!-- excerpt: ex/a.cpp -->\n```cpp\nint main() {\n// ...\nreturn x;\n```\n", True),
        ("an edited line", "<!-- excerpt: ex/a.cpp -->\n```cpp\nint x = 2;\n```\n", False),
        ("pieces out of order", "<!-- excerpt: ex/a.cpp -->\n```cpp\nreturn x;\n// ...\nint x = 1;\n```\n", False),
        ("lines not next to each other", "<!-- excerpt: ex/a.cpp -->\n```cpp\nint main() {\nx += 2;\n```\n", False),
        ("no marker", "```cpp\nint x = 1;\n```\n", False),
        ("a marker two blocks back", "<!-- excerpt: ex/a.cpp -->\n```sh\nls\n```\n```cpp\nint x = 1;\n```\n", False),
        ("a missing file", "<!-- excerpt: ex/b.cpp -->\n```cpp\nint x = 1;\n```\n", False),
        ("nothing to check", "```sh\nls\n```\n", False),
        ("a shell block needs no marker", "```sh\nls\n```\n<!-- excerpt: ex/a.cpp -->\n```cpp\nx += 2;\n```\n", True),
    ]
    failed = 0
    for name, guide, should_pass in cases:
        problems, _ = check(guide, read)
        if (not problems) != should_pass:
            failed += 1
            print(f"selftest: {name}: expected {'pass' if should_pass else 'a problem'}, got {problems or 'pass'}")
    print(f"selftest: {len(cases) - failed} of {len(cases)} cases as expected")
    return 1 if failed else 0


def main():
    if sys.argv[1:] == ["--selftest"]:
        return selftest()
    if len(sys.argv) != 2:
        sys.exit("usage: guide_excerpts.py SOURCE_DIR | --selftest")
    root = sys.argv[1]
    guide = os.path.join(root, "docs", "guide.md")
    if not os.path.isfile(guide):
        sys.exit(f"guide_excerpts: {guide}: no such file")

    def read(path):
        full = os.path.join(root, path)
        return open(full, encoding="utf-8").read() if os.path.isfile(full) else None

    problems, checked = check(open(guide, encoding="utf-8").read(), read)
    for p in problems:
        print(p)
    if problems:
        return 1
    print(f"guide_excerpts: {checked} excerpts in docs/guide.md match their files")
    return 0


sys.exit(main())
