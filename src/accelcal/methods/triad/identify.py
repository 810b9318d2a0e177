"""What a set of positions determines, before any reduction, and how well.

:func:`plan` analyses the design a set of gravity directions gives either
route (at a nominal triad: unit scale, no bias, orthogonal axes), with the
shared :func:`accelcal.identifiability.analyse`: rank, condition number,
the parameters determined, and the axis directions no position visits.
The reductions run the same analysis at their solution and refuse a
deficient design with the same words. :meth:`Plan.predicted_sd` gives the
standard uncertainties a test of that design will state, from the noise of
one sample and the samples averaged per position (first order: the
covariance of the least-squares estimates at the nominal triad).

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014, sec. IV
   (at least 9 orientations for the gravity norm; more in practice).
.. [Ferraris1995] Ferraris F. et al., Sensors and Materials 7(5), 1995 (six
   positions for the linear model).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import Identifiability, analyse
from accelcal.methods.triad.common import missing_directions
from accelcal.methods.triad.forward import known_model, norm_model
from accelcal.methods.triad.model import PARAMS, QUADRATIC
from accelcal.methods.triad.result import GAUGE


@dataclass(frozen=True)
class Plan:
    """What a position set determines.

    Attributes
    ----------
    route : {"known", "unknown"}
    positions : int
    identifiability : Identifiability
        Of the route's design (names: the parameters, and the gauge angles
        ``rot_*`` for known orientations).
    missing : tuple of str
        Axis directions (``x up`` ... ``z down``) no position comes within 60 deg of.
    """

    route: str
    positions: int
    identifiability: Identifiability
    missing: tuple[str, ...]
    design: np.ndarray

    @property
    def ok(self) -> bool:
        """True when every parameter is determined."""
        return self.identifiability.full_rank

    def predicted_sd(self, noise_sd: float, samples: int) -> dict[str, float]:
        """Standard uncertainties of the parameters a test of this design will state.

        Parameters
        ----------
        noise_sd : float
            Noise SD of one sample on each axis, in the input unit (m/s^2 at
            the nominal triad).
        samples : int
            Samples averaged per position.

        Returns
        -------
        dict
            Parameter -> standard uncertainty (bias in the input unit, scale
            factors relative, angles in rad): ``sigma / sqrt(samples)`` times the
            square roots of the diagonal of ``(J^T J)^-1`` (for the gravity norm,
            the norm's SD at a nominal triad equals one axis's).

        Raises
        ------
        AccelcalError
            For a design that does not determine every parameter, or bad values.
        """
        if not (np.isfinite(noise_sd) and noise_sd > 0):
            raise AccelcalError(f"{noise_sd!r} must be a finite number > 0",
                                parameter="noise_sd")
        if not (isinstance(samples, int | np.integer) and samples >= 1):
            raise AccelcalError(f"{samples!r} must be a whole number >= 1", parameter="samples")
        if not self.ok:
            raise AccelcalError(
                f"the positions do not determine {', '.join(self.identifiability.unobservable)}:"
                " no uncertainty can be predicted", parameter="up")
        r = np.linalg.qr(self.design, mode="r")
        rinv = np.linalg.inv(r)
        sd = noise_sd / np.sqrt(samples) * np.sqrt(np.sum(rinv**2, axis=1))
        return dict(zip(self.identifiability.names, sd.tolist(), strict=True))


def plan(up, *, route: str = "known", quadratic: bool = False, gravity: float = 9.80665) -> Plan:
    """Analyse the design of positions with gravity-opposing directions ``up``.

    Parameters
    ----------
    up : array_like, shape (n, 3)
        Unit directions (fixture frame for known orientations, body frame
        for the gravity norm).
    route : {"known", "unknown"}
    quadratic : bool
        Include the quadratic terms.
    gravity : float
        m/s^2 (scales the design only).

    Returns
    -------
    Plan

    Examples
    --------
    >>> import numpy as np
    >>> p = plan(np.vstack([np.eye(3), -np.eye(3)]))
    >>> p.ok, p.missing
    (True, ())
    >>> plan(np.eye(3)[[0, 1, 2, 0, 1]], route="known").missing
    ('x down', 'y down', 'z down')
    """
    d = np.array(up, dtype=float)
    if d.ndim != 2 or d.shape[1] != 3 or not len(d) or not np.isfinite(d).all():
        raise AccelcalError(f"must have shape (n, 3), got {d.shape}", parameter="up")
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    names = PARAMS + (QUADRATIC if quadratic else ())
    nominal = np.concatenate([np.zeros(3), np.ones(3), np.zeros(3 + 3 * quadratic)])
    if route == "known":
        _, jac = known_model(np.concatenate([nominal, np.zeros(3)]), np.eye(3), gravity * d,
                             quadratic)
        jac = jac.reshape(3 * len(d), -1)
        ident = analyse(jac, names + GAUGE)
    elif route == "unknown":
        _, jac = norm_model(nominal, gravity * d, gravity, quadratic)
        ident = analyse(jac, names)
    else:
        raise AccelcalError(f"{route!r} must be 'known' or 'unknown'", parameter="route")
    return Plan(route, len(d), ident, tuple(missing_directions(d)), jac)
