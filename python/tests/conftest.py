"""Shared paths for the Python package's tests."""

import json
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="session")
def reference():
    """Inputs and outputs of the Rust calls (written by `cargo test --test python_reference`)."""
    return json.loads((DATA / "rust_reference.json").read_text())
