"""Measuring a run and showing it: metrics, figures, the HTML report."""
