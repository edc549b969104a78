"""Shared fixtures: paths to the real recorded logs (skipped when ../shared is absent) and a
project copy with its own baselines folder, so tests never touch the committed baselines."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT.parent / "shared" / "fixtures" / "bags"


@pytest.fixture
def bags() -> Path:
    if not FIXTURES.is_dir():
        pytest.skip(f"real recorded logs not found at {FIXTURES} (only CI and developer "
                    "checkouts have ../shared/fixtures)")
    return FIXTURES


@pytest.fixture
def baselines(tmp_path: Path) -> Path:
    path = tmp_path / "baselines"
    path.mkdir()
    return path
