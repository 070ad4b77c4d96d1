"""Progress bars: drawn on a terminal, silent in a pipe, a file or under ``--json``."""

from __future__ import annotations

import io
import re

import pytest

from manigraph_shared.progress import Progress, is_interactive


class Terminal(io.StringIO):
    """A stream that says it is a TTY, as stderr does in a terminal."""

    def isatty(self) -> bool:
        return True


def work(stream: io.StringIO | None, **options: object) -> None:
    with Progress(10, "work", unit="step", stream=stream, **options) as bar:
        for _ in range(10):
            bar.status("loss 0.5")
            bar.update()


def test_a_terminal_gets_a_bar_with_a_count_and_an_eta() -> None:
    stream = Terminal()
    work(stream)
    text = stream.getvalue()
    assert "work:" in text and "10/10" in text and "loss 0.5" in text
    assert re.search(r"\[\d\d:\d\d<\d\d:\d\d", text), text  # elapsed<remaining


def test_forced_interactive_draws_a_bar_on_any_stream() -> None:
    stream = io.StringIO()
    work(stream, interactive=True)
    assert "10/10" in stream.getvalue()


def test_not_a_terminal_is_silent(capsys: pytest.CaptureFixture[str]) -> None:
    import sys

    assert not is_interactive(sys.stderr)  # pytest captures it: not a TTY
    work(sys.stderr)  # type: ignore[arg-type]
    assert capsys.readouterr().err == ""


def test_forced_off_or_without_a_stream_is_silent(capsys: pytest.CaptureFixture[str]) -> None:
    terminal = Terminal()
    work(terminal, interactive=False)
    work(None)
    assert terminal.getvalue() == ""
    assert capsys.readouterr() == ("", "")


def test_notes_are_output_with_or_without_a_bar() -> None:
    plain, terminal = io.StringIO(), Terminal()
    for stream in (plain, terminal):
        with Progress(2, "work", stream=stream) as bar:
            bar.note("cell: 0.950")
            bar.update()
    assert plain.getvalue() == "cell: 0.950\n"
    assert "cell: 0.950\n" in terminal.getvalue() and "1/2" in terminal.getvalue()
