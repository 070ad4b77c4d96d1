"""Progress lines while the camera's renderer warms up, instead of half a minute of silence.

The first frame a process renders compiles SAPIEN's shaders: 15-40 s in which the sim says
nothing and is not yet alive. A thread of the sim cannot say how long it has been: the
compiler holds the GIL the whole time (measured: a 0.5 s ticker thread was silent for 25 s).
So a tiny child process does it: :func:`progress_while` logs the start, and the child writes a
line every ``every`` seconds to the sim's own stderr, in the log's format, until the block ends
(its stdin is closed, which also happens if the sim dies); then the sim logs the total.
"""

from __future__ import annotations

import logging
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

#: Seconds between two progress lines.
PROGRESS_EVERY = 5.0

#: The child: one line per period until its stdin ends (the log format of manigraph_shared.cli).
_TICKER = r"""
import select, sys, time
every, name, what = float(sys.argv[1]), sys.argv[2], sys.argv[3]
started = time.monotonic()
while not select.select([sys.stdin], [], [], every)[0]:
    now = time.time()
    stamp = time.strftime("%H:%M:%S", time.localtime(now)) + f".{int(now * 1000) % 1000:03d}"
    seconds = time.monotonic() - started
    sys.stderr.write(f"{stamp} INFO  {name}: {what}: {seconds:.0f} s so far\n")
    sys.stderr.flush()
"""


@contextmanager
def progress_while(
    log: logging.Logger, what: str, expected: str, every: float | None = None
) -> Iterator[None]:
    """Log ``what`` (with how long it is ``expected`` to take), a line every ``every`` seconds
    while the block runs, even if it holds the GIL, and how long it took."""
    log.info("%s (%s) ...", what, expected)
    started = time.monotonic()
    ticker = None
    if log.isEnabledFor(logging.INFO):
        every = PROGRESS_EVERY if every is None else every
        ticker = subprocess.Popen(
            [sys.executable, "-c", _TICKER, str(every), log.name, what],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
        )
    try:
        yield
    finally:
        if ticker is not None:
            assert ticker.stdin is not None
            ticker.stdin.close()
            try:
                ticker.wait(timeout=5)
            except subprocess.TimeoutExpired:
                ticker.kill()
                ticker.wait()
    log.info("%s: done in %.1f s", what, time.monotonic() - started)
