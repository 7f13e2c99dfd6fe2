"""A session's outputs in a folder: the run log (log.npz, log.csv), the pipeline's trace
(teleop.npz), summary.json and the figures (figures/*.png), each file written atomically."""

from __future__ import annotations

import json
from functools import partial
from pathlib import Path

from rcmplan._atomic import write_text
from rcmplan.analysis.report import jsonable, prepare_folder, write_log
from rcmplan.exceptions import OutputError
from rcmplan.teleop.run import TeleopResult
from rcmplan.teleop.summary import summary


def write_summary(result: TeleopResult, out: Path, csv: bool = True) -> dict[str, object]:
    """The log, the trace and summary.json (first, so an early stop still leaves them);
    without `csv` (an interrupted session) no log.csv, as `analysis.report.write_summary`."""
    about_log = write_log(result.log, out, csv)
    extra = {} if result.intended is None else {"intended": result.intended}
    result.trace.save_npz(out / "teleop.npz", **extra)
    doc = jsonable({**summary(result), **about_log})
    write_text(out / "summary.json", json.dumps(doc, indent=2))
    return dict(doc)


def write_figures(result: TeleopResult, out: Path) -> dict[str, Path]:
    """The four figures in out/figures, drawn side by side where possible."""
    from rcmplan.analysis import style
    from rcmplan.analysis.parallel import run_jobs
    from rcmplan.teleop.plots import FIGURES

    if len(result.log) < 2:
        return {}
    figs = out / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    style.plt()  # import matplotlib once, before any fork
    jobs = [(figs / f"{name}.png", partial(draw, result, figs / f"{name}.png"))
            for name, draw in FIGURES.items()]  # fmt: skip
    return dict(zip(FIGURES, run_jobs(jobs), strict=True))


def write_outputs(
    result: TeleopResult, out: str | Path, figures: bool = True
) -> tuple[dict[str, object], dict[str, Path]]:
    """Everything for a session in `out`: (the summary, the figure paths). A file that cannot
    be written raises OutputError naming it."""
    folder = prepare_folder(out)
    try:
        doc = write_summary(result, folder)
        made = write_figures(result, folder) if figures else {}
    except OSError as exc:
        raise OutputError(exc.filename or folder, exc.strerror or str(exc)) from exc
    return doc, made
