"""The scenarios shipped with rcmplan (`rcmplan/scenarios/*.toml`) by name, as text: what
`rcmplan scenario --list/--show` and `--scenario NAME` name, without importing the scenario
loader (`rcmplan.scene.scenario`) and the numerical stack it checks a scenario with."""

from __future__ import annotations

from importlib import resources

from rcmplan.exceptions import ScenarioError


def scenario_names() -> list[str]:
    """Names of the scenarios shipped with rcmplan."""
    files = resources.files("rcmplan.scenarios").iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def shipped_text(name: str) -> str:
    """The TOML text of the scenario shipped as `name`; ScenarioError naming the shipped ones
    when there is none."""
    names = scenario_names()
    if name not in names:
        raise ScenarioError("shipped scenario", name, "one of " + ", ".join(names))
    return resources.files("rcmplan.scenarios").joinpath(f"{name}.toml").read_text()
