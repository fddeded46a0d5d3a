"""Sphinx directive ``jamflow-cli``: the help of every ``jamflow`` subcommand, generated from the
parsers themselves (``jamflow.cli.app.build_parser(name)`` for each name in ``SUBCOMMANDS``), so the
reference cannot drift from the code."""

from __future__ import annotations

import os

from docutils import nodes
from sphinx.util.docutils import SphinxDirective


def _help(parser) -> str:
    os.environ["COLUMNS"] = "100"
    return parser.format_help()


class JamflowCli(SphinxDirective):
    has_content = False

    def run(self):
        from jamflow.cli.app import SUBCOMMANDS, build_parser

        out = []
        top = build_parser("")
        section = nodes.section(ids=["jamflow"])
        section += nodes.title(text="jamflow")
        section += nodes.literal_block(text=_help(top), language="text")
        out.append(section)
        for name, (_module, help_text) in SUBCOMMANDS.items():
            parser = build_parser(name)
            sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
            section = nodes.section(ids=[f"jamflow-{name}"])
            section += nodes.title(text=f"jamflow {name}")
            section += nodes.paragraph(text=help_text[0].upper() + help_text[1:] + ".")
            section += nodes.literal_block(text=_help(sub.choices[name]), language="text")
            out.append(section)
        return out


def setup(app):
    app.add_directive("jamflow-cli", JamflowCli)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
