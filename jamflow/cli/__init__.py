"""The command line: ``jamflow`` and its subcommands (``cli.commands``), shared options, progress
display. It calls the library; nothing in the library calls it."""


def __getattr__(name):  # jamflow.cli.main / build_parser as before the layered package, loaded on use
    if name in ("main", "build_parser"):
        from jamflow.cli import app as module

        return getattr(module, name)
    raise AttributeError(f"module 'jamflow.cli' has no attribute {name!r}")
