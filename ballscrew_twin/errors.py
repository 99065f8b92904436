"""The package's error hierarchy: one base class, one narrow class per failure kind."""


class BallscrewTwinError(Exception):
    """Base class of every error raised on purpose by ballscrew_twin."""


class ConfigError(BallscrewTwinError, ValueError):
    """A parameter file or value is missing, malformed, non-finite or out of range."""


class OperatingPointError(BallscrewTwinError, ValueError):
    """An operating point (speed, temperature, preload, load) is invalid."""


class SolverError(BallscrewTwinError, RuntimeError):
    """A numerical solve did not converge; the message says which and why."""


class MapError(BallscrewTwinError, ValueError):
    """A steady map is invalid: missing, corrupt, of another format or another parameter set."""


class SampleError(BallscrewTwinError, ValueError):
    """A bench sample is not finite."""


class StampOrderError(SampleError):
    """A sample's stamp is earlier than the last one of its signal (clock jump, restart)."""


class BagError(BallscrewTwinError, ValueError):
    """A bag cannot be read or lacks what is needed; the message names the path and the topic."""


class SweepError(BallscrewTwinError, ValueError):
    """A sweep specification is invalid, or the cluster cannot be reached."""


class ResultsError(BallscrewTwinError):
    """An output could not be written (missing message definitions, unwritable path, ...)."""


class NonFiniteOutputError(SolverError):
    """A model returned a NaN or infinite number; the message names the quantity."""


class FidelityError(BallscrewTwinError, ValueError):
    """No model can serve what was asked: none meets a scene's tolerance, the bounds file is
    unusable, or the fidelity a node was given cannot be built here."""


class BuildCancelledError(BallscrewTwinError):
    """A table build was stopped on purpose (the node that started it is shutting down)."""


class MessageEncodingError(BallscrewTwinError, ValueError):
    """A value does not fit its ROS message field (type, range, array shape, text)."""


class ReplayError(BallscrewTwinError, ValueError):
    """Invalid replay request (rate, topics) or a bag that cannot be played."""


class RecordError(BallscrewTwinError, ValueError):
    """Invalid recording request (topic, type, output) or a bag that cannot be written."""
