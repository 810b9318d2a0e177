"""Acceptance-test rig: the indexing head stepping a pendulous accelerometer with friction.

The head tilts the input axis (IA) from horizontal by an angle theta, so the
applied acceleration is ``a = sin(theta)`` g. Two programmes:

threshold / resolution
    About a set point theta0 (0 for the threshold, e.g. 30 deg for the
    resolution), for each increment d of a ladder (arc-seconds, ascending)
    the head alternates ``theta0 + d, theta0, theta0 + d, ...``
    (``reversals`` up-and-back pairs), dwelling ``dwell`` s at each angle.
hysteresis
    The cycle 0 -> +90 deg -> 0 -> -90 deg -> 0 (input 0 -> +1 g -> 0 ->
    -1 g -> 0) in steps of ``cycle_step`` deg, one dwell per angle.

The sensor (physical model)
---------------------------
The output is ``E = K0 + K1 x + noise``, ``x`` the input the pendulum
senses, white noise of ``noise`` (output unit) per sample at ``rate``.
Two mechanisms separate ``x`` from the applied ``a``:

- Stick-slip (Coulomb friction at the pivot): the pendulum sticks until
  the input torque exceeds the break-away friction, then slips to the new
  equilibrium (kinetic friction below static): ``x_k = a_k`` when
  ``|a_k - x_(k-1)| > c``, else ``x_k = x_(k-1)``. The break-away level
  is ``c = breakaway + friction |a0|`` (g): a dead band ``breakaway`` at
  null, growing with the pivot load ``|a0|`` at the set point a0. A step
  larger than ``c`` moves the output fully, a smaller one not at all, so
  the true threshold (a0 = 0) and resolution are the smallest increments
  of the ladder larger than ``c``.
- Hysteresis (elastic after-effect of the flexure, torquer magnet): a
  first-order (Duhem-type) offset ``y`` relaxing towards ``+w`` on an
  increasing leg and ``-w`` on a decreasing one over an input span
  ``hysteresis_span``: ``y <- s w + (y - s w) exp(-|da| / span)``,
  ``x = a - y``. Far from the turning points the output of the
  decreasing leg exceeds that of the increasing one by ``2 w =
  hysteresis`` (g); the metadata give the exact difference at each point.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, threshold, resolution and hysteresis tests.
.. [Armstrong1994] B. Armstrong-Helouvry, P. Dupont, C. Canudas de Wit,
   "A survey of models, analysis tools and compensation methods for the
   control of machines with friction", Automatica 30 (7), 1994 (stick-slip,
   break-away friction).
.. [DOMAIN] accelcal domain notes, section 12.
"""

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.acceptance import TESTS, StepRecord
from accelcal.resources import generator

MAX_SAMPLES = 20_000_000
"""Most samples a simulated test may hold."""

LADDER_ARCSEC = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0)
"""Default increments, arc-seconds (1 arcsec ~ 4.85 ug at null)."""


def programme(test: str, *, set_point: float = 0.0, increments=LADDER_ARCSEC,
              reversals: int = 3, cycle_step: float = 15.0) -> np.ndarray:
    """The head's angle at each dwell, deg (module docs)."""
    if test == "hysteresis":
        if not 0.0 < cycle_step <= 90.0:
            raise AccelcalError("the cycle step must be in (0, 90] deg")
        up = np.arange(0.0, 90.0 + 1e-9, cycle_step)
        up = np.r_[up, 90.0] if up[-1] < 90.0 else up
        return np.r_[up, up[-2::-1], -up[1:], -up[-2::-1]]
    if reversals < 1 or not len(increments):
        raise AccelcalError("a threshold or resolution test needs increments and at least one "
                            "reversal")
    angles = [set_point]
    for d in increments:
        angles += [set_point + d / 3600.0, set_point] * reversals
    return np.asarray(angles)


