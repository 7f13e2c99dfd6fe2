"""One number formatter for everything a person reads: tables, the report, error lines.

`fmt` prints a value converted from SI to a display unit with three significant digits, plain
between 0.001 and 99,999, in scientific notation outside; `fmt_setting` prints a setting as it
was meant (six significant digits, so 0.00045000000000000004 reads 0.00045).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

# display unit -> factor from SI
FACTORS = {
    "m": 1.0, "mm": 1e3, "um": 1e6, "nm": 1e9,
    "rad": 1.0, "mrad": 1e3, "urad": 1e6, "deg": 180.0 / math.pi,
    "s": 1.0, "ms": 1e3, "us": 1e6, "": 1.0,
}  # fmt: skip


def fmt(value: float | None, unit: str = "", digits: int = 3, with_unit: bool = False) -> str:
    """value (SI) in `unit` with `digits` significant digits; "-" for None or NaN."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if unit not in FACTORS:
        raise KeyError(f"unknown display unit {unit!r}; known: {sorted(FACTORS)}")
    v = float(value) * FACTORS[unit]
    text = _sig(v, digits)
    return f"{text} {unit}" if with_unit and unit else text


def _sig(v: float, digits: int) -> str:
    if v == 0.0 or not math.isfinite(v):
        return "0" if v == 0.0 else str(v)
    if 1e-3 <= abs(v) < 1e5:
        decimals = max(0, digits - 1 - math.floor(math.log10(abs(v))))
        return f"{v:,.{decimals}f}"
    mantissa, exponent = f"{v:.{digits - 1}e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def fmt_setting(value: object) -> str:
    """A setting as text: floats to 6 significant digits, sequences comma-separated."""
    if isinstance(value, bool) or value is None:
        return {True: "yes", False: "no", None: "-"}[value]
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, str):
        return value
    if isinstance(value, Iterable):
        return ", ".join(fmt_setting(v) for v in value)
    return str(value)
