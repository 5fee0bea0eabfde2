#!/usr/bin/env python3
"""Fails on a broken local link in the guide (docs/src) or the README.

mdbook does not check links itself. Run after `mdbook build docs`: a link
`chapter.md#anchor` must name a file that exists and, for a chapter of the
book, an id that its built page (docs/book/chapter.html) has. External
links (http, https, mailto) are not followed.
"""

import html.parser
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
SRC = ROOT / "docs" / "src"
BOOK = ROOT / "docs" / "book"
# [text](target) and ![alt](target); the target ends at whitespace or ')'.
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^\s*```")


class Ids(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.ids = set()

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name == "id" and value:
                self.ids.add(value)


def ids_of(page, cache={}):
    if page not in cache:
        parser = Ids()
        parser.feed(page.read_text(encoding="utf-8"))
        cache[page] = parser.ids
    return cache[page]


def links(path):
    """(line number, target) of every link outside code blocks."""
    in_code = False
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if FENCE.match(line):
            in_code = not in_code
            continue
        if in_code:
            continue
        # Inline code is not a link.
        for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
            yield number, target


def check(path):
    errors = []
    for number, target in links(path):
        if re.match(r"^[a-z]+:", target):
            continue
        file_part, _, anchor = target.partition("#")
        linked = (path.parent / file_part).resolve() if file_part else path.resolve()
        where = f"{path.relative_to(ROOT)}:{number}: `{target}`"
        if not linked.exists():
            errors.append(f"{where}: no such file")
            continue
        if anchor and linked.suffix == ".md" and SRC in linked.parents:
            page = BOOK / linked.relative_to(SRC).with_suffix(".html")
            if not page.exists():
                errors.append(f"{where}: {page.relative_to(ROOT)} not built (run `mdbook build docs` first)")
            elif anchor not in ids_of(page):
                errors.append(f"{where}: no heading `#{anchor}` in {linked.relative_to(ROOT)}")
    return errors


def main():
    files = sorted(SRC.rglob("*.md")) + [ROOT / "README.md", ROOT / "ARCHITECTURE.md"]
    errors = [e for f in files for e in check(f)]
    for e in errors:
        print(f"broken link: {e}", file=sys.stderr)
    print(f"checked the links of {len(files)} files: {len(errors)} broken")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
