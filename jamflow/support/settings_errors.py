"""A bad value of a settings field, named by the field (the API argument), so that a command line
can name the option that set it instead (``cli.app``: ``--ftol`` for ``force_tol``)."""

from __future__ import annotations


class SettingError(ValueError):
    """``field`` (an argument of a settings class or function) ``problem`` ("must be ...")."""

    def __init__(self, field: str, problem: str):
        self.field, self.problem = field, problem
        super().__init__(f"{field} {problem}")

    def naming(self, name: str) -> str:
        """The message with the field called ``name`` (an option such as ``--ftol``)."""
        return f"{name} {self.problem}"
