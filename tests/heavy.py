"""The heavy suites: RCMPLAN_HEAVY_TESTS=1 (`bash scripts/check.sh --heavy`) runs them in full.

Without it, tests marked `heavy` are deselected (the session's last line says how many) and
the generated-input suites that scale with it draw fewer cases; each still runs in CI in its
short form.
"""

from __future__ import annotations

import os

import pytest

HEAVY = os.environ.get("RCMPLAN_HEAVY_TESTS") == "1"
heavy = pytest.mark.heavy


def cases(short: int, full: int) -> int:
    """How many cases a scaled suite draws: `full` under RCMPLAN_HEAVY_TESTS=1, else `short`."""
    return full if HEAVY else short
