"""`rcmplan scenario`: the scenario file format, generated from the validator's own schema.

`--schema` prints the page `docs/scenario-schema.md` holds (a test keeps the two equal): every
section and key of `rcmplan.scene.schema.SCHEMA` with its type, allowed range, default (read
from a scenario parsed from an empty file, so it is the value the code uses) and meaning; the
`[qp]` keys come from `rcmplan.control.qp_limits`. `--list` names the shipped scenarios, and
`--show NAME` prints one's file, a starting point for a scenario of one's own.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from rcmplan.analysis.units import fmt_setting
from rcmplan.choices import CURVED_METHODS, METHODS
from rcmplan.scene.shipped import scenario_names, shipped_text

if TYPE_CHECKING:  # the scenario loader imports the numerical stack: only --list and --schema
    from rcmplan.scene.scenario import Scenario

MM = 1e3
Key = tuple[str, str]


def _listed(names: tuple[str, ...]) -> str:
    """ "`a`, `b` or `c`"."""
    quoted = [f"`{n}`" for n in names]
    return f"{', '.join(quoted[:-1])} or {quoted[-1]}"


DESCRIPTIONS: dict[Key, str] = {
    ("", "name"): "name shown in outputs",
    ("", "procedure"): "`injection` or `spiral`",
    ("", "plant"): "plant the run uses (`rcmplan inject --help` lists them)",
    ("", "description"): "one line for people; not used by the run",
    ("", "robot"): "the robot: a name (`rcmplan robot --list`) or a robot file (.toml, a path "
    "relative to the scenario file; docs/robots.md); the eye is placed for it",
    ("eye", "radius_mm"): "outer (scleral) radius of the eye",
    ("eye", "wall_mm"): "wall thickness; the retina is the inner sphere",
    ("eye", "trocar_radius_mm"): "radius of the trocar port (the RCM bound)",
    ("eye", "trocar_offset_mm"): "trocar relative to the needle tip at home, base frame",
    ("eye", "insertion_angles_rad"): "needle angles (phi, psi) of the insertion axis",
    ("points", "outside_mm"): "p1: distance outside the trocar on its axis",
    ("points", "depth_mm"): "p3: depth inside the trocar on its axis",
    ("points", "spread_rad"): "tilt of the rays from the trocar to p4..p7",
    ("points", "visits"): "points the injection visits from p3, in order (among p3..p7)",
    ("points", "frame"): "frame of p1_mm..p7_mm: `base`, the robot's base frame (the points then "
    "run on the scenario's `robot` only), or `eye`, the eye frame of `--target` (origin at the "
    "eye centre, z along the insertion axis: the same place in the eye on every robot)",
    ("steps", "position_mm"): "largest tip step between two targets; at most the loop's "
    "largest target jump (the upper bound) less sqrt(3) x `tolerance_position_m`",
    ("steps", "angle_mrad"): "largest needle-angle step between two targets",
    ("controller", "method"): f"{_listed(METHODS)}; a curved needle: {_listed(CURVED_METHODS)} "
    "(its solvers have no thesis variant)",
    ("controller", "K"): "diagonal gains of the pseudoinverse methods, each in (0, 2)",
    ("controller", "damping"): "DLS damping in m (the QP: regularisation per unit motion)",
    ("controller", "tolerance_position_m"): "loop tolerance on position components (raised to "
    "what the plant's actuator resolution supports)",
    ("controller", "tolerance_angle_rad"): "loop tolerance on angle components (raised likewise)",
    ("controller", "max_iterations"): "iteration cap of Algorithm 1 per target",
    ("controller", "drift_correction"): "re-declare the RCM as the needle point nearest the trocar",
    ("controller", "dt_s"): "control period",
    ("controller", "rcm_bound_um"): "largest RCM distance from the trocar; a phase beyond it "
    "ends the run (RcmBoundError)",
    ("controller", "rcm_tolerance_um"): "largest RCM distance one step may leave: a longer step "
    "is shortened (its deviation is second order in its length)",
    ("needle", "kind"): "`straight`, or `curved`: a shaft then an arc (the roll joins the "
    "controlled joints; the injection enters along the arc and visits lateral targets)",
    ("needle", "radius_mm"): "arc radius R of a curved needle",
    ("needle", "arc_angle_rad"): "arc angle alpha of a curved needle (0: straight)",
    ("lateral", "directions"): "requested tip direction per visit, base frame (default: the "
    "retina's outward normal); the needle takes the nearest it can",
    ("lateral", "tolerance_mrad"): "largest angle between a requested direction and the one the "
    "needle takes; beyond it the target is refused before motion",
    ("spiral", "offset_mm"): "spiral centre from p3 along (e1, e2), normal to the trocar axis",
    ("spiral", "radius_mm"): "final radius (grows linearly from 0)",
    ("spiral", "turns"): "number of turns",
    ("spiral", "pitch_mm"): "advance along the trocar axis per turn (0: flat)",
    ("spiral", "points_per_turn"): "samples per turn",
}
DESCRIPTIONS.update({
    ("points", f"p{n}_mm"): f"p{n} given directly, in `frame` (replaces its default placement)"
    for n in range(1, 8)
})  # fmt: skip


def mm(v: Any) -> Any:
    """A length or a tuple of lengths from m to mm."""
    return tuple(x * MM for x in v) if isinstance(v, tuple) else v * MM


def _defaults(sc: Scenario) -> dict[Key, Any]:
    """Default value of each key, in the file's units, read from the parsed scenario."""
    eye, pts, ms = sc.eye_options, sc.point_options, sc.method_settings
    return {
        ("", "name"): sc.name, ("", "procedure"): sc.procedure, ("", "plant"): sc.plant,
        ("", "robot"): sc.robot,
        ("eye", "radius_mm"): mm(eye["radius"]), ("eye", "wall_mm"): mm(eye["wall"]),
        ("eye", "trocar_radius_mm"): mm(eye["trocar_radius"]),
        ("eye", "trocar_offset_mm"): mm(eye["trocar_offset"]),
        ("eye", "insertion_angles_rad"): eye["insertion_angles"],
        ("points", "outside_mm"): mm(pts["outside"]), ("points", "depth_mm"): mm(pts["depth"]),
        ("points", "spread_rad"): pts["spread"], ("points", "visits"): sc.visits,
        ("points", "frame"): sc.point_frame,
        ("steps", "position_mm"): mm(sc.steps.position),
        ("steps", "angle_mrad"): sc.steps.angle * 1e3,
        ("controller", "method"): sc.method, ("controller", "K"): ms.K,
        ("controller", "damping"): ms.damping,
        ("controller", "tolerance_position_m"): ms.tolerance.position,
        ("controller", "tolerance_angle_rad"): ms.tolerance.angle,
        ("controller", "max_iterations"): sc.loop.max_iterations,
        ("controller", "drift_correction"): sc.loop.drift_correction,
        ("controller", "dt_s"): sc.dt,
        ("controller", "rcm_bound_um"): sc.loop.rcm_bound * 1e6 if sc.loop.rcm_bound else None,
        ("controller", "rcm_tolerance_um"): (
            sc.loop.rcm_tolerance * 1e6 if sc.loop.rcm_tolerance else None
        ),
        ("needle", "kind"): sc.needle.kind, ("needle", "radius_mm"): mm(sc.needle.radius),
        ("needle", "arc_angle_rad"): sc.needle.arc_angle,
        ("lateral", "tolerance_mrad"): sc.needle.tolerance * 1e3,
        ("spiral", "offset_mm"): mm(sc.spiral.offset),
        ("spiral", "radius_mm"): mm(sc.spiral.radius),
        ("spiral", "turns"): sc.spiral.turns, ("spiral", "pitch_mm"): mm(sc.spiral.pitch),
        ("spiral", "points_per_turn"): sc.spiral.points_per_turn,
    }  # fmt: skip


