"""What a simulation or an analysis of sampled records may take: memory and randomness.

A record of ``n`` samples on ``c`` channels holds ``8 n c`` bytes as float64;
computing it takes a few such arrays at once. :func:`check_memory` estimates
the bytes a computation will hold (samples x channels x 8 bytes x a factor
the caller states from its temporaries) *before* allocating anything, and
refuses, with one line saying how much it would need, what exceeds half of
the memory this process can still take (:func:`available_memory`: its
address-space limit, its cgroup's limit, the machine's free memory). So a
sample rate of 1e12 Hz or a duration of 1e9 s ends at once with a message
instead of a numpy allocation error or a machine that swaps.

:func:`generator` turns a seed (a non-negative integer), a
``numpy.random.Generator`` or None into a generator, refusing negative or
non-integer seeds with a message that names the parameter.
"""

import math

import numpy as np

from accelcal.errors import AccelcalError

MEMORY_SHARE = 0.5
"""Share of the available memory a computation may take (the rest is for the
system, the other programs and what the estimate leaves out)."""

FLOAT_BYTES = 8
"""Bytes of one float64 sample."""


def available_memory() -> int:
    """Memory available to a new computation, bytes.

    The process's real limit (:func:`accelcal.io.limits.memory_limit`): the
    least of the headroom of its address-space limit (``RLIMIT_AS``), of its
    memory cgroup, and of the machine's ``MemAvailable``.
    """
    from accelcal.io.limits import memory_limit

    return memory_limit()


def shown_bytes(n: float) -> str:
    """A byte count for people: ``512 bytes``, ``3.1 MiB``, ``7.3 TiB``, ``8e+20 bytes``."""
    if not math.isfinite(n) or n >= 2**70:
        return f"{n:.3g} bytes"
    for unit, size in (("EiB", 2**60), ("PiB", 2**50), ("TiB", 2**40), ("GiB", 2**30),
                       ("MiB", 2**20), ("KiB", 2**10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} bytes"


def check_memory(samples: float, channels: float, factor: float, what: str, *,
                 parameter: str | None = None, hint: str = "") -> float:
    """Refuse a computation whose arrays would not fit in memory.

    Parameters
    ----------
    samples : float
        Samples per channel (may be a float: a product of user values is
        checked before it is rounded or allocated).
    channels : float
        Channels (records, angles, points, trials...) of that length.
    factor : float
        Arrays of ``samples x channels`` float64 the computation holds at
        its peak (temporaries included), as measured for it.
    what : str
        What would be computed, for the message (``"the vibrafuge records"``).
    parameter : str, optional
        The Python parameter to name in the error (the largest contributor).
    hint : str
        How to shrink the computation, appended to the message.

    Returns
    -------
    float
        The estimated bytes.

    Raises
    ------
    AccelcalError
        When the estimate exceeds :data:`MEMORY_SHARE` of
        :func:`available_memory` (or is not finite).
    """
    need = float(samples) * float(channels) * FLOAT_BYTES * float(factor)
    limit = MEMORY_SHARE * available_memory()
    if not (math.isfinite(need) and need <= limit):
        raise AccelcalError(
            f"{what} would need about {shown_bytes(need)} of memory "
            f"({float(samples):.3g} x {float(channels):.3g} values x 8 bytes x "
            f"{factor:g}); this process can take {shown_bytes(limit)}"
            + (f"; {hint}" if hint else ""),
            parameter=parameter,
        )
    return need


def generator(seed, parameter: str = "seed") -> np.random.Generator:
    """A random generator from a seed (integer >= 0), a SeedSequence, a Generator or None.

    A Generator is used as it is (its draws continue); None takes fresh entropy.

    Raises
    ------
    AccelcalError
        For a negative seed, or one that is not an integer.
    """
    if seed is None or isinstance(seed, np.random.Generator | np.random.SeedSequence):
        return np.random.default_rng(seed)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise AccelcalError(f"{seed!r} must be an integer >= 0, a numpy SeedSequence or "
                            "Generator (or none, for a fresh seed)",
                            parameter=parameter)
    return np.random.default_rng(int(seed))


def seeded(seed, rng=None) -> np.random.Generator | None:
    """The generator of a simulation taking ``seed=`` and the older alias ``rng=``.

    None when neither is given (a noise-free simulation); :func:`generator`
    of whichever is given.

    Raises
    ------
    AccelcalError
        When both are given, or for a seed :func:`generator` refuses.
    """
    if seed is not None and rng is not None:
        raise AccelcalError("give seed or its older alias rng, not both", parameter="rng")
    source = seed if rng is None else rng
    return None if source is None else generator(source)
