"""Vibrafuge simulator: an accelerometer under overload plus sinusoidal vibration.

A centrifuge holds a steady overload (a vector ``b`` in IA/OA/PA, g) while a
shaker on its arm adds a vibration ``A sin(2 pi f t + phase)`` along a unit
direction ``u``. The accelerometer feels ``a_j(t) = A u_j sin(theta) + b_j``
[Guan2021]_ eq. (4). For every test point the rig records the output at
rest (overload only) and while vibrating, at the same sample rate.

Two sampling models are offered:

``"point"``
    Each sample is the model output at the instant ``t_n = n / fs``
    (:meth:`accelcal.ErrorModel.output_g`). The whole-period mean of the
    sampled asymmetry term then differs from the continuous mean by a
    discretisation error (the sign changes between samples): with ``q``
    distinct phases per whole-period span it is at most
    ``|K0'| / q + pi |K1'| A_i / (2 q)`` g (see :func:`point_sampling_bound`).
``"integrating"``
    Each sample is the mean of the output over ``[t_n, t_n + 1/fs)``, as an
    integrating converter (I/F converter, integrating voltmeter) delivers
    it. Computed in closed form, so the whole-period mean of the record is
    exactly the continuous mean: no discretisation error.

Noise (white, Gaussian, in g) and quantisation of the output (a step in the
output unit, rounding to nearest) are optional. The records are a
:class:`~accelcal.io.formats.vibrafuge.VibrafugeRun` (written and read by
:mod:`accelcal.io.formats.vibrafuge`).

References
----------
.. [Guan2021] Guan W., Asymmetry coefficient errors of accelerometer under
   overload-vibration environment, Metrology & Measurement Technology 41(3),
   2021, eqs. (1)-(6).
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1 (coherent sampling over whole
   periods).
"""

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.vibrafuge import MAX_MAGNITUDE, VibrafugeRun
from accelcal.model import MAX_SPECIFIC_FORCE_G, ErrorModel
from accelcal.resources import check_memory, seeded

SAMPLING = ("integrating", "point")
"""Sampling models: mean over each sample interval, or instantaneous values."""

MEMORY_FACTOR = 16
"""Arrays of (points x samples) float64 a simulation holds at its peak: 13 measured
(tracemalloc) for integrating sampling, 9 for point sampling, 9 while the file
is written; 16 leaves a margin."""


