"""The package version, in one place (the package face and every output that records it)."""

__version__ = "0.1.0"
