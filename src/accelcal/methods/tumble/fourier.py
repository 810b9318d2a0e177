"""The IEEE 1293 Fourier route: harmonics of a uniform tumble and their relations.

For N equally spaced positions the outputs' discrete Fourier coefficients
A_k, B_k (k = 0..4) are uncorrelated, and the model's output-unit
coefficients ``b_t = K1 K_t`` are fixed linear combinations of them
(:func:`fourier_map`, the relations of [DOMAIN] section 5, checked and
extended to rotation about PA in docs/errata.md).

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex on multipoint tumble analysis.
.. [DOMAIN] accelcal domain notes, section 5 (corrected where docs/errata.md
   says so).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.physics.tumble import check_angles, check_outputs, is_uniform

HARMONICS = ("A0", "A1", "B1", "A2", "B2", "A3", "B3", "A4")
"""The harmonic amplitudes the relations use, in the order of :func:`fourier_map`'s columns."""


@dataclass(frozen=True)
class FourierCoefficients:
    """Discrete Fourier coefficients of a uniform tumble, harmonics 0..kmax.

    ``A[..., 0]`` is the mean output. For ``0 < k < N/2``,
    ``A_k = (2/N) sum E cos(k theta)`` and ``B_k = (2/N) sum E sin(k theta)``.
    At the Nyquist harmonic ``k = N/2`` (even N), ``cos(k theta_j) =
    cos(k theta_0) (-1)^j`` and ``sin(k theta_j) = sin(k theta_0) (-1)^j``
    are proportional, so only one amplitude is observable: ``A_k`` is the
    amplitude of ``cos(k theta)`` alone, ``sum E cos(k theta) / sum
    cos^2(k theta)`` (``(1/N) sum E cos(k theta)`` when theta_0 = 0; NaN when
    ``cos(k theta_0) = 0``), and ``B_k`` is set to 0. The tumble model has
    no ``sin(4 theta)`` term, so this is the amplitude it needs. Harmonics
    above N/2 are not computed.

    Attributes
    ----------
    k : tuple of int
        Harmonic numbers.
    A, B : numpy.ndarray
        Shape ``(..., len(k))``, in the output unit.
    """

    k: tuple[int, ...]
    A: np.ndarray
    B: np.ndarray


