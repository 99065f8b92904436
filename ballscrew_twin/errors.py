"""The package's error hierarchy: one base class, one narrow class per failure kind."""


class BallscrewTwinError(Exception):
    """Base class of every error raised on purpose by ballscrew_twin."""


class ConfigError(BallscrewTwinError, ValueError):
    """A parameter file or value is missing, malformed, non-finite or out of range."""


class OperatingPointError(BallscrewTwinError, ValueError):
    """An operating point (speed, temperature, preload, load) is invalid."""


class SolverError(BallscrewTwinError, RuntimeError):
    """A numerical solve did not converge; the message says which and why."""