def sensed(applied: np.ndarray, *, breakaway: float, friction: float, set_point_g: float,
           hysteresis: float, hysteresis_span: float) -> np.ndarray:
    """The input the pendulum senses at each dwell, g (the module's physical model)."""
    c = breakaway + friction * abs(set_point_g)
    x = np.empty_like(applied)
    held, y, w = applied[0], 0.0, 0.5 * hysteresis
    for k, a in enumerate(applied):
        if k:
            da = a - applied[k - 1]
            if da:
                s = np.sign(da)
                y = s * w + (y - s * w) * np.exp(-abs(da) / hysteresis_span)
        target = a - y
        if abs(target - held) > c or k == 0:
            held = target
        x[k] = held
    return x


def simulate(test: str = "threshold", *, scale_factor: float = 1.0, bias: float = 0.0,
             output_unit: str = "g", set_point: float | None = None,
             increments=LADDER_ARCSEC, reversals: int = 3, cycle_step: float = 15.0,
             dwell: float = 10.0, rate: float = 10.0, noise: float = 5e-6,
             breakaway: float = 10e-6, friction: float = 2e-5, hysteresis: float = 0.0,
             hysteresis_span: float = 0.05, seed=None) -> StepRecord:
    """A simulated step test of one accelerometer on the indexing head.

    Parameters
    ----------
    test : {"threshold", "resolution", "hysteresis"}
    scale_factor, bias : float
        K1 (output unit per g) and K0 (output unit).
    output_unit : str
    set_point : float, optional
        Set-point angle, deg (default 0 for the threshold, 30 for the
        resolution); unused by the hysteresis cycle.
    increments : sequence of float
        The ladder of angle increments, arcsec, ascending.
    reversals : int
        Up-and-back pairs per increment.
    cycle_step : float
        Angle step of the hysteresis cycle, deg.
    dwell, rate : float
        Time at each angle, s, and sample rate, Hz.
    noise : float
        Output noise SD per sample, output unit.
    breakaway, friction : float
        Break-away level at null, g, and its growth per g of set point (the
        threshold and resolution: module docs).
    hysteresis, hysteresis_span : float
        Decreasing-minus-increasing difference far from the turning points,
        g, and the input span over which it builds up, g.
    seed : int, numpy.random.SeedSequence or numpy.random.Generator, optional

    Returns
    -------
    StepRecord
        Metadata ``simulated``, ``seed``, ``settings`` and the truth:
        ``true_threshold_g`` or ``true_resolution_g`` (the 50 % rule's
        answer on the ladder, and ``true_breakaway_g``), ``step_g`` (the
        increments' input changes) or ``true_hysteresis_g`` (input point ->
        decreasing minus increasing sensed input).
    """
    if test not in TESTS:
        raise AccelcalError(f"test {test!r} is not one of {', '.join(TESTS)}")
    _check_settings(set_point=set_point, reversals=reversals, cycle_step=cycle_step,
                    dwell=dwell, rate=rate, noise=noise, breakaway=breakaway,
                    friction=friction, hysteresis=hysteresis, hysteresis_span=hysteresis_span,
                    scale_factor=scale_factor, bias=bias)
    rng = generator(seed)
    theta0 = (30.0 if test == "resolution" else 0.0) if set_point is None else set_point
    increments = np.asarray(increments, dtype=float)
    if test != "hysteresis" and not (np.all(increments > 0) and np.all(np.diff(increments) > 0)
                                     and increments.size and increments[-1] <= 3600.0):
        raise AccelcalError("the increments must be positive and ascending, at most 3600 "
                            "arcsec")
    if angles_count(test, increments.size, reversals, cycle_step) * round(dwell * rate) > \
            MAX_SAMPLES:
        raise AccelcalError(f"the test would take more than {MAX_SAMPLES:g} samples: shorten "
                            "the dwell, the rate or the ladder")
    work.simulated("acceptance", f"the {test} test at {rate:g} Hz",
                   float(angles_count(test, increments.size, reversals, cycle_step))
                   * round(dwell * rate), parameter="dwell",
                   hint="shorten the dwell, the rate or the ladder")
    angles = programme(test, set_point=theta0, increments=increments, reversals=reversals,
                       cycle_step=cycle_step)
    applied = np.sin(np.radians(angles))
    a0 = float(np.sin(np.radians(theta0))) if test != "hysteresis" else 0.0
    x = sensed(applied, breakaway=breakaway, friction=friction, set_point_g=a0,
               hysteresis=hysteresis if test == "hysteresis" else 0.0,
               hysteresis_span=hysteresis_span)
    n = round(dwell * rate)
    t = np.arange(angles.size * n) / rate
    out = bias + scale_factor * np.repeat(x, n) + rng.normal(0.0, noise, t.size)
    meta = {"simulated": True, "seed": seed if isinstance(seed, int) else None,
            "settings": {"set_point_deg": theta0, "increments_arcsec": increments.tolist(),
                         "reversals": reversals, "cycle_step_deg": cycle_step, "dwell_s": dwell,
                         "rate_hz": rate, "noise": noise, "bias": bias,
                         "breakaway_g": breakaway, "friction_per_g": friction,
                         "hysteresis_g": hysteresis, "hysteresis_span_g": hysteresis_span}}
    if test == "hysteresis":
        meta["true_hysteresis_g"] = _true_hysteresis(applied, x)
        meta["step_g"] = float(np.sin(np.radians(cycle_step)))
    else:
        steps = np.abs(np.sin(np.radians(theta0 + increments / 3600.0)) - a0)
        c = breakaway + friction * abs(a0)
        above = steps[steps > c]
        meta[f"true_{test}_g"] = float(above[0]) if above.size else None
        meta["true_breakaway_g"] = c
        meta["step_g"] = steps.tolist()
        meta["step_arcsec"] = increments.tolist()
    return StepRecord(t=t, input=np.repeat(applied, n), output=out, test=test,
                      output_unit=output_unit, scale_factor=scale_factor,
                      angle=np.repeat(angles, n), metadata=meta)


