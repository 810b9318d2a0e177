"""The triad model: bias, scale factor, non-orthogonality and optional quadratic terms.

Three sensitive axes in one housing map their raw output ``u`` (counts,
volts or nominal m/s^2: the *input unit*) to the specific force ``a`` in
m/s^2 in the body frame:

    p = K (u - b)                           K = diag(s_x, s_y, s_z)   # Eq. (1) [Tedaldi2014]
    a = T (p + q ⊙ p²)                      q = (q_x, q_y, q_z), 1/(m/s^2)
    T = [[1, -a_yz,  a_zy],
         [0,  1,    -a_zx],
         [0,  0,     1   ]]                 angles in rad           # Eq. (8) [Tedaldi2014]

with ``b`` in the input unit, ``s`` in (m/s^2)/(input unit) and ``q`` the
per-axis quadratic term on the scaled axis reading ``p`` (zero unless
fitted). **Body frame** (the gauge the upper-triangular ``T`` fixes, derived
in docs/triad.md): z_body lies along the sensor's z axis and y_body in the
plane of the sensor's y and z axes; x_body completes a right-handed frame.
The sensor axes (unit rows ``n_i``) are the rows of ``T^-1`` divided by
their norms, and ``s_i`` is the axis's sensitivity divided by the cosine
of ``n_i`` to the body axis (both from ``T^-1``, exactly).

:class:`TriadCalibration` holds one calibration, applies it (vectorised),
inverts it (the readings of a given specific force, for simulation), and
writes and reads it (accelcal's JSON, imucal's ``K_a, R_a, b_a`` layout).

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., "A robust and easy to
   implement method for IMU calibration without external equipments", ICRA
   2014, eqs. (1)-(8) (accelerometer model, triangular misalignment).
.. [Ferraris1995] Ferraris F., Grimaldi U., Parvis M., "Procedure for
   effortless in-field calibration of three-axis rate gyros and
   accelerometers", Sensors and Materials 7(5), 1995 (K_a, R_a, b_a layout
   that imucal implements).
"""

import json
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.limits import MAX_JSON_BYTES, load_json
from accelcal.methods.triad.frames import t_matrix
from accelcal.validation import shown

PARAMS = ("b_x", "b_y", "b_z", "s_x", "s_y", "s_z", "a_yz", "a_zy", "a_zx")
"""The nine parameters of the linear model, in the order of every vector and covariance."""

QUADRATIC = ("q_x", "q_y", "q_z")
"""The optional per-axis quadratic terms, 1/(m/s^2), appended after :data:`PARAMS`."""

OUTPUT_UNIT = "m/s^2"
"""Unit of the calibrated specific force."""

FORMAT = "accelcal-triad-calibration"
FORMAT_VERSION = 1

MAX_ANGLE = 0.5
"""Largest non-orthogonality angle accepted, rad (29 deg): T stays well conditioned and
the small-angle reading of the angles holds to a few per cent; real triads are within mrad."""

ORTHOGONAL_TOL = 1e-9
"""Largest ``|R' R - I|`` entry of a rotation accepted (rounding of a JSON-written matrix)."""


def input_units() -> tuple[str, ...]:
    """Units a triad's raw output may have (those of :mod:`accelcal.io.recordings`)."""
    from accelcal.io.recordings.options import UNITS

    return tuple(UNITS)


def nominal_factor(unit: str) -> float | None:
    """m/s^2 per ``unit`` for an acceleration unit (the nominal conversion), else None."""
    from accelcal.io.recordings.options import ACCELERATION_UNITS

    return ACCELERATION_UNITS.get(unit)


def units_of(input_unit: str, quadratic: bool = False) -> dict[str, str]:
    """Unit of every parameter for a triad whose output is in ``input_unit``."""
    out = {f"b_{c}": input_unit for c in "xyz"}
    out.update({f"s_{c}": f"(m/s^2)/({input_unit})" for c in "xyz"})
    out.update(dict.fromkeys(PARAMS[6:], "rad"))
    if quadratic:
        out.update(dict.fromkeys(QUADRATIC, "s^2/m"))
    return out


