"""The README's Python example runs as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
IRAMIS, LIMITS, OWN_ROBOT = range(3)


def test_readme_has_the_iramis_the_limits_and_the_own_robot_examples() -> None:
    assert len(BLOCKS) == 3


def test_the_own_robot_example_is_at_most_ten_lines_with_one_import() -> None:
    lines = [line for line in BLOCKS[OWN_ROBOT].splitlines() if line.strip()]
    assert len(lines) <= 10
    assert [line for line in lines if line.startswith(("import ", "from "))] == [
        "import rcmplan as rp"
    ]


@pytest.mark.parametrize("block", [BLOCKS[IRAMIS], BLOCKS[OWN_ROBOT]], ids=["iramis", "own-robot"])
def test_readme_python_examples_run(block: str, capsys, monkeypatch) -> None:
    monkeypatch.chdir(README.parent)  # the robot file's path is relative to the checkout
    exec(compile(block, "README.md", "exec"), {})
    printed = float(capsys.readouterr().out.strip().splitlines()[-1])
    assert 0.0 <= printed <= 1e-6  # each example prints the max RCM deviation in metres


def test_the_limits_example_runs_the_injection_with_the_rows_it_names(capsys) -> None:  # type: ignore[no-untyped-def]
    exec(compile(BLOCKS[LIMITS], "README.md", "exec"), {})
    rows, deviation = capsys.readouterr().out.strip().splitlines()[-2:]
    assert rows == str(["RcmLimit", "RetinaBarrier", "SingularMargin", "TipSpeed",
                        "WorkspaceBound"])  # fmt: skip
    assert 0.0 <= float(deviation) <= 0.5e-6 + 1e-12  # the QP's RCM box, held


def test_readme_opens_with_the_two_commands() -> None:
    lines = README.read_text().splitlines()
    i = lines.index("```bash")
    assert lines[i + 1] == 'pip install ".[all]" && rcmplan inject'
    assert lines[i + 2] == "bash scripts/check.sh"
    assert lines[i + 3] == "```"
