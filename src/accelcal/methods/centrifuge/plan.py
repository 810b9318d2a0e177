"""Test planning without data: predicted standard uncertainties of a centrifuge design.

Given the levels, the positions and the rig's uncertainties, :func:`plan`
predicts the standard uncertainty of every coefficient a reduction of that
test will state, to first order at a unit sensor (K1 = 1, output in g, the
other coefficients small): with the design ``A = [f_t(a), da_i/drho]`` of
the estimated coefficients and rig errors, readings of noise SD ``sigma``
(``n`` per step) and the given rig errors' SDs ``U`` ::

    cov = sigma^2 / n (A'A)^-1 + G U G',  G = (A'A)^-1 A' J_given         # Eq. (C2)

(:mod:`~accelcal.methods.centrifuge.core`; computed, as the reductions do it,
with the given rig errors as pseudo-observations, Eq. (C3), which is Eq.
(C2) where the records do not see them). A Monte Carlo run of the rig
and the reduction (:mod:`~accelcal.methods.centrifuge.mc`) confirms it in
the tests. An optional 1 g tumble about OA (uniform positions) adds the
joint reduction's observations.

References
----------
.. [IEEE836] IEEE Std 836-2009, Recommended Practice for Precision Centrifuge
   Testing of Linear Accelerometers.
.. [GUM] JCGM 100:2008, sec. 5.1.
.. [DOMAIN] accelcal domain notes, section 9.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.centrifuge import MAX_RADIUS, MIN_RADIUS, MIN_SD
from accelcal.methods.centrifuge.core import Block, design, unit_coefficients
from accelcal.methods.centrifuge.identify import CentrifugeIdentifiability, identifiability
from accelcal.model import term_unit
from accelcal.physics.centrifuge import (
    ASYMMETRY_TERMS,
    FULL_TERMS,
    MISALIGNMENT_AXES,
    RIG_ERRORS,
    check_terms,
    misalignment_name,
    rig_unit,
)
from accelcal.units import STANDARD_GRAVITY

MAX_STEPS = 100_000
"""Most (position, level) steps a plan analyses (a centrifuge test has a few hundred)."""


@dataclass(frozen=True)
class CentrifugePlan:
    """Predicted uncertainties of a centrifuge test.

    Attributes
    ----------
    terms : tuple of str
        Coefficients the reduction will estimate.
    estimated : tuple of str
        Rig errors it will estimate.
    names : tuple of str
        ``terms`` then ``estimated``.
    sd : numpy.ndarray
        Predicted standard uncertainty of each (g/g^n; K1 relative; rig
        errors in their units).
    covariance : numpy.ndarray
    identifiability : CentrifugeIdentifiability
    """

    terms: tuple
    estimated: tuple
    names: tuple
    sd: np.ndarray
    covariance: np.ndarray
    identifiability: CentrifugeIdentifiability

    def as_dict(self) -> dict[str, float]:
        """Name -> predicted standard uncertainty."""
        return dict(zip(self.names, self.sd.tolist(), strict=True))

    def rows(self) -> list[dict]:
        """One row per coefficient and rig error: ``coefficient, std, unit``."""
        return [{"coefficient": n, "std": float(s),
                 "unit": "1 (relative)" if n == "K1" else
                 (term_unit(n, "g") if n in self.terms else rig_unit(n))}
                for n, s in zip(self.names, self.sd, strict=True)]


def plan_blocks(positions, levels, *, radius=1.0, readings=1, gravity=STANDARD_GRAVITY,
                one_g_positions=0, one_g_readings=1):
    """Observation blocks of a planned test (outputs zero): centrifuge, optionally 1 g."""
    from accelcal.rigs.centrifuge import positions_of

    specs, mats = positions_of(positions)
    lev = np.asarray(levels, dtype=float).reshape(-1)
    if lev.size < 2 or np.unique(lev).size < 2 or not np.isfinite(lev).all() or (lev <= 0).any():
        raise AccelcalError("give at least two distinct levels > 0 g: the nonlinearity needs "
                            "several", parameter="levels")
    if len({m.tobytes() for m in mats}) < 2:
        raise AccelcalError("give at least two different positions (e.g. IA-in and IA-out)",
                            parameter="positions")
    n = len(specs) * lev.size
    if n > MAX_STEPS:
        raise AccelcalError(f"{n} steps: at most {MAX_STEPS}", parameter="levels")
    pos = np.repeat(np.arange(len(specs)), lev.size)
    level = np.tile(lev, len(specs))
    blk = Block("centrifuge", np.zeros(n), np.full(n, float(readings)), c=mats[pos],
                position=pos, position_names=tuple(s["name"] for s in specs),
                rate2=level * STANDARD_GRAVITY / radius, radius=radius, gravity=gravity,
                level=level)
    blocks = [blk]
    if not 0 <= one_g_positions <= MAX_STEPS:
        raise AccelcalError(f"{one_g_positions} must be 0 (none) to {MAX_STEPS}",
                            parameter="one_g_positions")
    if one_g_positions:
        from accelcal.physics.tumble import specific_force
        from accelcal.rigs.tumble import uniform_positions

        a = specific_force(uniform_positions(int(one_g_positions)), "OA")
        blocks.append(Block("1 g", np.zeros(a[0].size), np.full(a[0].size,
                                                                float(one_g_readings)), fixed=a))
    return blocks


def plan(positions, levels, *, noise_sd=1e-6, readings=1, radius=1.0, terms=None,
         radius_sd=0.0, stretch_sd=0.0, offset_sd=0.0, misalignment_sd=0.0, estimate=(),
         one_g_positions=0, one_g_noise_sd=None) -> CentrifugePlan:
    """Predict the standard uncertainty of each coefficient before the test.

    Parameters
    ----------
    positions : sequence
        Position names or ``{"name", "angles_deg"}``.
    levels : array_like
        Levels, g.
    noise_sd : float
        Noise SD of one reading, g.
    readings : int
        Readings averaged per step.
    radius : float
        Arm radius, m.
    terms : sequence of str, optional
        Default: the largest identifiable subset of every term.
    radius_sd, stretch_sd, offset_sd, misalignment_sd : float
        Standard uncertainties of the given rig errors (relative, s^2, m, rad).
    estimate : sequence of str
        Rig errors to estimate instead (e.g. ``("radius_error",)`` with a 1 g test).
    one_g_positions : int
        Positions of a joint 1 g tumble about OA (0: none).
    one_g_noise_sd : float, optional
        Its noise SD per reading, g (default ``noise_sd``).

    Returns
    -------
    CentrifugePlan

    References
    ----------
    .. [1] GUM 5.1; DOMAIN section 9.
    """
    values = {"noise_sd": noise_sd, "radius": radius, "radius_sd": radius_sd,
              "stretch_sd": stretch_sd, "offset_sd": offset_sd,
              "misalignment_sd": misalignment_sd}
    limits = {"noise_sd": (MIN_SD, 1.0), "radius": (MIN_RADIUS, MAX_RADIUS)}
    for name, v in values.items():
        lo, hi = limits.get(name, (MIN_SD, 1.0))
        if not (np.isfinite(v) and (lo <= v <= hi or (v == 0 and name not in limits))):
            raise AccelcalError(f"{v!r} must be {'' if name in limits else '0 or '}from {lo:g} "
                                f"to {hi:g}", parameter=name)
    if not (isinstance(readings, int | np.integer) and 1 <= readings <= 10**9):
        raise AccelcalError(f"{readings!r} must be a whole number >= 1", parameter="readings")
    blocks = plan_blocks(positions, levels, radius=radius, readings=int(readings),
                         one_g_positions=int(one_g_positions))
    names_p = blocks[0].position_names
    sds = {"radius_error": radius_sd, "arm_stretch": stretch_sd, "proof_mass_offset": offset_sd}
    sds |= {misalignment_name(p, a): misalignment_sd for p in names_p for a in MISALIGNMENT_AXES}
    estimate = tuple(misalignment_name(p, a) for p in names_p for a in MISALIGNMENT_AXES) \
        if tuple(estimate) == ("misalignment",) else tuple(estimate)
    for name in estimate:
        if name not in sds:
            raise AccelcalError(f"{name!r} is not a rig error ({', '.join(RIG_ERRORS)}, "
                                "misalignment)", parameter="estimate")
    given = {k: v for k, v in sds.items() if v > 0 and k not in estimate}
    report = identifiability(blocks, {}, (*FULL_TERMS, *ASYMMETRY_TERMS), estimate)
    terms = check_terms(terms, report.suggested)
    phi, jac = design(blocks, terms, {}, unit_coefficients(terms), (*estimate, *given))
    p, m, k = len(terms), len(estimate), len(given)
    sigma = np.concatenate([np.full(b.y.size, noise_sd if j == 0 or one_g_noise_sd is None
                                    else one_g_noise_sd) for j, b in enumerate(blocks)])
    w = np.concatenate([b.count for b in blocks]) / sigma**2
    # the given rig errors as pseudo-observations (Eq. (C3)): Eq. (C2) where the records do
    # not see them, the combination with the data where they do
    prior = np.hstack([np.zeros((k, p + m)), np.diag(1.0 / np.array(list(given.values())))])
    a = np.vstack([np.hstack([phi, jac]) * np.sqrt(w)[:, None], prior])
    from accelcal.identifiability import analyse

    r = np.linalg.qr(a, mode="r")
    if analyse(r, (*terms, *estimate, *given)).rank < a.shape[1]:
        raise AccelcalError(f"the design cannot separate {', '.join(terms + estimate)}; estimate "
                            f"fewer (suggested: {', '.join(report.suggested)})", parameter="terms")
    rinv = np.linalg.inv(r)
    cov = (rinv @ rinv.T)[:p + m, :p + m]
    return CentrifugePlan(terms, estimate, (*terms, *estimate), np.sqrt(np.diag(cov)), cov, report)
