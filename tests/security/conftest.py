from __future__ import annotations

from pathlib import Path

import pytest

from manigraph_tools.certificates import make_certificates


@pytest.fixture(scope="module")
def certs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One CA and every identity's certificate, made once per test module."""
    directory = tmp_path_factory.mktemp("certs")
    make_certificates(directory)
    return directory
