"""Exceptions raised for bad input.

Every error that a user can cause with bad input (a value, a file, an
option) is an :class:`AccelcalError`. Its message names what was wrong and
how to fix it. The library speaks of its own Python parameters: an error
about one parameter carries its name in :attr:`AccelcalError.parameter`
and the message reads ``parameter: ...``; the command line shows the same
message with the option that sets that parameter instead
(:meth:`AccelcalError.message_for`), prints it on one line and exits with
status 2.
"""


class AccelcalError(ValueError):
    """Bad input: a value, file or option that accelcal cannot use.

    Subclass of :class:`ValueError`, so library callers that already catch
    ``ValueError`` keep working.

    Parameters
    ----------
    message : str
        What was wrong and how to fix it (without the parameter's name).
    parameter : str, optional
        The Python parameter at fault (e.g. ``"serial"``, ``"workers"``).
    """

    def __init__(self, message: str, *, parameter: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.parameter = parameter

    def __str__(self) -> str:
        return f"{self.parameter}: {self.message}" if self.parameter else self.message

    def message_for(self, names: dict[str, str] | None = None) -> str:
        """The message naming the parameter as a caller knows it.

        ``names`` maps parameter names to what the caller calls them (the
        command line: ``{"record": "--record"}``); a parameter not in it is
        shown as ``--`` plus its name with ``-`` for ``_``.
        """
        if not self.parameter:
            return self.message
        shown = (names or {}).get(self.parameter, "--" + self.parameter.replace("_", "-"))
        return f"{shown}: {self.message}"


class ModelFileError(AccelcalError):
    """A model file that cannot be read: missing, malformed or of an unknown format."""
