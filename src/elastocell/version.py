"""The package version, in one place (``elastocell.__version__``, run metadata, cache entries)."""

__version__ = "0.1.0"
