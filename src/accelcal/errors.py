"""Exceptions raised for bad input.

Every error that a user can cause with bad input (a value, a file, an
option) is an :class:`AccelcalError`. Its message names what was wrong and
how to fix it; the command line prints it on one line and exits with
status 2.
"""


class AccelcalError(ValueError):
    """Bad input: a value, file or option that accelcal cannot use.

    Subclass of :class:`ValueError`, so library callers that already catch
    ``ValueError`` keep working.
    """


class ModelFileError(AccelcalError):
    """A model file that cannot be read: missing, malformed or of an unknown format."""
