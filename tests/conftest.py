from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from manigraph_testkit.testing import Stack, stack


@pytest.fixture
def running_stack(tmp_path: Path) -> Iterator[Stack]:
    """A router endpoint on a free loopback port; processes started by the test stop at the end."""
    with stack(tmp_path) as running:
        yield running
