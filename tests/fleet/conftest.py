"""Fleet tests need the [fleet] extra (dev.py installs it): skipped, saying so, without it."""

from __future__ import annotations

import pytest

from blinkcan import fleet

if fleet.missing("pyarrow", "duckdb", "fsspec", "zstandard", "distributed"):
    pytest.skip(f"the fleet extra is not installed: {fleet.EXTRA}", allow_module_level=True)
