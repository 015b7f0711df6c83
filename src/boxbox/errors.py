"""boxbox's errors: each maps to a one-line message and an exit status."""


class BoxboxError(Exception):
    """Base class: `str(err)` is the one line shown to the user."""

    exit_code = 1


class UsageError(BoxboxError, ValueError):
    """Bad input (unknown track, car, robot; invalid numbers): exit 2, before TORCS starts.

    Also a ValueError, as Python and Gymnasium raise for a bad argument: a caller (a learner's
    loop, a test) that catches ValueError around an env or `boxbox.race` call still catches it."""

    exit_code = 2


class SetupError(BoxboxError):
    """TORCS, its headers or the bridge could not be set up."""

    exit_code = 3


class RaceError(BoxboxError):
    """The race did not finish properly: a robot fault, TORCS dying, a timeout."""

    exit_code = 4


class Interrupted(RaceError):
    """The race was stopped by Ctrl-C or SIGTERM (its results so far are still written)."""

    exit_code = 130
