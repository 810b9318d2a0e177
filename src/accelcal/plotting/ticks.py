"""Log-axis tick labels as plain text (``10⁻³``), not math text (``$10^{-3}$``).

Matplotlib labels a log axis with math text, which every renderer parses
again (pyparsing, several milliseconds a label): on the Allan-deviation
figure that parsing was a third of the SVG rendering time. The same
labels written with Unicode superscripts need no parsing and read the
same. :func:`plain_log_labels` swaps matplotlib's default log formatters
of a figure for :class:`PlainLogFormatter` just before it is rendered
(:func:`accelcal.plotting.save_figure`, :func:`accelcal.report.figure_svg`);
a formatter a figure set itself is left alone.

References
----------
.. [MPL] Matplotlib, ``matplotlib.ticker.LogFormatterSciNotation`` (the labels
   reproduced here) and ``matplotlib.mathtext`` (the parsing avoided).
"""

import re

from matplotlib import rcParams
from matplotlib.ticker import LogFormatterSciNotation

_SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")

_MATH_LABEL = re.compile(
    r"\$\\mathdefault\{(?P<sign>-?)(?:(?P<coeff>[^\\{}]+)\\times)?"
    r"(?P<base>[^\\^{}]+)\^\{(?P<exp>-?\d+)\}\}\$")
r"""A label of ``LogFormatterSciNotation``: ``[-][c\times]b^{e}`` in ``$\mathdefault{}$``."""


def plain_label(label: str) -> str:
    r"""The plain-text form of one ``LogFormatterSciNotation`` label.

    ``$\mathdefault{10^{-3}}$`` -> ``10⁻³``, ``$\mathdefault{2\times10^{4}}$``
    -> ``2×10⁴``, ``$\mathdefault{0}$`` -> ``0``; a leading minus is the
    Unicode minus when ``axes.unicode_minus`` is set (as math text draws it).
    Any other label (empty, or a form this does not know) is returned as is.
    """
    if label == r"$\mathdefault{0}$":
        return "0"
    match = _MATH_LABEL.fullmatch(label)
    if match is None:
        return label
    sign = ("\N{MINUS SIGN}" if rcParams["axes.unicode_minus"] else "-") if match["sign"] else ""
    coeff = f"{match['coeff']}×" if match["coeff"] else ""
    return f"{sign}{coeff}{match['base']}{match['exp'].translate(_SUPERSCRIPT)}"


class PlainLogFormatter(LogFormatterSciNotation):
    """``LogFormatterSciNotation``'s labels (same ticks, same choice) in plain text."""

    def __call__(self, x, pos=None):
        """The label of tick ``x`` (position ``pos``), as matplotlib's but in plain text."""
        return plain_label(super().__call__(x, pos))

    @classmethod
    def like(cls, formatter: LogFormatterSciNotation) -> "PlainLogFormatter":
        """A plain formatter with ``formatter``'s base, labelling and thresholds."""
        return cls(base=formatter._base, labelOnlyBase=formatter.labelOnlyBase,
                   minor_thresholds=formatter.minor_thresholds,
                   linthresh=formatter._linthresh)


def plain_log_labels(fig) -> None:
    """Give every log axis of ``fig`` that has matplotlib's default labels plain ones."""
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for get, put in ((axis.get_major_formatter, axis.set_major_formatter),
                             (axis.get_minor_formatter, axis.set_minor_formatter)):
                formatter = get()
                if type(formatter) is LogFormatterSciNotation:
                    put(PlainLogFormatter.like(formatter))


def no_offset(fig) -> None:
    """Label every linear axis of ``fig`` with its full values, never with an offset.

    Matplotlib shortens labels like 1.29937, 1.29938 to 7, 8 with ``+1.2993``
    above the axis; a reader of a printed figure misses that text. A figure
    that plots small deviations subtracts its reference itself and says so
    in the axis label.
    """
    from matplotlib.ticker import ScalarFormatter

    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            formatter = axis.get_major_formatter()
            if isinstance(formatter, ScalarFormatter):
                formatter.set_useOffset(False)
