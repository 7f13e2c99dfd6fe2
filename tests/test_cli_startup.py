"""A command starts with what it needs: `rcmplan COMMAND` registers that command's module only,
the light commands (`scenario --show`, `--version`, the `view` parser) load no numerical library
(numba, scipy), and help and errors still list every command."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cli_usage import usage_error
from rcmplan.cli import COMMANDS, MODULE_OF, build_parser, command_parsers, main, modules_for

SRC = Path(__file__).resolve().parents[1] / "src"
NUMERICAL = ("numba", "scipy")
EVERY_COMMAND = sorted({*COMMANDS, *MODULE_OF})


def loaded_after(code: str) -> tuple[list[str], str]:
    """Run `code` in a fresh interpreter; the numerical modules it left loaded and its stdout
    (without the last line, which reports the modules)."""
    report = f"import json, sys; print(json.dumps([m for m in {NUMERICAL!r} if m in sys.modules]))"
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    out = subprocess.run([sys.executable, "-c", f"{code}\n{report}"], capture_output=True,
                         text=True, check=True, env=env)  # fmt: skip
    *printed, last = out.stdout.rstrip("\n").split("\n")
    return json.loads(last), "\n".join(printed)


def run_command(argv: list[str]) -> str:
    """Python code that runs `rcmplan argv` as `python -m rcmplan` does."""
    return (
        "import runpy, sys\n"
        f"sys.argv = ['rcmplan', *{argv!r}]\n"
        "sys.orig_argv = [sys.executable, '-m', 'rcmplan', *sys.argv[1:]]\n"
        "try:\n"
        "    runpy.run_module('rcmplan', run_name='__main__')\n"
        "except SystemExit as exc:\n"
        "    assert exc.code in (0, None), exc.code\n"
    )


def option(command: str, dest: str) -> argparse.Action:
    """The option `dest` of `command` in the parser `rcmplan command` builds."""
    parser = command_parsers(build_parser(modules_for([command])))[command]
    return next(a for a in parser._actions if a.dest == dest)


def test_scenario_show_prints_the_file_without_the_numerical_stack() -> None:
    from rcmplan.scene.shipped import shipped_text

    loaded, printed = loaded_after(run_command(["scenario", "--show", "default"]))
    assert loaded == []
    assert printed == shipped_text("default").rstrip("\n")


def test_version_loads_no_numerical_library() -> None:
    from rcmplan._version import __version__

    loaded, printed = loaded_after(run_command(["--version"]))
    assert loaded == []
    assert printed == f"rcmplan {__version__}"


def test_the_view_parser_loads_no_numerical_library() -> None:
    code = (
        "from rcmplan.cli import build_parser, modules_for\n"
        "argv = ['view', 'RUN', '--no-browser', '--plant', 'mujoco', '--robot', 'ur5']\n"
        "args = build_parser(modules_for(argv)).parse_args(argv)\n"
        "print(args.command, args.run_dir, args.no_browser, args.plant, args.robot)\n"
    )
    loaded, printed = loaded_after(code)
    assert loaded == []
    assert printed == "view RUN True mujoco ur5"


def test_a_run_command_still_loads_what_it_runs() -> None:
    """The check above can fail: a command that runs a scenario imports numba to run it."""
    code = "import rcmplan.cli.inject\nprint()"
    loaded, _ = loaded_after(code)
    assert "numba" in loaded


@pytest.mark.parametrize("name", EVERY_COMMAND)
def test_a_command_registers_its_own_module_only(name: str) -> None:
    module = MODULE_OF.get(name, name)
    assert modules_for([name, "--help"]) == (module,)
    assert modules_for(["--version", name]) == (module,)
    own = [n for n in EVERY_COMMAND if MODULE_OF.get(n, n) == module]
    assert sorted(command_parsers(build_parser(modules_for([name])))) == own


@pytest.mark.parametrize("name", EVERY_COMMAND)
def test_a_command_parser_alone_is_the_one_of_the_full_parser(name: str) -> None:
    """Its help, and what it reads from the command line with the defaults, are the same."""
    alone, full = build_parser(modules_for([name])), build_parser()
    assert command_parsers(alone)[name].format_help() == command_parsers(full)[name].format_help()
    argv = [name, *NEEDED.get(name, [])]
    assert vars(alone.parse_args(argv)) == vars(full.parse_args(argv))


NEEDED = {"view": ["--live"]}  # what a command needs besides its defaults (view: RUN_DIR or --live)


@pytest.mark.parametrize(
    "argv", [[], ["--help"], ["-h", "inject"], ["--he"], ["injct"], ["--bogus", "inject"], ["--"]]
)
def test_help_and_errors_register_every_command(argv: list[str]) -> None:
    assert modules_for(argv) == COMMANDS


def test_version_alone_registers_no_command() -> None:
    assert modules_for(["--version"]) == modules_for(["--vers"]) == ()
    assert modules_for(["--version", "--version"]) == ()


def test_the_help_lists_every_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["--help"])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    block = text.split("\n  COMMAND\n", 1)[1].split("\noptions:", 1)[0]
    assert [line.split()[0] for line in block.splitlines() if line[4:5].strip()] == [
        "compare", "inject", "spiral", "render", "reproduce", "robot", "scenario", "subretinal",
        "sweep", "teleop", "view",
    ]  # fmt: skip


def test_a_misspelt_command_lists_every_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["injct"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'injct' (choose from 'compare', 'inject', 'spiral', 'render'," in err
    assert all(f"'{name}'" in err for name in EVERY_COMMAND)


def test_method_choices_and_help_are_the_methods_the_solver_builds() -> None:
    from rcmplan.choices import METHODS as LISTED
    from rcmplan.control.methods import METHODS

    assert METHODS is LISTED
    assert METHODS == ("pinv", "pinv-thesis", "dls", "qp")
    method = option("inject", "method")
    assert method.choices == METHODS
    assert method.metavar == "{pinv,pinv-thesis,dls,qp}"
    assert method.help == "control method (the scenario's)"
    many = option("compare", "method")
    assert many.choices == METHODS
    assert many.help == "a method to run, repeatable: {pinv,pinv-thesis,dls,qp} (every method)"


def test_the_robot_names_are_the_registered_robots() -> None:
    from rcmplan.robot.names import ROBOT_NAMES
    from rcmplan.robot.registry import ROBOTS

    assert tuple(ROBOTS) == ROBOT_NAMES


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["inject", "--metod", "qp"], "rcmplan inject: error: unrecognized arguments: --metod qp; "
                                      "did you mean --method?"),
        (["inject", "--bogus=3"], "rcmplan inject: error: unrecognized arguments: --bogus=3"),
        (["injct"], "invalid choice: 'injct' (choose from 'compare', 'inject', "),
        (["injct"], "'view'); did you mean inject?"),
        (["inject", "--method", "qpp"], "(choose from 'pinv', 'pinv-thesis', 'dls', 'qp'); did "
                                        "you mean qp?"),
    ],
)  # fmt: skip
def test_a_misspelt_word_is_answered_with_the_command_usage_and_the_closest_valid_one(
    argv: list[str], said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    err = usage_error(argv, capsys)
    assert said in err
    usage = "usage: rcmplan inject " if argv[0] == "inject" else "usage: rcmplan [-h]"
    assert err.startswith(usage)
    assert err.count("did you mean") == (0 if argv == ["inject", "--bogus=3"] else 1)
