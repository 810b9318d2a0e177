"""Test methods: one package each (theory, reduction, Monte Carlo, figures).

Every method package under :mod:`accelcal.methods` returns a
:class:`~accelcal.results.Reduction` from its reductions and provides, for
the generic code paths (plots, reports), these names:

``figures(reduction, **context)``
    The method's figures, read from the Reduction's fields only: a list of
    ``(stem, title, matplotlib figure, caption)``.
``report_text(reduction)``
    A :class:`ReportText`: the report section's title and summary.
``ERRATA``
    Short corrections of the method's paper that a report shows, each with
    its entry in docs/errata.md.
``from_inputs(files, record)``
    Where the method writes calibration records: candidate reductions of
    the input files a ``record`` names (found by their SHA-256, in the
    record's order), as ``(reduction, context)`` pairs with the settings the
    record and the files determine, else those of ``accelcal demo`` and of
    the method's command by default; :func:`accelcal.report.rebuild.rebuild`
    keeps the first that reproduces the record.

:data:`REGISTRY` maps a Reduction's ``family`` to its package; it is
derived from the methods' descriptors (:data:`accelcal.catalog.METHODS`),
where a new method is named once.
"""

import importlib
from dataclasses import dataclass

from accelcal.catalog import families

REGISTRY = families()
"""Method family -> package (imported on first use)."""


@dataclass(frozen=True)
class ReportText:
    """What a report says about a reduction, besides its numbers.

    Attributes
    ----------
    title : str
        Section title (the serial number is prefixed per sensor).
    summary : str
        One paragraph: the test and how it was reduced.
    sensor_summary : str
        One sentence for each sensor's own section (the model fitted).
    paper : str
        Key of the paper whose errata apply (``""`` for none).
    """

    title: str
    summary: str
    sensor_summary: str = ""
    paper: str = ""


def package(family: str):
    """The method package of ``family`` (imported lazily).

    Raises
    ------
    KeyError
        For a family that is not in :data:`REGISTRY`.
    """
    return importlib.import_module(REGISTRY[family])


def figures_of(reduction, **context) -> list:
    """The figures of a reduction, from its method package."""
    return package(reduction.family).figures(reduction, **context)


def report_text_of(reduction) -> ReportText:
    """The report text of a reduction, from its method package."""
    return package(reduction.family).report_text(reduction)


def errata_of(reduction) -> tuple[str, ...]:
    """The errata a report shows beside a reduction."""
    return tuple(package(reduction.family).ERRATA)
