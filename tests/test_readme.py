"""The README's Python example runs as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_has_the_iramis_and_the_own_robot_examples() -> None:
    assert len(BLOCKS) == 2


def test_the_own_robot_example_is_at_most_ten_lines_with_one_import() -> None:
    lines = [line for line in BLOCKS[1].splitlines() if line.strip()]
    assert len(lines) <= 10
    assert [line for line in lines if line.startswith(("import ", "from "))] == [
        "import rcmplan as rp"
    ]


@pytest.mark.parametrize("block", BLOCKS, ids=["iramis", "own-robot"])
def test_readme_python_examples_run(block: str, capsys, monkeypatch) -> None:
    monkeypatch.chdir(README.parent)  # the robot file's path is relative to the checkout
    exec(compile(block, "README.md", "exec"), {})
    printed = float(capsys.readouterr().out.strip().splitlines()[-1])
    assert 0.0 <= printed <= 1e-6  # each example prints the max RCM deviation in metres


def test_readme_opens_with_the_two_commands() -> None:
    lines = README.read_text().splitlines()
    i = lines.index("```bash")
    assert lines[i + 1] == 'pip install ".[all]" && rcmplan inject'
    assert lines[i + 2] == "bash scripts/check.sh"
    assert lines[i + 3] == "```"