def _positive(value, name: str, unit: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise AccelcalError(f"{value} {unit} must be positive and finite", parameter=name)
    return value


def _recordable(value: float, name: str, unit: str) -> float:
    """``value`` if a vibrafuge file can hold it (:data:`MAX_MAGNITUDE`), else refused."""
    if abs(value) > MAX_MAGNITUDE:
        raise AccelcalError(f"{value:.6g} {unit} is beyond the {MAX_MAGNITUDE:g} a vibrafuge "
                            "record holds (and any physical test)", parameter=name)
    return value


def _specific_force(vectors: np.ndarray, A: np.ndarray, u: np.ndarray) -> None:
    """Refuse overloads and amplitudes beyond the specific force the model is evaluated at.

    Checked here, naming this function's parameters, before the model would
    refuse its inputs ``a_i``, ``a_o``, ``a_p`` in its own words.
    """
    limit = MAX_SPECIFIC_FORCE_G
    for arr, name in ((vectors, "overload"), (A, "amplitude")):
        peak = float(np.abs(arr).max())
        if peak > limit:
            raise AccelcalError(f"{peak:.3g} g is beyond the {limit:.0e} g an accelerometer "
                                "model is evaluated at; give it in g", parameter=name)
    peak = float((np.abs(vectors) + A[:, None] * np.abs(u)).max())  # Eq. (4) [Guan2021]
    if peak > limit:
        raise AccelcalError(
            f"overload plus amplitude reach {peak:.3g} g, beyond the {limit:.0e} g an "
            "accelerometer model is evaluated at; give smaller amplitudes or overloads",
            parameter="amplitude")


def _grid(overload, amplitude, direction):
    b = np.asarray(overload, dtype=float)
    A = np.asarray(amplitude, dtype=float)
    u = np.asarray(direction, dtype=float).reshape(-1)
    for arr, what in ((b, "overload"), (A, "amplitude"), (u, "direction")):
        if not np.isfinite(arr).all():
            raise AccelcalError("has non-finite values (NaN or inf); give finite numbers",
                                parameter=what)
    if (A < 0).any():
        raise AccelcalError(
            f"{A[A < 0].ravel()[0]:g} g is negative; a vibration amplitude is >= 0",
            parameter="amplitude",
        )
    if u.shape != (3,) or not np.linalg.norm(u) > 0:
        raise AccelcalError("must be a non-zero vector of 3 components (IA, OA, PA)",
                            parameter="direction")
    if b.ndim == 2 and b.shape[1] == 3:
        vectors = b
    elif b.ndim <= 1:
        b = b.reshape(-1)
        vectors = np.stack([b, np.zeros_like(b), np.zeros_like(b)], axis=1)
    else:
        raise AccelcalError(
            f"must be values along IA or vectors of shape (P, 3); got shape {b.shape}",
            parameter="overload",
        )
    try:
        vectors, A = np.broadcast_arrays(vectors, A.reshape(-1)[:, None])
    except ValueError:
        raise AccelcalError(
            f"{vectors.shape[0]} overloads and {A.size} amplitudes do not match; give equal "
            "numbers or a single value of one"
        ) from None
    if vectors.shape[0] == 0:
        raise AccelcalError("no test points: give at least one overload and one amplitude")
    u = u / np.linalg.norm(u)
    _specific_force(vectors, A[:, 0], u)
    return vectors.copy(), A[:, 0].copy(), u


def simulate(
    model: ErrorModel,
    overload,
    amplitude,
    *,
    frequency: float,
    sample_rate: float,
    duration: float,
    direction=(1.0, 0.0, 0.0),
    phase: float = 0.0,
    noise: float | None = None,
    quantum: float = 0.0,
    sampling: str = "integrating",
    seed=None,
    rng: np.random.Generator | None = None,
    centrifuge=None,
) -> VibrafugeRun:
    """Simulate the static and vibrating records of vibrafuge test points.

    Parameters
    ----------
    model : ErrorModel
        The accelerometer.
    overload : array_like, shape (P,) or (P, 3)
        Overload of each point: values along IA (any sign, zero allowed) or
        vectors in IA/OA/PA, g. Broadcasts with ``amplitude``.
    amplitude : array_like, shape (P,)
        Vibration amplitude of each point, g (>= 0).
    frequency : float
        Vibration frequency, Hz (below ``sample_rate / 2``).
    sample_rate : float
        Sample rate, Hz.
    duration : float
        Record length, s (``round(duration * sample_rate)`` samples).
    direction : array_like, shape (3,)
        Vibration direction in IA, OA, PA (normalised here).
    phase : float
        Vibration phase at t = 0, rad.
    noise : float, optional
        White noise standard deviation, g; default ``model.sigma``. Needs
        ``seed`` when positive.
    quantum : float
        Output quantisation step in the model's output unit (0: none).
    sampling : {"integrating", "point"}
        Sampling model (see the module notes).
    seed : int, numpy.random.SeedSequence or numpy.random.Generator, optional
        Source of the noise.
    rng : numpy.random.Generator, optional
        The older name of ``seed`` (a Generator), kept as an alias.
    centrifuge : accelcal.rigs.centrifuge.CentrifugeRig, optional
        The centrifuge that produces the overloads: the sensor then feels
        :meth:`~accelcal.rigs.centrifuge.CentrifugeRig.overload` of each
        nominal overload (the rig's radius, stretch, rate, misalignment and
        proof-mass errors, and gravity on the vertical), while the run
        records the nominal overloads, as a laboratory would. Default None:
        the sensor feels the nominal overloads exactly.

    Returns
    -------
    VibrafugeRun
        Marked ``simulated`` (its file says ``"simulated": true``).

    Raises
    ------
    AccelcalError
        For bad input (non-finite or negative amplitude, frequency not below
        Nyquist, noise without a generator, ...), overloads and amplitudes
        beyond :data:`accelcal.model.MAX_SPECIFIC_FORCE_G`, values or outputs
        a vibrafuge file cannot hold (:data:`~accelcal.io.formats.vibrafuge.MAX_MAGNITUDE`),
        or records that would not fit in memory
        (:func:`accelcal.resources.check_memory`).

    References
    ----------
    .. [1] Guan2021, eqs. (4)-(6) (inputs), (1)-(3) (output).
    """
    rng = seeded(seed, rng)
    vectors, A, u = _grid(overload, amplitude, direction)
    f = _positive(frequency, "frequency", "Hz")
    fs = _positive(sample_rate, "sample_rate", "Hz")
    T = _positive(duration, "duration", "s")
    if 2 * f >= fs:
        raise AccelcalError(f"{f} Hz is not below the Nyquist frequency {fs / 2} Hz",
                            parameter="frequency")
    if sampling not in SAMPLING:
        raise AccelcalError(f"{sampling!r} is not one of {', '.join(SAMPLING)}",
                            parameter="sampling")
    phase = float(phase)
    if not np.isfinite(phase):
        raise AccelcalError("must be a finite angle", parameter="phase")
    _recordable(phase, "phase", "rad")
    sigma = model.sigma if noise is None else float(noise)
    if not (np.isfinite(sigma) and sigma >= 0):
        raise AccelcalError(f"{sigma} g must be >= 0 and finite", parameter="noise")
    _recordable(sigma, "noise", "g")
    if sigma > 0 and rng is None:
        raise AccelcalError("noise > 0 needs a seed (or a random generator); or set noise = 0",
                            parameter="seed")
    quantum = float(quantum)
    if not (np.isfinite(quantum) and quantum >= 0):
        raise AccelcalError(f"{quantum} must be >= 0 and finite (0: no quantisation)",
                            parameter="quantum")
    _recordable(quantum, "quantum", model.output_unit)
    samples = T * fs
    check_memory(samples, A.size, MEMORY_FACTOR,
                 f"{A.size} vibrafuge points of {T:g} s at {fs:g} Hz",
                 hint="shorten the duration, lower the sample rate or test fewer points")
    work.simulated("vre", f"{A.size} vibrafuge points of {T:g} s at {fs:g} Hz",
                   float(samples) * A.size, parameter="duration",
                   hint="shorten the duration, lower the sample rate or test fewer points")
    _recordable(fs, "sample_rate", "Hz")  # after the memory check: its message says more
    n = round(samples)
    if n < 1:
        raise AccelcalError(f"{T} s at {fs} Hz gives no samples; record longer",
                            parameter="duration")

    felt = vectors
    if centrifuge is not None:
        if not callable(getattr(centrifuge, "overload", None)):
            raise AccelcalError("must be a CentrifugeRig", parameter="centrifuge")
        felt = centrifuge.overload(vectors)  # DOMAIN section 9: b from the centrifuge
        _specific_force(felt, A, u)
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is refused below
        static, vib = _records(model, felt, A[:, None] * u, (f, fs, n, phase), sampling,
                               sigma, rng)
        if quantum > 0:
            static, vib = np.round(static / quantum) * quantum, np.round(vib / quantum) * quantum
    if not (np.abs(static).max() <= MAX_MAGNITUDE and np.abs(vib).max() <= MAX_MAGNITUDE):
        raise AccelcalError(
            f"the simulated outputs overflow (exceed the {MAX_MAGNITUDE:g} {model.output_unit} "
            "a vibrafuge record holds, or are not finite): the overload, amplitude, noise or "
            "model coefficients are beyond any physical accelerometer; give smaller values"
        )
    return VibrafugeRun(
        static=np.array(static), vibrating=np.array(vib), overload=vectors, amplitude=A,
        direction=u, frequency=f, sample_rate=fs, phase=phase, scale_factor=model.K1,
        output_unit=model.output_unit, sampling=sampling, noise=sigma, quantum=quantum,
        simulated=True,
    )


def _records(model, vectors, amp, timing, sampling, sigma, rng):  # noqa: PLR0917
    """Static and vibrating outputs (output unit), shape (P, n) each.

    ``timing`` is (frequency, sample rate, samples, phase at t = 0).
    """
    f, fs, n, phase = timing
    A = amp.shape[0]
    theta = (2.0 * np.pi * f * (np.arange(n) / fs) + phase) % (2.0 * np.pi)  # (n,)
    static_g = model.output_g(vectors[:, 0], vectors[:, 1], vectors[:, 2])  # Eq. (5)
    static_g = np.broadcast_to(np.asarray(static_g)[:, None], (A, n))
    if sampling == "point":
        s = np.sin(theta)
        a = amp[:, :, None] * s + vectors[:, :, None]  # Eq. (6) [Guan2021]
        vib_g = model.output_g(a[:, 0], a[:, 1], a[:, 2])
    else:
        vib_g = _integrated_output(model, vectors, amp, theta, 2.0 * np.pi * f / fs)
    if sigma > 0:
        static_g = static_g + rng.normal(0.0, sigma, static_g.shape)
        vib_g = vib_g + rng.normal(0.0, sigma, vib_g.shape)
    return model.K1 * static_g, model.K1 * vib_g


def _sin_power_coefficients(model: ErrorModel, b: np.ndarray, amp: np.ndarray):
    """Coefficients c0..c4 of the polynomial part of the output in s = sin(theta).

    With ``a_j = A_j s + b_j``, the model's polynomial terms (all but the
    asymmetry) equal ``sum_k c_k s^k``.
    """
    bi, bo, bp = b[:, 0], b[:, 1], b[:, 2]
    Ai, Ao, Ap = amp[:, 0], amp[:, 1], amp[:, 2]
    m = model
    c = [m.K0 + bi + m.Ko * bo + m.Kp * bp, Ai + m.Ko * Ao + m.Kp * Ap, 0.0, 0.0, 0.0]
    # a_i powers: (A s + b)^k expanded.
    for coef, k in ((m.K2, 2), (m.K3, 3), (m.K4, 4)):
        for j in range(k + 1):
            binom = float(np.prod(np.arange(k - j + 1, k + 1)) / np.prod(np.arange(1, j + 1)))
            c[j] = c[j] + coef * binom * Ai**j * bi ** (k - j)
    # Quadratic cross terms K_jk a_j a_k.
    for coef, (Aj, bj), (Ak, bk) in (
        (m.Koo, (Ao, bo), (Ao, bo)), (m.Kpp, (Ap, bp), (Ap, bp)), (m.Kio, (Ai, bi), (Ao, bo)),
        (m.Kip, (Ai, bi), (Ap, bp)), (m.Kop, (Ao, bo), (Ap, bp)),
    ):
        c[0] = c[0] + coef * bj * bk
        c[1] = c[1] + coef * (Aj * bk + Ak * bj)
        c[2] = c[2] + coef * Aj * Ak
    return [np.asarray(ck, dtype=float)[:, None] * np.ones(1) for ck in c]


def _integrated_output(model, b, amp, theta, dtheta):
    """Mean of the output (g) over each sample interval [theta, theta + dtheta)."""
    c0, c1, c2, c3, c4 = _sin_power_coefficients(model, b, amp)
    mid = theta + 0.5 * dtheta
    # Bin mean of cos(k x) / sin(k x) is cos(k mid) D_k / sin(k mid) D_k,
    # D_k = sin(k dtheta / 2) / (k dtheta / 2); s^2, s^3, s^4 as harmonics.
    D = [np.sinc(k * dtheta / (2.0 * np.pi)) for k in range(5)]
    out = (c0 + 0.5 * c2 + 0.375 * c4
           + (c1 + 0.75 * c3) * np.sin(mid) * D[1]
           - (0.5 * c2 + 0.5 * c4) * np.cos(2 * mid) * D[2]
           - 0.25 * c3 * np.sin(3 * mid) * D[3]
           + 0.125 * c4 * np.cos(4 * mid) * D[4])
    if model.K0_asym or model.K1_asym:
        mean_sgn, mean_abs = _integrated_sign(b[:, 0], amp[:, 0], theta, dtheta)
        out = out + 0.5 * (model.K0_asym * mean_sgn + model.K1_asym * mean_abs)  # Eq. (3)
    return out


def _integrated_sign(bi, Ai, theta, dtheta):
    """Bin means of sgn(a_i) and |a_i| for a_i = A_i sin(theta) + b_i.

    Returns arrays of shape (P, n). A negative A_i is a half-period shift.
    """
    A = np.abs(Ai)[:, None]
    b = bi[:, None]
    x = (theta[None, :] + np.where(Ai < 0, np.pi, 0.0)[:, None]) % (2.0 * np.pi)
    y = x + dtheta
    mean_a = b + A * np.sin(x + 0.5 * dtheta) * np.sinc(dtheta / (2.0 * np.pi))
    crossing = np.abs(b) < A
    A_safe = np.where(crossing, A, 1.0)
    b_abs = np.where(crossing, np.abs(b), 0.0)
    leg = np.sqrt(((A_safe - b_abs) / A_safe) * ((A_safe + b_abs) / A_safe))
    # a_i < 0 on (3 pi/2 - half, 3 pi/2 + half), half = arccos(b / A)
    half = np.arctan2(leg, np.where(crossing, b, 0.0) / A_safe)
    meas = np.zeros(np.broadcast_shapes(x.shape, b.shape))
    integral = np.zeros_like(meas)
    for k in (-1, 0, 1):
        centre = 1.5 * np.pi + 2.0 * np.pi * k
        lo = np.maximum(x, centre - half)
        hi = np.minimum(y, centre + half)
        inside = crossing & (hi > lo)
        width = np.where(inside, hi - lo, 0.0)
        meas += width
        # Integral of A sin + b over (lo, hi): A (cos lo - cos hi) + b (hi - lo).
        integral += np.where(
            inside, 2.0 * A * np.sin(0.5 * (lo + hi)) * np.sin(0.5 * width) + b * width, 0.0
        )
    sign_b = np.sign(b)
    mean_sgn = np.where(crossing, 1.0 - 2.0 * meas / dtheta, sign_b)
    mean_abs = np.where(crossing, mean_a - 2.0 * integral / dtheta, sign_b * mean_a)
    return mean_sgn, mean_abs


def point_sampling_bound(model: ErrorModel, run: VibrafugeRun, distinct_phases: int):
    """Bound on the discretisation error of point-sampled whole-period means, g.

    Parameters
    ----------
    model : ErrorModel
        Supplies K0' and K1'.
    run : VibrafugeRun
        Gives the input-axis amplitude of each point.
    distinct_phases : int
        Number ``q`` of distinct vibration phases among the samples of the
        whole-period span (the denominator of ``f / fs`` in lowest terms).

    Returns
    -------
    numpy.ndarray, shape (P,)
        ``|K0'| / q + pi |K1'| A_i / (2 q)``: the mean of sgn over q
        equispaced phases is off by less than 2/q (less than one sample at
        each of the two sign changes), times K0'/2; the mean of |a_i|
        (Lipschitz in theta with constant A_i) is off by at most
        ``pi A_i / q``, times K1'/2. The polynomial terms are exact when
        ``q > 4`` (no harmonic up to the 4th aliases to zero frequency).

    References
    ----------
    .. [1] Guan2021, eq. (3) (the discontinuous term).
    """
    q = int(distinct_phases)
    Ai = np.abs(run.amplitude * run.direction[0])
    return abs(model.K0_asym) / q + 0.5 * np.pi * abs(model.K1_asym) * Ai / q
