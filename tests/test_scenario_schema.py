"""The scenario file format page is generated from the validator and cannot drift from it."""

from __future__ import annotations

from pathlib import Path

import pytest

from rcmplan.cli import main
from rcmplan.cli.scenario import DESCRIPTIONS, schema_markdown
from rcmplan.control.qp_limits import EXTRA_KEYS
from rcmplan.scene.schema import SCHEMA

PAGE = Path(__file__).resolve().parents[1] / "docs" / "scenario-schema.md"


def test_the_docs_page_equals_the_generators_output() -> None:
    assert PAGE.read_text() == schema_markdown(), (
        "docs/scenario-schema.md is stale: rcmplan scenario --schema > docs/scenario-schema.md"
    )


def test_every_key_the_validator_accepts_is_described() -> None:
    for section, keys in SCHEMA.items():
        for key in keys:
            assert (section, key) in DESCRIPTIONS, (section, key)
            assert f"| `{key}` |" in schema_markdown()
    for key in EXTRA_KEYS:
        assert f"| `{key}` |" in schema_markdown()


def test_ranges_come_from_the_schema() -> None:
    lo, hi = SCHEMA["eye"]["radius_mm"][1:]
    row = next(r for r in schema_markdown().splitlines() if r.startswith("| `radius_mm` | number"))
    assert f"[{lo:g}, {hi:g}]" in row and "| 12 |" in row


def test_the_schema_command_prints_the_page(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scenario", "--schema"]) == 0
    assert capsys.readouterr().out == schema_markdown()
