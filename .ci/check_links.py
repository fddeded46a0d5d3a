#!/usr/bin/env python3
"""Dangling-link check: every relative Markdown link or image in the repository's .md files must
name a file or folder that exists, and every ``docs/...`` path mentioned in any tracked text file
(code, docstrings, decks, notes) must exist. Prints each dangling link; exit 1 if there is one.

    python .ci/check_links.py
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
DOCS_PATH = re.compile(r"(?<![A-Za-z0-9_./-])docs/[A-Za-z0-9_./*-]*[A-Za-z0-9_/*-]")
# outputs written on demand, never committed (benchmark --out defaults, placeholders)
NOT_COMMITTED = {"docs/notes/nmers/crosscheck.csv", "docs/notes/protocol-bias.csv", "docs/notes/protocol-bias-nN.csv",
                 "docs/gallery/images", "docs/gallery/images/"}  # the gallery's pictures: docs/gallery/make_gallery.py
TEXT = {".md", ".py", ".lmp", ".toml", ".txt", ".yaml", ".yml", ".cfg", ".cff", ""}


def tracked() -> list[Path]:
    out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout.split("\n")
    return [ROOT / p for p in out if p and (ROOT / p).is_file() and not p.startswith("docs/_build/")]


def main() -> int:
    bad = []
    for path in tracked():
        if path.suffix not in TEXT:
            continue
        try:
            text = path.read_text()
        except UnicodeDecodeError:
            continue
        rel = path.relative_to(ROOT)
        for no, line in enumerate(text.splitlines(), 1):
            if path.suffix == ".md":
                for target in LINK.findall(line):
                    if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith(("#", "{")):
                        continue
                    name = target.split("#")[0]
                    if name and not (path.parent / name).exists():
                        bad.append(f"{rel}:{no}: link to missing {target}")
            for mention in DOCS_PATH.findall(line):
                # a path, a glob (docs/notes/structure-*.png) or an output prefix (docs/notes/shear-path-n10)
                ok = mention in NOT_COMMITTED or (ROOT / mention).exists() or any(ROOT.glob(mention.rstrip("*") + "*"))
                if not ok and not mention.startswith("docs/_build"):
                    bad.append(f"{rel}:{no}: mentions missing {mention}")
    for line in bad:
        print(line)
    print(f"check_links: {len(bad)} dangling link(s)", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