def _kind(kind: str, lo: float, hi: float) -> tuple[str, str]:
    """(type, allowed) of a SCHEMA entry."""
    if kind in ("str", "bool"):
        return {"str": "string", "bool": "true / false"}[kind], ""
    if kind == "strlist":
        return "list of point names", f"{lo:g} to {hi:,.0f} names"
    if kind == "vec3list":
        return "list of [x, y, z] lists", f"each in [{lo:g}, {hi:g}]"
    if kind.startswith("vec"):
        return f"list of {kind[3:]} numbers", f"each in [{lo:g}, {hi:g}]"
    return {"float": "number", "int": "integer"}[kind], f"[{lo:g}, {hi:g}]"


def attribute_docs(docstring: str) -> dict[str, str]:
    """name -> text of the "Attributes:" section of a Google-style docstring, on one line."""
    out: dict[str, str] = {}
    name = None
    for line in docstring.split("Attributes:", 1)[-1].splitlines():
        head, sep, text = line.strip().partition(": ")
        depth = len(line) - len(line.lstrip())
        if sep and head.isidentifier() and depth == 8:
            name, out[head] = head, text.strip()
        elif name and line.strip():
            out[name] += " " + line.strip()
    return {k: v.replace("|", "\\|") for k, v in out.items()}


def _unit(key: str) -> str:
    if key.endswith("_mm_per_rad"):
        return "mm/rad"
    if key.endswith("_mm_s"):
        return "mm/s"
    for suffix, unit in (("_mm", "mm"), ("_mrad", "mrad"), ("_rad", "rad"), ("_m", "m"),
                         ("_s", "s"), ("_um", "um")):  # fmt: skip
        if key.endswith(suffix):
            return unit
    return ""


