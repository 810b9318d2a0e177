"""The ``accelcal`` command.

:func:`main` runs the typer application with accelcal's error policy: bad
input (an :class:`~accelcal.errors.AccelcalError` or a usage error) prints
one line, ``accelcal: error: ...``, on standard error and exits with
status 2, with no traceback; so does any failure of the system to read or
write a file (an :class:`OSError`: the line names the file). SIGINT, SIGTERM
and SIGHUP end a run with one line and the status ``128 + signal``
(:mod:`accelcal.cli.signals`), at any moment from start-up on; once its
work is over and its outputs are written, by the signal's default action. Command
modules import numpy-heavy code inside their functions so that
``accelcal --help`` starts quickly.
"""

import sys

OPTION_NAMES: dict[str, str] = {
    "rotation_axis": "--axis",  # accelcal tumble
    "angles_rad": "--angles",  # accelcal tumble identify
    "one_g": "--with",  # accelcal centrifuge reduce
    "values": "FILE",
    "rows": "--block-rows",  # accelcal import  # the samples of a recording (accelcal noise, triad)
}
"""Library parameter -> command-line option, where the option is not ``--`` plus the
parameter's name with ``-`` for ``_`` (see :meth:`accelcal.errors.AccelcalError.message_for`)."""


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``accelcal`` console script."""
    from accelcal.cli import signals

    try:
        signals.install()
        code = _run(argv)
    except KeyboardInterrupt as exc:
        _interrupted(getattr(exc, "signum", None) or signals.received() or 2)
    except BrokenPipeError:
        sys.exit(0)
    except Exception:
        if signals.received() is None:
            raise
        _interrupted(signals.received())  # an interrupt an import wrapped in its own error
    if signals.received():  # a signal a library took for its own and did not raise
        _interrupted(signals.received())
    signals.done()
    sys.exit(code if isinstance(code, int) else 0)


def _run(argv: list[str] | None):
    """Run the command; every failure but an interrupt becomes one line and exit status 2."""
    import typer

    from accelcal.cli import signals
    from accelcal.cli.app import app

    try:
        command = typer.main.get_command(app)
        return command.main(args=argv, prog_name="accelcal", standalone_mode=False)
    except typer.Abort as exc:  # click's wrapping of KeyboardInterrupt (our Interrupted)
        cause = exc.__context__
        raise cause if isinstance(cause, KeyboardInterrupt) else KeyboardInterrupt() from None
    except Exception as exc:
        if signals.received() is not None:  # an interrupt a library wrapped in its own error
            raise KeyboardInterrupt from None
        _fail(exc)
    return None


def _fail(exc: Exception) -> None:
    """One line and exit status 2 for a failure of the command (re-raise what is a bug)."""
    from accelcal.errors import AccelcalError

    if isinstance(exc, AccelcalError):
        _die(exc.message_for(OPTION_NAMES))
    if isinstance(exc, BrokenPipeError):
        raise exc
    if isinstance(exc, OSError):  # a net behind the checks made before writing or reading
        _die(_os_error(exc))
    if isinstance(exc, MemoryError):  # a net behind the size estimates made before allocating
        _die("not enough memory for this input on this machine; give fewer samples, "
             "positions or points")
    if isinstance(exc, RecursionError):  # a net behind the depth checks of nested input
        _die("the input nests too deeply to be read; is it the right file?")
    if type(exc).__name__ == "LinAlgError":  # numpy.linalg: a net behind the validation
        _die(f"the computation failed ({exc}); the input's values are probably far out of "
             "range: check their magnitudes and units")
    # Usage and parameter errors of the (possibly vendored) click layer
    # under typer: recognised by their interface, not their class.
    if not (hasattr(exc, "format_message") and hasattr(exc, "exit_code")):
        raise exc
    if not exc.format_message().strip():
        # A group called without a command: its help was printed already.
        sys.exit(exc.exit_code)
    ctx = getattr(exc, "ctx", None)
    hint = f" (see '{ctx.command_path} --help')" if ctx is not None else ""
    _die(exc.format_message() + hint)


def _os_error(exc: OSError) -> str:
    """One line of a failed file operation: the file (when known) and what to do."""
    from accelcal.io.atomic import write_error

    if exc.filename is not None:
        return write_error(exc.filename, exc).args[0].replace("cannot write", "cannot use", 1)
    return f"a file operation failed: {exc.strerror or exc}"


def _interrupted(signum: int) -> None:
    from accelcal.cli import signals

    signals.finish(signum)
    sys.exit(signals.exit_status(signum))


def _die(message: str) -> None:
    """Print ``message`` as one ``accelcal: error:`` line and exit with status 2.

    Whitespace runs (line breaks included) become one space, and a message
    longer than :data:`accelcal.validation.MAX_MESSAGE_LENGTH` characters is
    cut, keeping its start and end around an ellipsis: a backstop behind the
    messages that quote values shortened, so no input can make the line
    unbounded.
    """
    from accelcal.validation import MAX_MESSAGE_LENGTH

    one_line = " ".join(message.split())
    if len(one_line) > MAX_MESSAGE_LENGTH:
        head = MAX_MESSAGE_LENGTH * 4 // 5
        tail = MAX_MESSAGE_LENGTH - head - 5
        one_line = f"{one_line[:head]} ... {one_line[-tail:]}"
    print(f"accelcal: error: {one_line}", file=sys.stderr)
    sys.exit(2)
