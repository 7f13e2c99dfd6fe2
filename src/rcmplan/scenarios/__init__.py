"""Scenario files shipped with rcmplan (TOML), loaded by name."""