def section_rows(section: str, defaults: dict[Key, Any]) -> list[str]:
    """Markdown table rows of one section."""
    from rcmplan.scene.schema import SCHEMA

    rows = []
    for key, (kind, lo, hi) in SCHEMA[section].items():
        typ, allowed = _kind(kind, lo, hi)
        default = fmt_setting(defaults[(section, key)]) if (section, key) in defaults else "-"
        rows.append(f"| `{key}` | {typ} | {allowed} | {_unit(key)} | {default} | "
                    f"{DESCRIPTIONS[(section, key)]} |")  # fmt: skip
    return rows


def qp_rows() -> list[str]:
    """Markdown rows of the [qp] section, from the QP's own key table and defaults."""
    from dataclasses import fields

    from rcmplan.control.qp_limits import EXTRA_KEYS, QpLimits

    defaults = QpLimits()
    doc = {f.name: f.name.replace("_", " ") for f in fields(QpLimits)}
    doc.update(attribute_docs(QpLimits.__doc__ or ""))
    rows = []
    for key, (name, factor) in EXTRA_KEYS.items():
        value = getattr(defaults, name)
        shown = "-" if value is None else fmt_setting(value / factor)
        rows.append(f"| `{key}` | number | | {_unit(key)} | {shown} | {doc[name]} |")
    rows.append("| `contacts_mm` | list of points | | mm | none | extra contact points where "
                "the retina margin is relaxed |")  # fmt: skip
    return rows


HEAD = ["| key | type | allowed | unit | default | meaning |", "|---|---|---|---|---|---|"]


def schema_markdown() -> str:
    """The scenario file format as a Markdown page (docs/scenario-schema.md)."""
    from rcmplan.scene.scenario import scenario_from_dict
    from rcmplan.scene.schema import SCHEMA

    defaults = _defaults(scenario_from_dict({}))
    out = [
        "# Scenario files",
        "",
        "Generated by `rcmplan scenario --schema` from the validator's schema",
        "(`rcmplan.scene.schema.SCHEMA`, `rcmplan.control.qp_limits.EXTRA_KEYS`); a test keeps",
        "this page equal to the generator's output. Keys carry their unit; values are converted",
        "to SI on load. A key outside this list, or a value outside its range, is an error that",
        "names the key and the allowed values (`true` and `false` are not numbers). Defaults are",
        "those of a scenario parsed from an empty file. `rcmplan scenario --show NAME` prints a",
        "shipped scenario's file. Shipped scenarios: "
        + ", ".join(f"`{n}`" for n in scenario_names())
        + ".",
    ]
    for section in SCHEMA:
        title = "Top level" if section == "" else f"[{section}]"
        out += ["", f"## {title}", ""]
        if section == "qp":
            out += ["Options of the `qp` method. The meanings quote `QpLimits`, which holds SI",
                    "values; the file gives each in the unit its key names.", ""]  # fmt: skip
        out += HEAD
        out += qp_rows() if section == "qp" else section_rows(section, defaults)
    return "\n".join(out) + "\n"


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `scenario` subcommand."""
    p = sub.add_parser(
        "scenario", help="the scenario file format and the shipped scenarios",
        description="Print the scenario file format generated from the validator (--schema, "
        "Markdown), list the shipped scenarios (--list, the default), or print one's TOML "
        "file (--show NAME: `rcmplan scenario --show default > mine.toml`, edit, then "
        "`rcmplan inject --scenario mine.toml`).",
    )  # fmt: skip
    p.add_argument("--schema", action="store_true", help="print the file format (Markdown)")
    p.add_argument("--list", action="store_true", help="list the shipped scenarios")
    p.add_argument("--show", metavar="NAME", help="print the TOML file of a shipped scenario")
    p.add_argument("--json", action="store_true", help="print the list as JSON")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Print the schema, a shipped scenario's file, or the list of scenarios."""
    if args.show is not None:
        print(shipped_text(args.show), end="")
        return 0
    if args.schema:
        print(schema_markdown(), end="")
        return 0
    from rcmplan.scene.scenario import load_scenario

    rows = []
    for name in scenario_names():
        sc = load_scenario(name)
        rows.append({"name": name, "procedure": sc.procedure, "method": sc.method,
                     "plant": sc.plant})  # fmt: skip
    if args.json:
        from rcmplan.cli.output import print_json

        print_json(rows)
        return 0
    from rcmplan.cli.output import table

    print(table(["name", "procedure", "method", "plant"], [list(r.values()) for r in rows]))
    return 0
