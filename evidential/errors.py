"""Errors raised by the evidential engine; every one is a ``ValueError``."""


class EvidentialError(ValueError):
    """Base class of the engine's errors (a ``ValueError`` subclass)."""


class FrameError(EvidentialError):
    """A bad frame, an element not in the frame, or masses on different frames."""


class MassError(EvidentialError):
    """A bad mass value: negative, not finite, sums off 1, or not allowed by a rule."""


class TotalConflictError(EvidentialError):
    """The sources are in total conflict (K = 1): a normalized rule is undefined."""


class UndefinedTransformError(EvidentialError):
    """A transform undefined for this mass function: all of its mass is on the empty set (m(∅) = 1)."""
