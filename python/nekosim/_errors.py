"""The exceptions of the nekosim package."""

from typing import Optional


class ScenarioError(ValueError):
    """Bad input: a scenario, a `set` path or an output path nekosim refuses.

    ``str(e)`` is the command line's one line, ``FILE:LINE:COL: what is wrong``;
    ``.file``, ``.line`` and ``.col`` give the location (``None`` where none applies).
    """

    def __init__(
        self,
        message: str,
        file: Optional[str] = None,
        line: Optional[int] = None,
        col: Optional[int] = None,
    ) -> None:
        super().__init__(message)
        self.file = file
        self.line = line
        self.col = col
