"""Numbers as a person reads them: those printed with more significant digits than
`rcmplan.analysis.units.fmt` gives (three). Integers (counts, and fmt's values from 1,000 on,
which it rounds to units) are not checked."""

from __future__ import annotations

import re

NUMBER = re.compile(r"(?<![\w.])-?\d[\d,]*(?:\.\d+)?(?:e[+-]?\d+)?(?![\w.])")


def overlong(text: str, digits: int = 3) -> list[str]:
    """The numbers in text with a fraction or an exponent and more than `digits` significant
    digits."""
    found = []
    for token in NUMBER.findall(text):
        if "." not in token and "e" not in token:
            continue
        mantissa = token.split("e")[0].lstrip("-").replace(",", "").replace(".", "")
        if len(mantissa.lstrip("0")) > digits:
            found.append(token)
    return found
