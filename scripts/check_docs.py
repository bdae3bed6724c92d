"""Checks README.md and docs/*.md: every relative link names a file that exists and, with an
anchor, a heading in it (GitHub's slugs); no commit hash stands outside a generated block's stamp
(a measured figure belongs to the run its block is stamped with, scripts/performance_page.py).
Prints one line per problem; exits 1 if there is any.
Run by test/ros/docs.test (fast tier).

    python3 scripts/check_docs.py [ROOT]
"""
import pathlib
import re
import sys

LINK = re.compile(r"\]\(([^)\s]+)\)")
HEADING = re.compile(r"^(#{1,6}) (.*)$")
# 7 to 40 hex digits with at least one letter (all digits is a number): a commit hash
COMMIT = re.compile(r"\b(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b")
GENERATED = re.compile(r"<!-- generated: \w+ -->\n.*?<!-- end generated -->", re.S)


def commit_hashes(text):
    """(line number, hash) of each commit hash outside the generated blocks."""
    kept = GENERATED.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    for number, line in enumerate(kept.split("\n"), 1):
        for found in COMMIT.findall(line):
            yield number, found


def slug(heading):
    """GitHub's anchor for a heading: lower case, punctuation but '-' and '_' dropped, spaces
    to '-'."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(text):
    """The anchors of a Markdown text's headings (outside code blocks), numbered as GitHub
    numbers repeated ones."""
    found, counts, fenced = set(), {}, False
    for line in text.split("\n"):
        if line.startswith("```"):
            fenced = not fenced
        match = None if fenced else HEADING.match(line)
        if match:
            name = slug(match.group(2))
            n = counts.get(name, 0)
            counts[name] = n + 1
            found.add(name if n == 0 else f"{name}-{n}")
    return found


def links(text):
    """Relative link targets outside code blocks and inline code."""
    fenced = False
    for line in text.split("\n"):
        if line.startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
                if not re.match(r"^[a-z]+://", target) and not target.startswith("mailto:"):
                    yield target


def problems(root):
    root = pathlib.Path(root)
    pages = [root / "README.md"] + sorted((root / "docs").glob("*.md"))
    out = []
    for page in pages:
        text = page.read_text()
        for target in links(text):
            path, _, anchor = target.partition("#")
            file = (page.parent / path).resolve() if path else page
            name = page.relative_to(root)
            if not file.exists():
                out.append(f"{name}: link to {target}: no such file")
            elif anchor and file.suffix == ".md" and anchor not in anchors(file.read_text()):
                out.append(f"{name}: link to {target}: no heading with that anchor")
        for number, found in commit_hashes(text):
            out.append(f"{name}:{number}: commit {found} outside a generated block's stamp: name "
                       "the run by its block, or the change by what it did")
    return out


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent
    found = problems(root)
    for line in found:
        print(line)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
