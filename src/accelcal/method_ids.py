"""Method ids: one pattern, ``<family>/<route>``, and the ids records carried before.

A reduction's ``method`` names its family (the method package) and the route
it took: ``"dividing-head/joint"``, ``"tumble/fourier"``, ``"transverse/2w"``,
``"vre/identify"``, ``"triad/gravity-norm"``, ``"noise/ieee952-fit"``,
``"thermal/wls"``, ``"centrifuge/lsq"``. Records and stores written before the
pattern carry older ids (``"tumble-fourier"``, ``"ieee952-fit"``...):
:data:`ALIASES` maps each to its id today, and every reader (calibration
records, the store's rows and its ``method`` filter) goes through
:func:`canonical` and :func:`spellings`, so old and new files read alike.

This module imports nothing: io, the store and the methods all use it.

Examples
--------
>>> canonical("tumble-fourier"), canonical("tumble/fourier")
('tumble/fourier', 'tumble/fourier')
>>> spellings("noise/ieee952-fit")
('noise/ieee952-fit', 'ieee952-fit')
"""

ALIASES = {
    "tumble-fourier": "tumble/fourier",
    "tumble-lsq": "tumble/lsq",
    "transverse-2w": "transverse/2w",
    "transverse-dc": "transverse/dc",
    "transverse-both": "transverse/both",
    "transverse-w": "transverse/w",
    "vre-identify": "vre/identify",
    "ieee952-fit": "noise/ieee952-fit",
    "noise-run-to-run": "noise/run-to-run",
    "thermal-wls": "thermal/wls",
}
"""Old method id -> its id today (``<family>/<route>``)."""


def canonical(method: str) -> str:
    """The id today of ``method`` (an old id mapped by :data:`ALIASES`, else itself)."""
    return ALIASES.get(method, method)


def spellings(method: str) -> tuple[str, ...]:
    """Every id a record of ``method`` may carry: its id today first, then the old ones."""
    new = canonical(method)
    return (new, *(old for old, today in ALIASES.items() if today == new))


def route_of(method: str) -> str:
    """The route of a method id: ``dividing-head/joint`` -> ``joint`` (old ids mapped first)."""
    return canonical(method).partition("/")[2]
