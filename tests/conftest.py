from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from manigraph_testkit.testing import Stack, stack


def pytest_configure(config: pytest.Config) -> None:
    """Every stack a test starts keeps its emergency-stop latch under this run's own state
    home (one directory per port), never the user's ``~/.local/state``."""
    os.environ["XDG_STATE_HOME"] = tempfile.mkdtemp(prefix="manigraph-test-state-")


def pytest_unconfigure(config: pytest.Config) -> None:
    """The run's state home goes with it: a test run leaves nothing behind in /tmp."""
    state = os.environ.get("XDG_STATE_HOME", "")
    if Path(state).name.startswith("manigraph-test-state-"):
        shutil.rmtree(state, ignore_errors=True)


@pytest.fixture
def running_stack(tmp_path: Path) -> Iterator[Stack]:
    """A router endpoint on a free loopback port; processes started by the test stop at the end."""
    with stack(tmp_path) as running:
        yield running
