"""The one number formatter: significant digits, units, settings without float noise."""

from __future__ import annotations

import math

import pytest

from rcmplan.analysis.units import fmt, fmt_setting


def test_values_keep_three_significant_digits_in_plain_notation() -> None:
    assert fmt(4.589e-7, "um") == "0.459"
    assert fmt(4.5e-7, "um") == "0.450"
    assert fmt(0.0918, "ms") == "91.8"
    assert fmt(1465.0) == "1,465"


def test_very_small_and_very_large_values_switch_to_scientific_notation() -> None:
    assert fmt(3.1031e-17, "um") == "3.10e-11"
    assert fmt(2.5e5) == "2.50e5"


def test_missing_values_print_as_a_dash() -> None:
    assert fmt(None, "um") == "-"
    assert fmt(math.nan, "um") == "-"


def test_the_unit_can_follow_the_number() -> None:
    assert fmt(0.45e-3, "um", with_unit=True) == "450 um"


def test_settings_print_without_float_noise() -> None:
    assert fmt_setting(0.45e-3 * 1e0) == "0.00045"
    assert fmt_setting(0.00045000000000000004) == "0.00045"
    assert fmt_setting((1.0, 10.0, 0.5)) == "1, 10, 0.5"
    assert fmt_setting(True) == "yes"


def test_an_unknown_display_unit_is_refused() -> None:
    with pytest.raises(KeyError, match="furlong"):
        fmt(1.0, "furlong")
