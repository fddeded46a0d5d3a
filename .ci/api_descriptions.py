"""Share of the API reference's entries that have a description, from the built site.

Reads the HTML Sphinx wrote for docs/reference/api/ (build it first:
``sphinx-build -b html docs docs/_build/html``) and counts every documented object (function,
class, method, attribute, property, exception, data): an entry has a description when its body
has text of its own, not counting the entries nested in it. Prints the share over all entries
and over the names in ``jamflow.__all__`` and their members, and lists the entries without one
(``--list``). ``--min PERCENT``: exit 1 when the share over all entries is below PERCENT (CI
runs it with the share reached, so that it cannot fall back).

    python .ci/api_descriptions.py [docs/_build/html] [--list] [--min PERCENT]
"""

from __future__ import annotations

import sys
from html.parser import HTMLParser
from pathlib import Path

KINDS = {"function", "class", "method", "attribute", "property", "exception", "data", "classmethod", "staticmethod"}


class _Entries(HTMLParser):
    """Collects (id, kind, own text of the description) for every <dl class="py KIND">."""

    def __init__(self):
        super().__init__()
        self.stack = []  # per open <dl>/<dt>/<dd>: [tag, entry or None]
        self.entries = []  # [id, kind, text]
        self.open = []  # entries whose <dl> is open, innermost last
        self.in_dd = []  # per open entry: depth of its own <dd>, None before it
        self.pending_id = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "dl":
            classes = (a.get("class") or "").split()
            kind = next((c for c in classes if c in KINDS), None)
            if "py" in classes and kind:
                entry = [None, kind, ""]
                self.entries.append(entry)
                self.open.append(entry)
                self.stack.append(("dl", entry))
                return
            self.stack.append(("dl", None))
        elif tag in ("dt", "dd"):
            self.stack.append((tag, self.open[-1] if self.open else None))
            if tag == "dt" and self.open and self.open[-1][0] is None and a.get("id"):
                self.open[-1][0] = a["id"]

    def handle_endtag(self, tag):
        if tag in ("dl", "dt", "dd"):
            while self.stack:
                t, entry = self.stack.pop()
                if t == tag:
                    if t == "dl" and entry is not None:
                        self.open.pop()
                    break

    def handle_data(self, data):
        # text belongs to the innermost entry when the innermost dl/dt/dd is that entry's own <dd>
        if not self.stack or not self.open:
            return
        tag, entry = self.stack[-1]
        if tag == "dd" and entry is self.open[-1]:
            entry[2] += data


def entries(html_dir: Path) -> list[tuple[str, str, bool]]:
    out = []
    for page in sorted((html_dir / "reference" / "api").glob("*.html")):
        parser = _Entries()
        parser.feed(page.read_text(encoding="utf-8"))
        out += [(ident or f"?{page.name}", kind, bool(text.strip())) for ident, kind, text in parser.entries]
    return out


def main(argv: list[str]) -> int:
    minimum = None
    if "--min" in argv:
        k = argv.index("--min")
        minimum = float(argv[k + 1])
        argv = argv[:k] + argv[k + 2:]
    html_dir = Path(next((a for a in argv if not a.startswith("-")), "docs/_build/html"))
    found = entries(html_dir)
    if not found:
        print(f"no API entries under {html_dir / 'reference' / 'api'}: build the site first", file=sys.stderr)
        return 2
    import jamflow

    public = tuple(f"jamflow.{name}" for name in jamflow.__all__)

    def in_all(ident: str) -> bool:
        return any(ident == p or ident.startswith(p + ".") for p in public)

    for label, rows in (("all API entries", found), ("jamflow.__all__ and members", [e for e in found if in_all(e[0])])):
        have = sum(d for _, _, d in rows)
        print(f"{label}: {have} of {len(rows)} have a description ({100 * have / max(len(rows), 1):.1f} %), "
              f"{len(rows) - have} have none")
    if "--list" in argv:
        for ident, kind, described in found:
            if not described:
                print(f"  none: {kind} {ident}{'  (__all__)' if in_all(ident) else ''}")
    share = 100 * sum(d for _, _, d in found) / len(found)
    if minimum is not None and share < minimum:
        print(f"the share of API entries with a description, {share:.1f} %, is below {minimum:g} %: describe the "
              "new entries (--list names them)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
