"""What the commands print and write at their end: tables, JSON, progress bars, the outputs
of a run stopped early, and the last lines of a run command."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rcmplan.cli import interrupts

if TYPE_CHECKING:
    from rcmplan.analysis.result import RunResult
    from rcmplan.control.phase import Phase


class _NoBar:
    """Stands in for a tqdm bar when tqdm (extra "progress") is not installed."""

    def reset(self, total: int | None = None) -> None:
        """Nothing to show."""

    def update(self, n: int = 1) -> None:
        """Nothing to show."""

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        """Nothing to show."""


@contextlib.contextmanager
def progress_bar(label: str, unit: str, total: int | None = None) -> Iterator[Any]:
    """A tqdm bar on stderr that appears after about a second, only on a terminal."""
    try:
        from tqdm import tqdm
    except ImportError:
        yield _NoBar()
        return
    tqdm.monitor_interval = 0  # no monitor thread: the figures may be drawn in forked processes
    bar = tqdm(total=total, desc=label, unit=unit, delay=1.0, file=sys.stderr, leave=False,
               disable=not sys.stderr.isatty())  # fmt: skip
    try:
        yield bar
    finally:
        bar.close()


@contextlib.contextmanager
def progress(label: str, total: int | None = None) -> Iterator[Callable[[Phase], None]]:
    """A progress bar over phases: yields the function to call with each finished phase."""
    with progress_bar(label, "phase", total) as bar:

        def tick(phase: Phase) -> None:
            bar.set_postfix_str(phase.name, refresh=False)
            bar.update(1)

        yield tick


def write_stopped(
    out: Path, args: argparse.Namespace, status: str, message: str, result: RunResult | None = None
) -> None:
    """Outputs of a run command stopped before it finished (interrupted, or a bad scenario):
    the partial log (an interrupted run's without log.csv: `report.write_summary`) and
    summary.json with `status` and `message` when a result exists, else
    the command's stop file alone (`interrupts.write_stop_file`: no log of an earlier run left
    beside it). Signals are ignored meanwhile, and every file is written atomically."""
    from rcmplan.analysis.report import write_summary

    with interrupts.shielded():
        if result is not None:
            stopped = replace(result, status=status, message=message, command=args.command)
            write_summary(stopped, out, csv=status != "interrupted")
            return
        doc = {"status": status, "message": one_line(message)}
        if getattr(args, "scenario", None):
            doc = {"scenario": args.scenario, **doc}
        interrupts.write_stop_file(out, args.command, doc)


def interrupted_message(exc: BaseException, where: str) -> str:
    """ "interrupted by SIGTERM <where>"."""
    return f"interrupted by {interrupts.signal_name(exc)} {where}".strip()


def print_summary(result: RunResult) -> None:
    """A per-phase table of the run's figures, then the lines report.html also carries
    (`analysis.summary_text`)."""
    from rcmplan.analysis.report_html import PHASE_HEAD, phase_rows
    from rcmplan.analysis.summary_text import summary_lines

    s = result.summary()
    print(f"scenario {s['scenario']}  procedure {s['procedure']}  method {s['method']}  "
          f"plant {s['plant']}  status {s['status']}")  # fmt: skip
    print(table(list(PHASE_HEAD), phase_rows(s)))
    print("\n".join(summary_lines(s)))


def one_line(text: str) -> str:
    """text with every run of whitespace (newlines too) as one space."""
    return " ".join(str(text).split())


def print_json(obj: Any) -> None:
    """JSON to stdout."""
    from rcmplan.analysis.report import jsonable

    print(json.dumps(jsonable(obj), indent=2))


def table(header: list[str], rows: list[list[Any]]) -> str:
    """A plain-text table with aligned columns."""
    rows = [[str(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    line = "  ".join("-" * w for w in widths)
    fmt = "  ".join("{:<" + str(w) + "}" for w in widths)
    return "\n".join([fmt.format(*header), line, *(fmt.format(*r) for r in rows)])


def finish(args: argparse.Namespace, out: Path, doc: Any, show: Callable[[], None],
           failure: str | None, code: int = 1) -> int:  # fmt: skip
    """The end of a run command whose outputs are written: they are final (a late signal
    leaves them as they are; a command with its own interrupt handling declares them final
    inside it, `interrupts.finished()`, so that no signal falls between), the JSON or the table
    and the folder on stdout, and exit `code` (1: stopped early; 2: refused before motion) with
    `failure` on stderr if the run did not end ok."""
    interrupts.finished()
    if args.json:
        print_json(doc)
    else:
        show()
        print(f"outputs in {out}/")
    if failure:
        print(f"rcmplan {args.command}: {failure}", file=sys.stderr)
        return code
    return 0