def angles_count(test: str, increments: int, reversals: int, cycle_step: float) -> int:
    """Number of dwells of a programme (:func:`programme`)."""
    if test == "hysteresis":
        return 4 * int(np.ceil(90.0 / cycle_step)) + 1
    return 1 + 2 * reversals * increments


def _check_settings(**values) -> None:
    """Every setting a finite number in its range (one line naming it, else)."""
    limits = {"set_point": (-360.0, 360.0), "reversals": (1, 1000), "cycle_step": (1e-3, 90.0),
              "dwell": (1e-6, 1e6), "rate": (1e-6, 1e6), "noise": (0.0, 1e3),
              "breakaway": (0.0, 1.0), "friction": (0.0, 1.0), "hysteresis": (0.0, 1.0),
              "hysteresis_span": (1e-6, 10.0), "scale_factor": (-1e6, 1e6),
              "bias": (-1e6, 1e6)}
    for name, value in values.items():
        if value is None:
            continue
        lo, hi = limits[name]
        if isinstance(value, bool) or not (lo <= value <= hi):
            raise AccelcalError(f"{name} {value!r:.30} is not a number in [{lo:g}, {hi:g}]",
                                parameter=name)
    if values["scale_factor"] == 0:
        raise AccelcalError("the scale factor must not be 0", parameter="scale_factor")
    if values["dwell"] * values["rate"] < 2:
        raise AccelcalError("dwell * rate must give at least two samples per dwell",
                            parameter="dwell")


def _true_hysteresis(applied: np.ndarray, x: np.ndarray) -> dict:
    """Input point (g, as text) -> decreasing minus increasing sensed input, g."""
    direction = np.r_[0.0, np.sign(np.diff(applied))]
    out = {}
    for a in np.unique(applied):
        at = applied == a
        up, down = at & (direction > 0), at & (direction < 0)
        if up.any() and down.any():
            out[f"{a + 0.0:.6f}"] = float(x[down].mean() - x[up].mean())
    return out


__all__ = ["LADDER_ARCSEC", "MAX_SAMPLES", "angles_count", "programme", "sensed", "simulate"]
