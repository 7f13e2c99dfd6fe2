"""One package base error and specific subclasses that keep their data as attributes.

Every message names the offending value and, where one exists, the valid range or choices.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable
from typing import Any


class RcmplanError(Exception):
    """Base class of every error raised by rcmplan.

    Attributes:
        log: The run log up to the failure when the error stopped a run (a RunLog), else None.
        status: The machine-readable status a run stopped by this error reports (summary.json
            `status`; each subclass names its own, e.g. "rcm_bound_exceeded").
    """

    status = "error"
    log: Any = None


class InvalidInputError(RcmplanError, ValueError):
    """A value is non-finite, of the wrong shape, or outside its valid range.

    Attributes:
        name: What the value is (argument or key name).
        value: The offending value.
        valid: A human-readable statement of the valid range or choices.
    """

    status = "invalid_input"

    def __init__(self, name: str, value: Any, valid: str) -> None:
        self.name = name
        self.value = value
        self.valid = valid
        super().__init__(f"{name} = {_short(value)} is invalid; valid: {valid}")


class PlanTooLargeError(InvalidInputError):
    """A procedure would plan more targets than a run allows (step sizes far below the path's
    length); refused before any motion and before the targets are allocated."""

    status = "plan_too_large"


class UnknownJointTypeError(InvalidInputError):
    """A DH link names a joint type other than 'revolute' or 'prismatic'."""


class PcjmAngleError(InvalidInputError):
    """A PCJM angle has no slider difference (|q| >= pi/2), or a slider pair has no angle."""


class ActuatorLimitError(RcmplanError):
    """An actuator command or configuration lies outside its travel.

    Attributes:
        index: Actuator index (iRAM!S: in s = (L1, L2, L3, L4, L5, q5); an arm: the joint).
        slider: The actuator's name.
        value: Commanded value in m or rad.
        lower, upper: The travel limits.
    """

    status = "actuator_limit"

    def __init__(
        self, index: int, name: str, value: float, lower: float, upper: float,
        kind: str = "slider", unit: str | None = None,
    ) -> None:  # fmt: skip
        self.index = index
        self.slider = name
        self.value = value
        self.lower = lower
        self.upper = upper
        unit = unit or ("rad" if name == "q5" else "m")
        super().__init__(
            f"{kind} {name} = {value:.6g} {unit} is beyond its travel "
            f"[{lower:.6g}, {upper:.6g}] {unit}"
        )


SliderLimitError = ActuatorLimitError  # iRAM!S's actuators are its piezo sliders


class RcmBoundError(RcmplanError):
    """The RCM left its bound: the needle point at lambda moved farther from the trocar than the
    run allows.

    Attributes:
        phase: The phase in which it happened.
        deviation: The largest distance in [m] from the trocar in that phase.
        bound: The bound in [m].
    """

    status = "rcm_bound_exceeded"

    def __init__(self, phase: str, deviation: float, bound: float) -> None:
        self.phase = phase
        self.deviation = deviation
        self.bound = bound
        super().__init__(
            f"RCM bound exceeded in phase {phase!r}: the RCM moved {1e6 * deviation:.3f} um "
            f"from the trocar, beyond the bound of {1e6 * bound:.3f} um"
        )


class SingularPoseError(RcmplanError):
    """A configuration is at or near the singular set cos(q1) = 0 or cos(q3) = 0.

    Attributes:
        q: The joint vector.
        measure: min(|cos q1|, |cos q3|).
        threshold: The smallest accepted measure.
    """

    status = "singular_pose"

    def __init__(
        self, q: Any, measure: float, threshold: float, name: str = "min(|cos q1|, |cos q3|)"
    ) -> None:
        self.q = q
        self.measure = measure
        self.threshold = threshold
        super().__init__(
            f"pose is singular: {name} = {measure:.3g} is below the "
            f"threshold {threshold:.3g} (q = {_short(q)})"
        )


class UnreachableTargetError(RcmplanError):
    """A target cannot be reached: lambda outside [0, 1], needle angle or slider travel exceeded.

    Attributes:
        reason: Which condition failed, with the numbers.
        target: The target as stated by the user.
        stated: How the message states the target (default: its numbers, in the robot base
            frame for an X_ext target), or None.
    """

    status = "unreachable_target"

    def __init__(self, reason: str, target: Any = None, stated: str | None = None) -> None:
        self.reason = reason
        self.target = target
        if stated is None and target is not None:
            stated = f"target {_short(target)}"
        self.stated = stated
        super().__init__(self._message())

    def _message(self) -> str:
        return f"target unreachable: {self.reason}" + (f" ({self.stated})" if self.stated else "")

    def restated(
        self, reason: str | None = None, stated: str | None = None
    ) -> UnreachableTargetError:
        """A copy of this refusal (its class, target, log, cause and other attributes) with
        another reason and/or another statement of its target in the message (`stated`: for
        example its tip in the eye frame where the base frame's numbers would stand)."""
        out = copy.copy(self)
        out.reason = self.reason if reason is None else reason
        out.stated = self.stated if stated is None else stated
        out.args = (out._message(),)
        out.__cause__ = self.__cause__
        return out


class ConvergenceError(RcmplanError):
    """A control loop hit its iteration cap before every task component met its tolerance.

    Attributes:
        iterations: Iterations spent on the failing step.
        error: The task error at the last iteration.
        tolerance: The tolerance per component.
        log: The run log up to the failure (a RunLog), or None.
    """

    status = "no_convergence"

    def __init__(
        self, iterations: int, error: Any, tolerance: Any, log: Any = None, where: str = ""
    ) -> None:
        self.iterations = iterations
        self.error = error
        self.tolerance = tolerance
        if log is not None:
            self.log = log
        at = f" in {where}" if where else ""
        super().__init__(
            f"no convergence{at} after {iterations} iterations: |error| = {_short(error)} "
            f"exceeds tolerance {_short(tolerance)}"
        )


class ScenarioError(InvalidInputError):
    """A scenario file is malformed: the message names the key and the allowed values."""

    status = "invalid_scenario"


class QPError(RcmplanError):
    """A QP solve failed or was infeasible.

    Attributes:
        problem: The QP that was solved (an rcmplan.control.qp.QPProblem).
        result: The solver's raw result, if any.
    """

    status = "qp_failed"

    def __init__(self, message: str, problem: Any = None, result: Any = None) -> None:
        self.problem = problem
        self.result = result
        super().__init__(message)


class SimulationError(RcmplanError):
    """A simulation became unstable (NaN, loop-closure gap or RCM deviation past a bound)."""

    status = "simulation_unstable"


class OutputError(RcmplanError):
    """An output file cannot be written (a full disk, a read-only folder).

    Attributes:
        path: The file or folder.
        reason: The system's reason.
    """

    status = "output_failed"

    def __init__(self, path: Any, reason: str) -> None:
        self.path = path
        self.reason = reason
        super().__init__(f"cannot write {str(path)!r}: {reason}")


class MissingExtraError(RcmplanError, ImportError):
    """An optional dependency is missing; the message names the extra to install."""

    status = "missing_extra"

    def __init__(self, package: str, extra: str) -> None:
        self.package = package
        self.extra = extra
        super().__init__(f"{package} is required for this feature: pip install 'rcmplan[{extra}]'")


def _short(value: Any) -> str:
    """value on one line: numbers to 3 significant digits, arrays and sequences as (a, b, c)."""
    text = _one_line(value)
    return text if len(text) <= 200 else text[:197] + "..."


def _one_line(value: Any, digits: int = 6) -> str:
    """A float to `digits` significant digits (keeping a decimal point: 40.0, not 40), arrays
    and sequences as (a, b, c) with 3 significant digits each, anything else as its repr."""
    if hasattr(value, "tolist") and not isinstance(value, str | bytes):
        value = value.tolist()
    if isinstance(value, float):
        text = f"{value:.{digits}g}"
        return text if any(c in text for c in ".enia") else text + ".0"
    if isinstance(value, list | tuple):
        return "(" + ", ".join(_one_line(v, 3) for v in value) + ")"
    return " ".join(repr(value).split())


def require_extra(module: str, extra: str) -> Any:
    """Import an optional module, or raise MissingExtraError naming the extra. An interrupt
    that cut the import (raised as an ImportError by the extension's initialisation) is raised
    as the interrupt, not as a missing extra."""
    import importlib

    from rcmplan._signals import wrapped_interrupt

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        interrupt = wrapped_interrupt(exc)
        if interrupt is not None:
            raise interrupt from None
        raise MissingExtraError(module.split(".")[0], extra) from exc


class ModelFileError(RcmplanError):
    """A robot model file (URDF, MJCF) cannot be read.

    Attributes:
        path: The file as given.
        reason: The parser's reason.
    """

    status = "invalid_model_file"

    def __init__(self, path: Any, reason: str) -> None:
        self.path = path
        self.reason = reason
        super().__init__(f"cannot load robot model file {str(path)!r}: {reason}")


class UnknownFrameError(InvalidInputError):
    """A frame (link, body or site) is not in the model.

    Attributes:
        frame: The name asked for.
        frames: The frames that exist.
    """

    def __init__(self, name: str, frame: str, frames: Any) -> None:
        self.frame = frame
        self.frames = tuple(frames)
        super().__init__(name, frame, "one of " + ", ".join(self.frames))


class UnsupportedJointError(InvalidInputError):
    """A joint on a chain's path is neither revolute, prismatic nor fixed (mimic, floating...).

    Attributes:
        joint: The joint name.
        kind: Its type as the model file states it.
    """

    def __init__(self, joint: str, kind: str) -> None:
        self.joint = joint
        self.kind = kind
        valid = "revolute, continuous, prismatic or fixed joints (no mimic) on the chain's path"
        super().__init__(f"joint {joint!r} type", kind, valid)


class RunFolderError(RcmplanError):
    """A folder or file given to `rcmplan view` is not a run rcmplan can show: not a run
    folder, a log written by another version, a truncated or damaged file.

    Attributes:
        path: The folder or file at fault.
        reason: What is wrong with it and what a run folder holds.
    """

    status = "invalid_run_folder"

    def __init__(self, path: Any, reason: str) -> None:
        self.path = path
        self.reason = reason
        super().__init__(f"cannot show {str(path)!r}: {reason}")


class PortInUseError(RcmplanError):
    """A server cannot listen on a port another program (another viewer) holds.

    Attributes:
        host: The address asked for. port: The port asked for.
    """

    status = "port_in_use"

    def __init__(self, host: str, port: int, reason: str = "") -> None:
        self.host = host
        self.port = port
        why = f" ({reason})" if reason else ""
        super().__init__(
            f"port {port} on {host} is in use{why}: is another viewer running? "
            f"Stop it or choose another port with --port (1024-65535, or 0 for any free port)"
        )


class InputStreamError(InvalidInputError):
    """A master input stream (a replay file, a live sample) is malformed: the message names
    the source, the row and the value, and what is valid.

    Attributes:
        source: The file (or "live input").
        row: Index of the offending data row (0-based, header excluded), or None for the
            file as a whole (a missing column).
        column: The column (or key) the value is in.
    """

    status = "invalid_input_stream"

    def __init__(self, source: str, row: int | None, column: str, value: Any, valid: str) -> None:
        self.source = source
        self.row = row
        self.column = column
        where = f"{source}: row {row} {column}" if row is not None else f"{source}: {column}"
        super().__init__(where, value, valid)


class RobotFileError(InvalidInputError):
    """A robot file (TOML) is malformed or describes an arm rcmplan cannot drive: the message
    names the file, the key and the offending value (a frame, a joint's value and limits, a
    count) and what is valid.

    Attributes:
        path: The robot file.
        key: The key of its [robot] table at fault ("" for the file as a whole).
    """

    status = "invalid_robot_file"

    def __init__(self, path: Any, key: str, value: Any, valid: str, name: str = "") -> None:
        self.path = path
        self.key = key
        name = name or (f"[robot] {key}" if key else "")  # what `value` is, in the file
        where = f"robot file {str(path)!r}" + (f": {name}" if name else "")
        super().__init__(where, value, valid)


class NoHomeFoundError(RobotFileError):
    """A robot file gives no home and the search finds no pose within the joint limits with
    the needle horizontal and the arm away from its singular set."""

    status = "no_home_found"


def did_you_mean(word: Any, valid: Iterable[str]) -> str:
    """The suggestion "; did you mean X?" for the closest of `valid` to `word` (leading dashes
    aside), or "" when none is close (or `word` is not a string): for messages that list the
    valid names."""
    import difflib

    if not isinstance(word, str):
        return ""
    names = {v.lstrip("-"): v for v in valid}
    close = difflib.get_close_matches(word.lstrip("-"), list(names), n=1, cutoff=0.6)
    return f"; did you mean {names[close[0]]}?" if close else ""
