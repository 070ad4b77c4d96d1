"""A private directory that does not outlive the process that made it: ``up --secure``'s
certificate directory, every private key of the stack.

``up`` removes it when it stops; that ``finally`` never runs when ``up`` is killed (SIGKILL,
the OOM killer). So a watcher process holds the read end of a pipe whose only write end is
the owner's: when the owner ends, however it ends, the kernel closes that end, the watcher
reads end-of-file and removes the directory, then exits. The watcher leads its own session
(a Ctrl-C or a closing terminal does not reach it) and ignores SIGINT and SIGHUP; SIGTERM
makes it remove the directory at once. Its only cost is one idle Python process.

Belt and braces: the directory's name carries the owner's pid (``manigraph-certs-<pid>-...``),
and :func:`sweep` removes those of owners no longer running, so even a watcher killed with its
owner leaves the keys only until the next ``up --secure``. What neither covers: a power cut
or a kernel crash before the next start, where the directory stays in the temporary
directory (mode 0700, readable by its user only) until the system clears it.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from types import FrameType

#: The certificate directory of ``up --secure``: ``manigraph-certs-<pid>-<random>``.
CERTS_PREFIX = "manigraph-certs-"


class OwnedDirectory:
    """A new directory ``<tmp>/<prefix><pid>-<random>`` (mode 0700), removed by :meth:`remove`
    or, should this process end first, by its watcher."""

    def __init__(self, prefix: str = CERTS_PREFIX, parent: Path | None = None) -> None:
        sweep(prefix, parent)
        self.path = Path(tempfile.mkdtemp(prefix=f"{prefix}{os.getpid()}-", dir=parent))
        read_end, self._write_end = os.pipe()  # neither is inherited by other children
        try:
            self.watcher = subprocess.Popen(
                [sys.executable, "-m", __name__, str(self.path)],
                stdin=read_end,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
        except BaseException:
            os.close(self._write_end)
            shutil.rmtree(self.path, ignore_errors=True)
            raise
        finally:
            os.close(read_end)

    def remove(self) -> None:
        """Remove the directory now, and let the watcher go."""
        shutil.rmtree(self.path, ignore_errors=True)
        with contextlib.suppress(OSError):
            os.close(self._write_end)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.watcher.wait(timeout=5.0)


def sweep(prefix: str = CERTS_PREFIX, parent: Path | None = None) -> list[Path]:
    """Remove this user's ``<prefix><pid>-*`` directories whose owner no longer runs; returns
    them."""
    where = Path(parent or tempfile.gettempdir())
    pattern = re.compile(rf"^{re.escape(prefix)}(\d+)-")
    removed = []
    for entry in where.glob(f"{prefix}*"):
        match = pattern.match(entry.name)
        try:
            mine = entry.is_dir() and not entry.is_symlink() and entry.stat().st_uid == os.getuid()
        except OSError:
            continue
        if match and mine and not _running(int(match.group(1))):
            shutil.rmtree(entry, ignore_errors=True)
            removed.append(entry)
    return removed


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: running
        return True
    return True


def _watch(path: Path) -> None:
    """Until the owner's end of stdin closes (or SIGTERM), then remove ``path``."""

    def stop(_signum: int, _frame: FrameType | None) -> None:
        raise SystemExit(0)

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, stop)
    try:
        while os.read(0, 4096):
            pass
    except OSError:
        pass
    finally:
        shutil.rmtree(path, ignore_errors=True)


if __name__ == "__main__":
    _watch(Path(sys.argv[1]))
