"""How the command line's help shows an option: a flag shows no value type.

typer's rich help prints the type of every option beside its name, flags
included (``--summary <bool>``), although a flag takes no value; its plain
help leaves flags bare. :func:`bare_flags` makes the rich help agree, for
every command and for ``--help`` and ``--version`` themselves.
"""

from typer.core import TyperOption


def bare_flags() -> None:
    """Make the rich help show no type for flags and counters (idempotent)."""
    typed = TyperOption.display_type_rich
    if getattr(typed, "bare_flags", False):
        return

    def display_type_rich(self, ctx):
        if (self.is_flag or self.count) and self.metavar is None:
            return None
        return typed(self, ctx)

    display_type_rich.bare_flags = True
    TyperOption.display_type_rich = display_type_rich
