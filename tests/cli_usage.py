"""A command line that argparse refuses: its exit code and what it printed."""

from __future__ import annotations

import pytest

from rcmplan.cli import main


def usage_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """stderr of `rcmplan argv`, which must end in argparse's usage error (exit 2)."""
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    return capsys.readouterr().err
