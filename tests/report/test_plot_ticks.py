"""Log-axis tick labels in plain text (issue 16): the same labels, no math-text parsing."""

import numpy as np
import pytest
from matplotlib import mathtext
from matplotlib.ticker import FuncFormatter, LogFormatterSciNotation

from accelcal.plotting import new_figure, save_figure
from accelcal.plotting.ticks import PlainLogFormatter, plain_label, plain_log_labels
from accelcal.report import figure_svg


@pytest.mark.parametrize(("label", "plain"), [
    (r"$\mathdefault{10^{-3}}$", "10⁻³"),
    (r"$\mathdefault{10^{0}}$", "10⁰"),
    (r"$\mathdefault{10^{12}}$", "10¹²"),
    (r"$\mathdefault{2\times10^{-5}}$", "2×10⁻⁵"),
    (r"$\mathdefault{-10^{4}}$", "\N{MINUS SIGN}10⁴"),
    (r"$\mathdefault{-3\times2^{7}}$", "\N{MINUS SIGN}3×2⁷"),
    (r"$\mathdefault{0}$", "0"),
    ("", ""),
    (r"$\mathdefault{10^{0.50}}$", r"$\mathdefault{10^{0.50}}$"),  # not a form it knows
])
def test_plain_label(label, plain):
    assert plain_label(label) == plain


@pytest.fixture
def parses(monkeypatch):
    """Every string matplotlib's math-text parser is asked to parse."""
    seen = []
    original = mathtext.MathTextParser.parse

    def parse(self, s, *args, **kwargs):
        seen.append(s)
        return original(self, s, *args, **kwargs)

    monkeypatch.setattr(mathtext.MathTextParser, "parse", parse)
    return seen


def loglog_figure(ymax=1e5):
    fig = new_figure()
    ax = fig.add_subplot()
    x = np.geomspace(1e-3, 1e4, 50)
    ax.loglog(x, np.sqrt(x) * ymax / 100)
    ax.set_ylim(ymax / 5, ymax)  # under a decade: labelled minor ticks (c x 10^e)
    return fig


def labels(fig):
    fig.canvas.draw()
    ax = fig.axes[0]
    return [t.get_text() for axis in (ax.xaxis, ax.yaxis)
            for t in axis.get_majorticklabels() + axis.get_minorticklabels()]


def test_the_same_ticks_and_labels_as_matplotlib_in_plain_text(parses):
    fig = loglog_figure()
    mathtext_labels = labels(fig)
    assert any(r"\times" in s for s in mathtext_labels)  # minor labels are exercised
    plain_log_labels(fig)
    assert all(type(f) is PlainLogFormatter for axis in (fig.axes[0].xaxis, fig.axes[0].yaxis)
               for f in (axis.get_major_formatter(), axis.get_minor_formatter()))
    assert labels(fig) == [plain_label(s) for s in mathtext_labels]
    parses.clear()
    figure_svg(fig)
    assert parses == []


def test_figure_svg_and_save_figure_parse_no_math_text(parses, tmp_path):
    figure_svg(loglog_figure())
    save_figure(loglog_figure(), tmp_path, "f")
    assert parses == []
    assert (tmp_path / "f.png").stat().st_size > 1000
    # matplotlib's own formatter would have parsed its labels: the check above can fail
    fig = loglog_figure()
    fig.savefig(tmp_path / "g.svg")
    assert any(r"\mathdefault" in s for s in parses)


def test_a_figure_s_own_formatter_is_left_alone():
    fig = loglog_figure()
    own = FuncFormatter(lambda x, pos: f"{x:g}")
    fig.axes[0].xaxis.set_major_formatter(own)
    plain_log_labels(fig)
    assert fig.axes[0].xaxis.get_major_formatter() is own
    assert type(fig.axes[0].yaxis.get_major_formatter()) is PlainLogFormatter
    linear = new_figure().add_subplot()
    plain_log_labels(linear.figure)
    assert not isinstance(linear.xaxis.get_major_formatter(), LogFormatterSciNotation)