def _vector(value, name: str, *, nonzero: bool = False) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise AccelcalError(f"must be three numbers, got {shown(value)}", parameter=name) from None
    if arr.shape != (3,) or not np.isfinite(arr).all():
        got = shown(arr.tolist()) if arr.shape == (3,) else f"shape {arr.shape}"
        raise AccelcalError(f"must be three finite numbers, got {got}", parameter=name)
    if nonzero and (arr == 0).any():
        raise AccelcalError("scale factors must be non-zero", parameter=name)
    arr.setflags(write=False)
    return arr


def check_rotation(value, name: str = "rotation") -> np.ndarray:
    """A proper 3x3 rotation matrix (orthogonal to :data:`ORTHOGONAL_TOL`, det +1), read-only."""
    try:
        r = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise AccelcalError("must be a 3x3 matrix of numbers", parameter=name) from None
    if r.shape != (3, 3) or not np.isfinite(r).all():
        raise AccelcalError(f"must be a finite 3x3 matrix, got shape {r.shape}", parameter=name)
    if np.abs(r.T @ r - np.eye(3)).max() > ORTHOGONAL_TOL or np.linalg.det(r) < 0:
        raise AccelcalError("must be a proper rotation (orthogonal, determinant +1)",
                            parameter=name)
    r.setflags(write=False)
    return r


