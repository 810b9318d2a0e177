"""The triad's non-orthogonality triangle ``T`` and its angles, both ways.

Tedaldi's upper-triangular unit-diagonal matrix fixes the body frame of a
triad (docs/triad.md)::

    T = [[1, -a_yz,  a_zy],
         [0,  1,    -a_zx],
         [0,  0,     1   ]]                 angles in rad           # Eq. (8) [Tedaldi2014]

The model (:mod:`.model`), the forward map (:mod:`.forward`) and the RQ split
(:mod:`.split`) all build it here, below each of them, so that none imports
another for it.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., "A robust and easy to
   implement method for IMU calibration without external equipments", ICRA
   2014, eq. (8) (triangular misalignment).
"""

import numpy as np


def t_matrix(angles) -> np.ndarray:
    """Tedaldi's upper-triangular non-orthogonality matrix ``T`` of (a_yz, a_zy, a_zx).

    Eq. (8) [Tedaldi2014].
    """
    a_yz, a_zy, a_zx = (float(v) for v in angles)
    return np.array([[1.0, -a_yz, a_zy], [0.0, 1.0, -a_zx], [0.0, 0.0, 1.0]])


def angles_of(t) -> np.ndarray:
    """(a_yz, a_zy, a_zx) of an upper-triangular unit-diagonal ``T`` (inverse of t_matrix)."""
    t = np.asarray(t, dtype=float)
    return np.array([-t[0, 1], t[0, 2], -t[1, 2]])
