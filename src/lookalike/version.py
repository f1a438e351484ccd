"""The package version (also ``lookalike.__version__``)."""

__version__ = "0.1.0"