@dataclass(frozen=True, eq=False)
class TriadCalibration:
    """One triad calibration: ``a = T (p + q ⊙ p²)``, ``p = K (u - b)`` (module docs).

    Parameters
    ----------
    bias : array_like, shape (3,)
        b, input unit.
    scale : array_like, shape (3,)
        s, (m/s^2)/(input unit); non-zero.
    angles : array_like, shape (3,)
        (a_yz, a_zy, a_zx), rad; each within +-:data:`MAX_ANGLE`.
    quadratic : array_like, shape (3,), optional
        q, 1/(m/s^2); None for the linear model.
    input_unit : str
        Unit of the raw output (one of :func:`input_units`).
    rotation : array_like, shape (3, 3), optional
        Body-to-reference rotation (a gauge): the fixture frame of a
        known-orientation calibration or the frame of an imported imucal
        calibration. ``apply(u, frame="reference")`` applies it.
    """

    bias: np.ndarray
    scale: np.ndarray
    angles: np.ndarray
    quadratic: np.ndarray | None = None
    input_unit: str = "m/s^2"
    rotation: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "bias", _vector(self.bias, "bias"))
        object.__setattr__(self, "scale", _vector(self.scale, "scale", nonzero=True))
        angles = _vector(self.angles, "angles")
        if np.abs(angles).max() > MAX_ANGLE:
            raise AccelcalError(f"non-orthogonality angles must be within +-{MAX_ANGLE} rad; got "
                                f"{shown(angles.tolist())}", parameter="angles")
        object.__setattr__(self, "angles", angles)
        if self.quadratic is not None:
            object.__setattr__(self, "quadratic", _vector(self.quadratic, "quadratic"))
        if self.rotation is not None:
            object.__setattr__(self, "rotation", check_rotation(self.rotation))
        if self.input_unit not in input_units():
            raise AccelcalError(f"{shown(self.input_unit)} is not a known unit; use one of "
                                + ", ".join(input_units()), parameter="input_unit")

    # ------------------------------------------------------------------ the model
    @property
    def t(self) -> np.ndarray:
        """The non-orthogonality matrix T."""
        return t_matrix(self.angles)

    @property
    def matrix(self) -> np.ndarray:
        """``T K``: the linear map of ``u - b`` to the body-frame specific force."""
        return self.t * self.scale[None, :]

    @property
    def vector(self) -> np.ndarray:
        """The parameters in the order of :data:`PARAMS` (then :data:`QUADRATIC` if any)."""
        parts = [self.bias, self.scale, self.angles]
        if self.quadratic is not None:
            parts.append(self.quadratic)
        return np.concatenate(parts)

    @classmethod
    def from_vector(cls, values, input_unit: str = "m/s^2", rotation=None) -> "TriadCalibration":
        """A calibration from 9 (linear) or 12 (quadratic) values in :data:`PARAMS` order."""
        v = np.asarray(values, dtype=float)
        if v.shape not in ((9,), (12,)):
            raise AccelcalError(f"need 9 or 12 parameter values, got shape {v.shape}",
                                parameter="values")
        return cls(v[0:3], v[3:6], v[6:9], v[9:12] if v.size == 12 else None, input_unit,
                   rotation)

    def _check_u(self, u, name: str) -> tuple[np.ndarray, bool]:
        arr = np.asarray(u, dtype=float)
        single = arr.ndim == 1
        arr = np.atleast_2d(arr)
        if arr.ndim != 2 or arr.shape[1] != 3:
            raise AccelcalError(f"must have shape (n, 3), got {np.shape(u)}", parameter=name)
        return arr, single

    def apply(self, u, *, frame: str = "body") -> np.ndarray:
        """Specific force ``a`` (m/s^2) of raw outputs ``u`` (input unit), row by row.

        Parameters
        ----------
        u : array_like, shape (n, 3) or (3,)
        frame : {"body", "reference"}
            ``"reference"`` also applies :attr:`rotation` (when there is one).

        Returns
        -------
        numpy.ndarray, same shape as ``u``
        """
        arr, single = self._check_u(u, "u")
        p = (arr - self.bias) * self.scale
        if self.quadratic is not None:
            p = p + self.quadratic * p * p
        a = p @ self.t.T
        if frame == "reference" and self.rotation is not None:
            a = a @ self.rotation.T
        elif frame not in ("body", "reference"):
            raise AccelcalError(f"{shown(frame)} must be 'body' or 'reference'", parameter="frame")
        return a[0] if single else a

    def readings(self, a, *, frame: str = "body") -> np.ndarray:
        """The raw outputs ``u`` whose calibrated specific force is ``a`` (inverse of apply).

        The quadratic inverse takes the root of ``p + q p² = w`` continuous at
        ``q = 0``, ``p = 2 w / (1 + sqrt(1 + 4 q w))``; a specific force beyond
        the turning point of the quadratic (``1 + 4 q w < 0``) is refused.
        """
        arr, single = self._check_u(a, "a")
        if frame == "reference" and self.rotation is not None:
            arr = arr @ self.rotation
        w = np.linalg.solve(self.t, arr.T).T
        if self.quadratic is not None:
            disc = 1.0 + 4.0 * self.quadratic * w
            if (disc <= 0).any():
                raise AccelcalError("the specific force is beyond the range where the quadratic "
                                    "model can be inverted", parameter="a")
            w = 2.0 * w / (1.0 + np.sqrt(disc))
        u = w / self.scale + self.bias
        return u[0] if single else u

    # ----------------------------------------------------------------- files
    def to_dict(self) -> dict:
        """JSON-ready form (see :meth:`from_dict`)."""
        params = dict(zip(PARAMS, (float(x) for x in self.vector[:9]), strict=True))
        if self.quadratic is not None:
            params.update(zip(QUADRATIC, (float(x) for x in self.quadratic), strict=True))
        return {"format": FORMAT, "format_version": FORMAT_VERSION,
                "input_unit": self.input_unit, "output_unit": OUTPUT_UNIT,
                "model": "a = T (p + q*p^2), p = diag(s) (u - b)",
                "parameters": params,
                "rotation": None if self.rotation is None else self.rotation.tolist()}

    @classmethod
    def from_dict(cls, data, where: str = "triad calibration") -> "TriadCalibration":
        """A calibration from :meth:`to_dict`'s form; one-line errors naming ``where``."""
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise AccelcalError(f"{where}: not an accelcal triad calibration (no "
                                f"\"format\": \"{FORMAT}\")")
        if data.get("format_version") != FORMAT_VERSION:
            raise AccelcalError(f"{where}: format_version {shown(data.get('format_version'))} "
                                f"is not supported (this accelcal reads {FORMAT_VERSION})")
        params = data.get("parameters")
        if not isinstance(params, dict):
            raise AccelcalError(f"{where}: \"parameters\" must be an object")
        missing = [n for n in PARAMS if n not in params]
        if missing:
            raise AccelcalError(f"{where}: parameters lack {', '.join(missing)}")
        quad = [n for n in QUADRATIC if n in params]
        if quad and len(quad) != 3:
            raise AccelcalError(f"{where}: give all of {', '.join(QUADRATIC)} or none")
        names = PARAMS + (QUADRATIC if quad else ())
        values = [params[n] for n in names]
        bad = [n for n, v in zip(names, values, strict=True)
               if isinstance(v, bool) or not isinstance(v, int | float)]
        if bad:
            raise AccelcalError(f"{where}: parameter {bad[0]} must be a number, got "
                                f"{shown(params[bad[0]])}")
        try:
            return cls.from_vector(values, data.get("input_unit", "m/s^2"), data.get("rotation"))
        except AccelcalError as exc:
            raise AccelcalError(f"{where}: {exc}") from None

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text (full precision)."""
        return json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"

    def save(self, path) -> None:
        """Write :meth:`to_json` to ``path`` atomically."""
        from accelcal.io.atomic import write_text_atomic

        write_text_atomic(path, self.to_json())

    @classmethod
    def load(cls, path) -> "TriadCalibration":
        """Read a calibration written by :meth:`save` (bounded read, one-line errors)."""
        from accelcal.io.limits import read_bounded
        from accelcal.validation import shown_path

        where = f"triad calibration {shown_path(path)}"
        try:
            raw = read_bounded(path, MAX_JSON_BYTES, "triad calibration")
        except OSError as exc:
            raise AccelcalError(f"cannot read {where}: {exc.strerror or exc}") from None
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise AccelcalError(f"{where} is not UTF-8 text; is it the right file?") from None
        return cls.from_dict(load_json(text, where), where)

    # ---------------------------------------------------------------- imucal
    def to_imucal(self) -> dict:
        """The calibration in imucal's layout ``{"K_a", "R_a", "b_a"}`` (nested lists).

        imucal calibrates ``acc = R_a^-1 K_a^-1 (u - b_a)``
        (``FerrarisCalibrationInfo._calibrate_acc``), so ``K_a R_a`` is the
        inverse of this calibration's map (``rotation T K`` when a rotation
        is held): ``K_a`` the norms of its rows, ``R_a`` the unit rows, as
        imucal's Ferraris computation makes them [Ferraris1995]. Exact: the
        two give the same ``acc`` to rounding.

        Raises
        ------
        AccelcalError
            For a calibration with quadratic terms (imucal has none).
        """
        if self.quadratic is not None and np.any(self.quadratic != 0):
            raise AccelcalError("imucal's layout has no quadratic terms; export a linear "
                                "calibration", parameter="quadratic")
        m = self.matrix if self.rotation is None else self.rotation @ self.matrix
        inv = np.linalg.inv(m)  # = K_a R_a
        k = np.linalg.norm(inv, axis=1)
        return {"K_a": np.diag(k).tolist(), "R_a": (inv / k[:, None]).tolist(),
                "b_a": self.bias.tolist()}

    @classmethod
    def from_imucal(cls, data, input_unit: str = "m/s^2") -> "TriadCalibration":
        """A calibration from imucal's ``{"K_a", "R_a", "b_a"}`` (any extra keys ignored).

        ``K_a R_a = (rotation T K)^-1 = K^-1 T^-1 rotation'`` is an RQ
        decomposition (upper-triangular times orthogonal,
        :func:`accelcal.methods.triad.split.rq_split`): the triangular factor
        gives ``s`` and ``T``, the orthogonal one the gauge, held as
        :attr:`rotation`. ``apply(u, frame="reference")`` then equals imucal's
        ``acc`` to rounding.

        Raises
        ------
        AccelcalError
            For missing or malformed matrices, or a singular ``K_a R_a``.
        """
        from accelcal.methods.triad.split import rq_split

        if not isinstance(data, dict):
            raise AccelcalError("an imucal calibration must be a mapping with K_a, R_a, b_a",
                                parameter="data")
        arrays = {}
        for key, shape in (("K_a", (3, 3)), ("R_a", (3, 3)), ("b_a", (3,))):
            try:
                arr = np.array(data[key], dtype=float)
            except KeyError:
                raise AccelcalError(f"the imucal calibration lacks {key}",
                                    parameter="data") from None
            except (TypeError, ValueError):
                raise AccelcalError(f"imucal {key} must hold numbers", parameter="data") from None
            if arr.shape != shape or not np.isfinite(arr).all():
                raise AccelcalError(f"imucal {key} must be finite of shape {shape}, got "
                                    f"{arr.shape}", parameter="data")
            arrays[key] = arr
        m = arrays["K_a"] @ arrays["R_a"]
        if not np.linalg.cond(m) < 1e12:
            raise AccelcalError("imucal K_a R_a is singular", parameter="data")
        scale, angles, orth, _ = rq_split(m)
        return cls(arrays["b_a"], scale, angles, None, input_unit, orth.T)
