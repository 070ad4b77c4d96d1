"""Progress of long work (training, evaluation, the suite): a bar with an ETA on a terminal,
nothing anywhere else.

A bar is drawn only when its stream is interactive (a TTY), so a run piped into a file, a CI
log or another program's stdout stays clean; a command given ``--json`` passes no stream at
all. Lines that are *results* rather than progress (a suite cell's score, a skipped
demonstration) go through :meth:`Progress.note`, which prints them above a running bar and
plainly when there is none.

The planner (training) and the lab (evaluation, suite, selection) both use it, and a service
must not import the lab, so it lives in ``shared/``.
"""

from __future__ import annotations

from types import TracebackType
from typing import Any, TextIO

__all__ = ["Progress", "is_interactive"]


def is_interactive(stream: TextIO | None) -> bool:
    """Whether ``stream`` is a terminal a bar can redraw in place."""
    if stream is None:
        return False
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty and isatty())
    except ValueError:  # a closed stream
        return False


class Progress:
    """A tqdm bar on ``stream`` if it is interactive, otherwise a no-op with the same methods.

    Args:
        total: units of work expected (None: unknown, no ETA).
        desc: what is being done, shown before the bar.
        unit: the unit of work (``episode``, ``epoch``...).
        stream: where the bar goes, normally ``sys.stderr``; None: silent, notes included.
        interactive: force the bar on (True) or off (False); None: ``is_interactive(stream)``.
        leave: keep the finished bar on screen; None: only if it is not nested in another.
    """

    def __init__(
        self,
        total: int | None,
        desc: str = "",
        *,
        unit: str = "it",
        stream: TextIO | None,
        interactive: bool | None = None,
        leave: bool | None = None,
    ) -> None:
        self.stream = stream
        show = stream is not None and (
            is_interactive(stream) if interactive is None else interactive
        )
        self._bar: Any = None
        if show:
            from tqdm import tqdm

            self._bar = tqdm(
                total=total, desc=desc, unit=unit, file=stream, leave=leave, dynamic_ncols=True
            )

    @property
    def shown(self) -> bool:
        return self._bar is not None

    def update(self, n: int = 1) -> None:
        if self._bar is not None:
            self._bar.update(n)

    def status(self, text: str) -> None:
        """Show ``text`` after the bar (e.g. ``loss 0.12``)."""
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=False)

    def note(self, line: str) -> None:
        """A line of output (not progress): above the bar, or plainly without one."""
        if self._bar is not None:
            self._bar.write(line, file=self.stream)
        elif self.stream is not None:
            print(line, file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()

    def __enter__(self) -> Progress:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