def fourier_coefficients(angles_rad, outputs, kmax: int = 4) -> FourierCoefficients:
    """The A_k, B_k of a uniform tumble, harmonics 0..min(kmax, N//2).

    Parameters
    ----------
    angles_rad : array_like, shape (N,)
        N equally spaced positions (any start, any order), rad.
    outputs : array_like, shape (..., N)
        Outputs at the positions.
    kmax : int
        Highest harmonic wanted.

    Returns
    -------
    FourierCoefficients

    Raises
    ------
    AccelcalError
        If the positions are not uniform or the shapes do not match.

    References
    ----------
    .. [1] IEEE1293, multipoint tumble analysis; DOMAIN section 5.
    """
    angles = check_angles(angles_rad)
    y = check_outputs(outputs, angles.size)
    if not is_uniform(angles):
        raise AccelcalError(
            "Fourier coefficients need N equally spaced positions; these are not "
            "(use the least-squares route for non-uniform positions)",
            parameter="angles_rad",
        )
    n = angles.size
    ks = tuple(range(min(int(kmax), n // 2) + 1))
    k = np.asarray(ks, dtype=float)
    cos_k, sin_k = np.cos(np.outer(angles, k)), np.sin(np.outer(angles, k))  # (N, K)
    weight = 1.0 / cos_norm(angles, k)  # 2/N below Nyquist
    A = (y @ cos_k) * weight  # Eq. A_k = (2/N) sum E cos(k theta) [IEEE1293]
    B = np.where(2 * k == n, 0.0, (y @ sin_k) * weight)  # Eq. B_k [IEEE1293]
    return FourierCoefficients(k=ks, A=A, B=B)


def cos_norm(angles, k):
    """Sum over the positions of cos^2(k theta) for a uniform set.

    N at k = 0, N/2 for 0 < k < N/2 and N cos^2(k theta_0) at the Nyquist
    harmonic k = N/2; NaN there when it vanishes, so that the amplitude comes
    out NaN rather than as a silent value.
    """
    n = angles.size
    norm = np.where(k == 0, float(n), n / 2.0)
    nyq = 2 * k == n
    if nyq.any():
        c2 = float(np.sum(np.cos(k[nyq][0] * angles) ** 2))
        norm = np.where(nyq, c2 if c2 > 1e-9 * n else np.nan, norm)
    return norm


def fourier_map(axis: str, terms) -> np.ndarray:
    """Matrix L with b = L h, h the harmonic amplitudes :data:`HARMONICS`, for DEFAULT_TERMS.

    Rows follow ``terms`` (the default terms of ``axis``, any order).

    References
    ----------
    .. [1] DOMAIN section 5 (OA); derived the same way for PA (docs/errata.md).
    """
    idx = {key: i for i, key in enumerate(HARMONICS)}
    rows = {}

    def row(**w):
        r = np.zeros(len(idx))
        for key, v in w.items():
            r[idx[key]] = v
        return r

    if axis == "OA":
        # A1 = K1 (1 + 3 K3/4), 4 A3/K1 = K3  ->  K1 = A1 - 3 A3   # Eq. [DOMAIN] s. 5
        rows["K1"] = row(A1=1.0, A3=-3.0)
        rows["K3"] = row(A3=4.0)  # 4 A3 = K1 K3  # [DOMAIN] s. 5
        rows["Kp"] = row(B1=1.0)  # B1 = K1 Kp (IEEE delta_o)  # [DOMAIN] s. 5
        rows["Kip"] = row(B2=2.0)  # 2 B2 = K1 Kip  # [DOMAIN] s. 5
        rows["K4"] = row(A4=8.0)  # 8 A4 = K1 K4  # [DOMAIN] s. 5
        rows["K2"] = row(A2=2.0, A4=-8.0)  # 2 A2 = K1 (K2 - Kpp + K4)  # [DOMAIN] s. 5
        # A0 = K1 (K0 + (K2 + Kpp)/2 + 3 K4/8)  # [DOMAIN] s. 5
        rows["K0"] = row(A0=1.0, A2=-1.0, A4=1.0)  # b0 = A0 - b2/2 - 3 b4/8
    else:
        # About PA: B1 = K1 (1 + 3 K3/4), B3 = -K1 K3/4, A1 = K1 Ko,
        # 2 B2 = K1 Kio, 8 A4 = K1 K4, -2 A2 = K1 (K2 - Koo + K4),
        # A0 = K1 (K0 + (K2 + Koo)/2 + 3 K4/8).  # Derived as [DOMAIN] s. 5, a_i = sin
        rows["K1"] = row(B1=1.0, B3=3.0)
        rows["K3"] = row(B3=-4.0)
        rows["Ko"] = row(A1=1.0)
        rows["Kio"] = row(B2=2.0)
        rows["K4"] = row(A4=8.0)
        rows["K2"] = row(A2=-2.0, A4=-8.0)
        rows["K0"] = row(A0=1.0, A2=1.0, A4=1.0)  # b0 = A0 - b2/2 - 3 b4/8
    return np.array([rows[t] for t in terms])


def harmonics_vector(fc: FourierCoefficients) -> np.ndarray:
    """The amplitudes :data:`HARMONICS` of ``fc``, shape ``(..., 8)`` (0 where not computed)."""
    h = np.zeros((*fc.A.shape[:-1], len(HARMONICS)))
    for i, key in enumerate(HARMONICS):
        k = int(key[1])
        if k in fc.k:
            h[..., i] = (fc.A if key[0] == "A" else fc.B)[..., fc.k.index(k)]
    return h


def fourier_solution(angles, y, fc: FourierCoefficients, *, axis, terms):
    """Output-unit coefficients by the Fourier relations.

    Returns
    -------
    b : numpy.ndarray, shape (..., p)
    cov_unit : numpy.ndarray, shape (p, p)
        Covariance of ``b`` for unit noise variance of one (averaged) output
        (the harmonics of a uniform set are uncorrelated).
    residuals : numpy.ndarray, shape (..., N)
        The outputs minus the harmonics the model excites.

    References
    ----------
    .. [1] IEEE1293, multipoint tumble analysis; DOMAIN section 5.
    """
    L = fourier_map(axis, terms)
    h = harmonics_vector(fc)
    b = h @ L.T
    # Residual: the outputs minus the harmonics the model excites.
    k_of = np.array([float(key[1]) for key in HARMONICS])
    basis = np.zeros((angles.size, len(HARMONICS)))
    for i, key in enumerate(HARMONICS):
        if int(key[1]) in fc.k and L[:, i].any():
            k = k_of[i]
            basis[:, i] = np.cos(k * angles) if key[0] == "A" else np.sin(k * angles)
    resid = y - h @ basis.T
    var_h = 1.0 / cos_norm(angles, k_of)
    cov_unit = (L * var_h) @ L.T  # harmonics are uncorrelated for uniform positions
    return b, cov_unit, resid
