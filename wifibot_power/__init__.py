"""wbpower: energy models of a mobile robot from power-analyser logs, and where they go wrong."""

__version__ = "0.1.0"
