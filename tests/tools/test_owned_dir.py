"""``up --secure``'s certificate directory does not outlive its owner: removed by its watcher
when the owner is killed (SIGKILL: no ``finally`` runs), and by the next start's sweep when
the watcher went too."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from manigraph_tools.owned_dir import CERTS_PREFIX, OwnedDirectory, sweep

OWNER = """
import signal, sys, time
signal.signal(signal.SIGINT, signal.SIG_IGN)  # as up, busy stopping its stack
from pathlib import Path
from manigraph_tools.owned_dir import OwnedDirectory
owned = OwnedDirectory(parent=Path(sys.argv[1]))
(owned.path / "client.key").write_text("secret")
print(owned.path, owned.watcher.pid, flush=True)
time.sleep(60)
"""


def _gone(path: Path, within: float) -> bool:
    deadline = time.monotonic() + within
    while path.exists():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def test_a_killed_owner_leaves_no_key_behind(tmp_path: Path) -> None:
    owner = subprocess.Popen(  # leads its process group, as a command at a terminal does
        [sys.executable, "-c", OWNER, str(tmp_path)],
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    assert owner.stdout is not None
    path_text, watcher_pid = owner.stdout.readline().split()
    path = Path(path_text)
    assert path.name.startswith(f"{CERTS_PREFIX}{owner.pid}-")
    assert (path / "client.key").read_text() == "secret"
    assert path.stat().st_mode & 0o777 == 0o700
    os.killpg(owner.pid, signal.SIGINT)  # Ctrl-C reaches the owner's group, not the watcher
    time.sleep(0.2)
    assert path.exists()  # the watcher did not hear it: the owner still holds it
    owner.kill()
    owner.wait()
    assert _gone(path, within=5.0)
    # the watcher has gone too: nothing is left to wait for
    deadline = time.monotonic() + 5.0
    while Path(f"/proc/{watcher_pid}").exists() and "Z" not in _state(int(watcher_pid)):
        assert time.monotonic() < deadline
        time.sleep(0.02)


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return "gone"


def test_remove_is_at_once_and_lets_the_watcher_go(tmp_path: Path) -> None:
    owned = OwnedDirectory(parent=tmp_path)
    (owned.path / "router.key").write_text("secret")
    owned.remove()
    assert not owned.path.exists()
    assert owned.watcher.poll() == 0


def test_the_next_start_sweeps_what_a_dead_owner_left(tmp_path: Path) -> None:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # a pid that no longer runs (not reused within this test)
    left = tmp_path / f"{CERTS_PREFIX}{dead.pid}-abc123"
    left.mkdir()
    (left / "sim.key").write_text("secret")
    live = tmp_path / f"{CERTS_PREFIX}{os.getpid()}-def456"  # another running up's: kept
    live.mkdir()
    unrelated = tmp_path / f"{CERTS_PREFIX}abc_def1"  # not named by a pid: kept
    unrelated.mkdir()
    assert sweep(parent=tmp_path) == [left]
    assert not left.exists() and live.exists() and unrelated.exists()
