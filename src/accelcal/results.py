"""What a reduction found: one :class:`Reduction` type for every method.

Coefficients are values and estimators are separate: every reduction
(indexing head single/four/joint/tumble, IEEE 1293 tumble, transverse
identification, VRE identification, and every method added later) returns
a frozen :class:`Reduction`. It holds, per sensor, an :class:`Estimate`
(coefficients with units, covariance, residuals, degrees of freedom), the
parameters shared by the sensors (e.g. the head's angle errors), the
combinations a deficient design still determines, typed
:class:`Assumption` s (fields, not sentences), and provenance. Tables, JSON,
calibration records, figures and report sections are produced from these
fields by one code path each (:mod:`accelcal.outputs`,
:mod:`accelcal.calibration`, :mod:`accelcal.report.sections`), never from
printed text.

References
----------
.. [1] python-control ``TimeResponseData`` (one result type for every
   simulation function, with ``to_pandas()`` and ``plot()``).
.. [2] JCGM 100:2008 (GUM) secs. 4.2, 6.2 (standard uncertainty, degrees
   of freedom, expanded uncertainty).
"""

import functools
from dataclasses import dataclass, field

import numpy as np

from accelcal.aliasing import Alias, Contribution, Prior
from accelcal.errors import AccelcalError
from accelcal.identifiability import Combination, Identifiability


def _frozen(a) -> np.ndarray:
    """A read-only float copy, or complex where ``a`` is complex."""
    arr = np.array(a)
    arr = arr.astype(complex if arr.dtype.kind == "c" else float, copy=False)
    arr.setflags(write=False)
    return arr


def _frozen_real(a, what: str) -> np.ndarray:
    """A read-only float copy of a covariance (never complex: see :mod:`accelcal.polar`)."""
    arr = np.array(a)
    if arr.dtype.kind == "c":
        raise ValueError(f"{what} must be real: a complex estimate's covariance is that of "
                         "[Re x1, Im x1, Re x2, ...] (accelcal.polar)")
    arr = arr.astype(float, copy=False)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class Estimate:
    """Estimated parameters of one sensor (or of the rig) with their covariance.

    Parameters
    ----------
    names : tuple of str
        Parameter names, in the order of ``values``.
    values : numpy.ndarray
        Estimates, shape ``(p,)``, real or complex (a frequency response's
        sensitivities); NaN where a parameter is not identifiable.
    covariance : numpy.ndarray
        Covariance of the estimates, always real: shape ``(p, p)`` for real
        values; for complex values shape ``(2p, 2p)``, the covariance of
        ``[Re x1, Im x1, Re x2, Im x2, ...]`` (GUM Supplement 2's real 2n
        representation, :mod:`accelcal.polar`), so the correlation of the
        real and imaginary parts and between coefficients is kept exactly.
        NaN rows and columns where a parameter is not identifiable. Infinite
        values are refused (AccelcalError): an overflow is never passed on
        as a result.
    units : dict
        Unit of each parameter by name.
    method : str
        Name of the reduction that produced it.
    residuals : numpy.ndarray, optional
        Residuals of the fit (observed minus fitted), in the data's unit.
    dof : int
        Degrees of freedom of the residuals (observations minus parameters).
    notes : tuple of str
        Caveats for people to read; no code reads them.
    provenance : dict
        Inputs' description (settings).
    labels : dict
        The reported name of a coefficient that estimates a combination
        (plain name -> e.g. ``"K0+Kpp"``, decided by
        :func:`accelcal.identifiability.combination_name`); a coefficient
        not in it is reported under its plain name. Either name finds it
        (``est["K0"]``, ``est["K0+Kpp"]``).

    Notes
    -----
    A complex coefficient's value (``est[name]``) is a Python ``complex``;
    its standard uncertainty (``std``, ``std_of``) is that of its magnitude,
    to first order from its 2x2 block (:func:`accelcal.polar.polar`), and
    :meth:`polar` gives magnitude and phase with both uncertainties.

    References
    ----------
    .. [1] JCGM 102:2011 (GUM Supplement 2), secs. 6.2.1.3 and 9.3.
    """

    names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    units: dict[str, str]
    method: str
    residuals: np.ndarray | None = None
    dof: int = 0
    notes: tuple[str, ...] = ()
    provenance: dict = field(default_factory=dict)
    labels: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        values = _frozen(self.values)
        cov = _frozen_real(self.covariance, "Estimate: the covariance")
        p = len(self.names)
        n = 2 * p if values.dtype.kind == "c" else p
        if values.shape != (p,) or cov.shape != (n, n):
            raise ValueError(
                f"Estimate: {p} names need values of shape ({p},) and covariance ({n}, {n}); "
                f"got {values.shape} and {cov.shape}"
            )
        if np.isinf(values).any() or np.isinf(cov).any():
            raise AccelcalError(
                f"{self.method}: the estimates or their uncertainties overflowed (infinite): an "
                "input value is far out of range; check the inputs' magnitudes and units"
            )
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "covariance", cov)
        object.__setattr__(self, "names", tuple(self.names))
        if self.residuals is not None:
            object.__setattr__(self, "residuals", _frozen(self.residuals))

    @property
    def is_complex(self) -> bool:
        """True when the values are complex (covariance of shape ``(2p, 2p)``)."""
        return self.values.dtype.kind == "c"

    @property
    def std(self) -> np.ndarray:
        """Standard uncertainties: square roots of the covariance diagonal.

        For complex values, those of the magnitudes (:meth:`polar`).
        """
        if self.is_complex:
            return self.polar().magnitude_std
        return np.sqrt(np.diag(self.covariance))

    def index(self, name: str) -> int:
        """Position of parameter ``name`` (its plain or its reported name)."""
        if name in self.names:
            return self.names.index(name)
        for plain, label in self.labels.items():
            if label == name:
                return self.names.index(plain)
        raise ValueError(f"{name!r} is not a parameter of this estimate")

    def label(self, name: str) -> str:
        """The reported name of parameter ``name`` (its combination name, if it has one)."""
        return self.labels.get(name, name)

    def __getitem__(self, name: str) -> float | complex:
        """The estimate of parameter ``name``, plain or reported (complex values: a complex)."""
        value = self.values[self.index(name)]
        return complex(value) if isinstance(value, np.complexfloating) else float(value)

    def std_of(self, name: str) -> float:
        """The standard uncertainty of parameter ``name`` (of its magnitude, if complex)."""
        i = self.index(name)
        if self.is_complex:
            return float(self.std[i])
        return float(np.sqrt(self.covariance[i, i]))

    def block(self, name: str) -> np.ndarray:
        """The 2x2 covariance of ``(Re, Im)`` of a complex parameter ``name``."""
        from accelcal.polar import stacked_index

        if not self.is_complex:
            raise ValueError(f"{self.method}: {name} is real; block() is for complex values")
        rows = stacked_index([self.index(name)])
        return self.covariance[np.ix_(rows, rows)]

    def polar(self):
        """Magnitudes, phases (rad) and their first-order standard uncertainties.

        Returns
        -------
        accelcal.polar.Polar
            Real values read as complex with a zero-variance imaginary part.
        """
        from accelcal.polar import polar

        if self.is_complex:
            return polar(self.values, self.covariance)
        cov = np.zeros((2 * len(self.names),) * 2)
        cov[::2, ::2] = self.covariance
        return polar(self.values, cov)

    def as_dict(self) -> dict[str, float | complex]:
        """Estimates by name."""
        return dict(zip(self.names, self.values.tolist(), strict=True))

    def rows(self) -> list[dict]:
        """One dict per parameter: name, estimate, std, unit (for tables and files).

        A complex parameter's ``estimate`` and ``std`` are its magnitude's;
        its row adds the keys of :func:`accelcal.outputs.complex_columns`.
        """
        if self.is_complex:
            from accelcal.outputs import complex_columns

            return [{"coefficient": n, **columns, "unit": self.units.get(n, "")}
                    for n, columns in zip(self.names, complex_columns(self), strict=True)]
        return [
            {"coefficient": n, "estimate": float(v), "std": float(s), "unit": self.units.get(n, "")}
            for n, v, s in zip(self.names, self.values, self.std, strict=True)
        ]

    def to_frame(self):
        """The estimates as a pandas DataFrame (pandas imported lazily)."""
        import pandas as pd

        return pd.DataFrame(self.rows()).set_index("coefficient")

    def residual_sigma(self) -> float:
        """Residual standard deviation ``sqrt(r'r / dof)`` (0 without residuals or dof).

        Complex residuals give ``sqrt(sum |r|^2 / dof)``.
        """
        if self.residuals is None or not self.dof:
            return 0.0
        if self.residuals.dtype.kind == "c":
            return float(np.sqrt(np.sum(np.abs(self.residuals) ** 2) / self.dof))
        return float(np.sqrt(np.sum(self.residuals**2) / self.dof))


@dataclass(frozen=True)
class Assumption:
    """One assumption a reduction made, as a field (never parsed from text).

    Attributes
    ----------
    name : str
        Machine name, e.g. ``"first_harmonic"``, ``"covariance"``,
        ``"amplitude"``; the method's docs list the names it sets.
    value : object
        The value: a number, a tuple of numbers, a string or a bool.
    unit : str
        Unit of a numeric value ('' otherwise).
    text : str
        The same for people (shown in tables, records and reports).
    """

    name: str
    value: object
    unit: str = ""
    text: str = ""

    def as_dict(self) -> dict:
        """JSON-ready form (tuples as lists)."""
        value = list(self.value) if isinstance(self.value, tuple) else self.value
        return {"name": self.name, "value": value, "unit": self.unit, "text": self.text}


STATUSES = ("fitted", "not identifiable", "fixed")
"""Status of a coefficient row: estimated, not separable by the design, or held fixed."""


@dataclass(frozen=True)
class Reduction:
    """The result of any reduction: what the data say about each sensor.

    Attributes
    ----------
    family : str
        The method's package under :mod:`accelcal.methods` (``"dividing-head"``,
        ``"tumble"``, ``"transverse"``, ``"vre"``, ...): the key of
        :data:`accelcal.methods.REGISTRY`, which finds its figures.
    method : str
        The reduction's id ``<family>/<route>``, as calibration records and
        the store carry it (``"dividing-head/joint"``, ``"tumble/fourier"``,
        ``"transverse/2w"``, ``"vre/identify"``); older ids are mapped by
        :mod:`accelcal.method_ids`.
    sensors : tuple of Estimate
        One per sensor: coefficients with units, covariance, residuals, dof.
    sensor_names : tuple of str
        Labels of the sensors (record-file columns, ``U1``...).
    shared : Estimate or None
        Parameters common to all sensors (e.g. the head's angle errors, rad).
    covariance : numpy.ndarray or None
        Full covariance of ``[sensor 1 coefficients, ..., shared]`` where the
        sensors are correlated (joint reductions); None when independent.
        Always real: a complex estimate's coefficients take two rows each
        (real and imaginary part, as in :class:`Estimate`).
    dof : int
        Degrees of freedom of the variance estimate behind the covariance
        (0 when the noise was given, not estimated).
    combinations : tuple of Combination
        Estimates of the combinations of non-identifiable coefficients that
        the design determines (with their sensor index).
    identifiability : Identifiability or None
        Rank, condition number, null space of the design (sensor 1's, when
        the sensors share one design).
    assumptions : tuple of Assumption
        What the reduction took as given.
    fixed : dict
        Coefficients held at given values (name -> value), for every sensor.
    observations : dict
        The data the fit used, as named read-only arrays (the abscissae of
        residual plots and the like); each method's docs list the names.
    models : tuple
        Per sensor, the :class:`~accelcal.model.ErrorModel` the estimates
        define, or None where they do not define one.
    quantities : dict
        Overrides of :data:`accelcal.engineering.QUANTITIES` by coefficient
        (e.g. ``{"Ko": "transverse"}`` for a shaker test).
    nominal : dict
        Nominal values of coefficients for ppm deviations: name -> one value
        for every sensor, or a tuple of one per sensor (:meth:`nominal_of`).
    provenance : dict
        Settings and inputs (JSON-ready values).
    notes : tuple of str
        Further caveats for people; no code reads them.
    type_b : tuple of Contribution
        Type B contributions of the priors of unestimated terms, itemised by
        row and input (:mod:`accelcal.aliasing`); already included in the
        sensors' covariances.
    aliases : tuple of Alias
        Alias-matrix entries of the unestimated terms: how much each row
        would move per unit of each (with or without a prior).
    priors : tuple of Prior
        The priors that were propagated.
    """

    family: str
    method: str
    sensors: tuple[Estimate, ...]
    sensor_names: tuple[str, ...] = ()
    shared: Estimate | None = None
    covariance: np.ndarray | None = None
    dof: int = 0
    combinations: tuple[Combination, ...] = ()
    identifiability: Identifiability | None = None
    assumptions: tuple[Assumption, ...] = ()
    fixed: dict = field(default_factory=dict)
    observations: dict = field(default_factory=dict)
    models: tuple = ()
    quantities: dict = field(default_factory=dict)
    nominal: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    type_b: tuple[Contribution, ...] = ()
    aliases: tuple[Alias, ...] = ()
    priors: tuple[Prior, ...] = ()

    def __post_init__(self) -> None:
        sensors = tuple(self.sensors)
        if not sensors:
            raise ValueError("Reduction: at least one sensor estimate is needed")
        names = tuple(self.sensor_names) or tuple(f"U{k + 1}" for k in range(len(sensors)))
        if len(names) != len(sensors):
            raise ValueError(f"Reduction: {len(names)} sensor names for {len(sensors)} sensors")
        object.__setattr__(self, "sensors", sensors)
        object.__setattr__(self, "sensor_names", names)
        if self.covariance is not None:
            object.__setattr__(self, "covariance",
                               _frozen_real(self.covariance, "Reduction: the covariance"))
        obs = {k: (_frozen(v) if not isinstance(v, str) else v)
               for k, v in self.observations.items()}
        object.__setattr__(self, "observations", obs)
        models = tuple(self.models) or (None,) * len(sensors)
        object.__setattr__(self, "models", models)
        for name in ("combinations", "assumptions", "notes", "type_b", "aliases", "priors"):
            object.__setattr__(self, name, tuple(getattr(self, name)))

    # ------------------------------------------------------------- access
    @property
    def n_sensors(self) -> int:
        """Number of sensors."""
        return len(self.sensors)

    @property
    def estimate(self) -> Estimate:
        """The one sensor's estimate (the first sensor's when there are several)."""
        return self.sensors[0]

    def value(self, name: str, sensor: int = 0) -> float | complex:
        """Estimate of coefficient ``name`` of sensor ``sensor`` (a ``complex`` if complex)."""
        return self.sensors[sensor][name]

    def std(self, name: str, sensor: int = 0) -> float:
        """Standard uncertainty of coefficient ``name`` of sensor ``sensor``.

        For a complex coefficient, that of its magnitude (first order; the
        phase's is in :meth:`Estimate.polar` and in :meth:`rows`).
        """
        return self.sensors[sensor].std_of(name)

    def residuals(self) -> np.ndarray:
        """Residuals of every sensor, stacked: shape ``(K, n)`` (data unit)."""
        return np.stack([np.asarray(e.residuals) for e in self.sensors])

    def assumption(self, name: str) -> Assumption | None:
        """The assumption called ``name``, or None when the reduction made none."""
        return next((a for a in self.assumptions if a.name == name), None)

    def assumed(self, name: str, default=None):
        """The value of assumption ``name`` (``default`` when absent)."""
        a = self.assumption(name)
        return default if a is None else a.value

    def status(self, name: str, sensor: int = 0) -> str:
        """``"fitted"``, ``"not identifiable"`` or ``"fixed"`` for one coefficient."""
        if name in self.fixed:
            return "fixed"
        est = self.sensors[sensor]
        i = est.index(name)
        return "fitted" if np.isfinite(est.values[i]) else "not identifiable"

    def unidentified(self, sensor: int = 0) -> tuple[str, ...]:
        """Coefficients of ``sensor`` that the design does not determine."""
        est = self.sensors[sensor]
        return tuple(n for n, v in zip(est.names, est.values, strict=True) if not np.isfinite(v))

    def nominal_of(self, name: str, sensor: int = 0) -> float | None:
        """The nominal value of coefficient ``name`` for ``sensor`` (None when not given)."""
        value = self.nominal.get(name)
        if isinstance(value, tuple | list):
            return float(value[sensor]) if sensor < len(value) else None
        return None if value is None else float(value)

    def scale_factor(self, sensor: int = 0) -> float | None:
        """The sensor's scale factor in output unit per g (``K_I`` or ``K1``), or None.

        Estimated (a finite ``K_I`` or ``K1`` coefficient) or given (the
        ``scale_factor`` assumption).
        """
        est = self.sensors[sensor]
        for name in ("K_I", "K1"):
            if name in est.names and not est.is_complex and np.isfinite(est[name]):
                return est[name]
        value = self.assumed("scale_factor")
        return float(value) if isinstance(value, int | float) else None

    def contributions(self, row: str, sensor: int = 0) -> tuple[Contribution, ...]:
        """The Type B contributions to one row (plain or reported name) of one sensor."""
        label = self.sensors[sensor].label(row)
        return tuple(c for c in self.type_b if c.sensor == sensor and c.row in (row, label))

    def dof_eff(self, row: str, sensor: int = 0) -> float:
        """Welch-Satterthwaite degrees of freedom of one row (GUM G.4.1).

        The Type A variance (the covariance less the Type B contributions)
        has the reduction's ``dof`` (infinite when the noise was given); each
        prior its own.
        """
        from accelcal.aliasing import welch_satterthwaite

        parts = self.contributions(row, sensor)
        var_a = max(self.std(row, sensor) ** 2 - sum(c.contribution**2 for c in parts), 0.0)
        return welch_satterthwaite(var_a, self.dof if self.dof > 0 else np.inf, parts)

    def coverage_under_priors(self) -> tuple:
        """What each row's stated 95 % interval covers with the terms following their priors.

        One :class:`accelcal.interval.RowCoverage` per real row with Type B
        (none for the others): the probability, computed without random
        draws, that ``estimate +- k u_c`` (``k`` of the row's :meth:`dof_eff`)
        holds the truth when each prior's term follows the prior's own
        distribution and the Type A part is a t with the reduction's dof.
        Computed once per reduction; it states, it never alters ``k`` or ``u_c``.
        """
        return self._coverage_rows

    @functools.cached_property
    def _coverage_rows(self) -> tuple:
        from accelcal.interval import coverages

        return tuple(coverages(self))

    # ------------------------------------------------------------- outputs
    def rows(self, *, engineering: bool = True) -> list[dict]:
        """One row per sensor and coefficient (and per fixed coefficient).

        Keys: ``sensor, coefficient, estimate, std, unit, status, dof``;
        where the reduction has Type B, ``coverage_under_priors`` (NaN for a
        row without: :meth:`coverage_under_priors`) and,
        where a coefficient has engineering units (:mod:`accelcal.engineering`),
        ``eng_estimate, eng_std, eng_unit`` (the first of them) and
        ``engineering`` (all of them, as a list of dicts). A complex
        coefficient's ``estimate`` and ``std`` are its magnitude's; its row
        adds ``real, imag, real_std, imag_std, magnitude, magnitude_std,
        phase_deg, phase_std_deg`` (:func:`accelcal.outputs.complex_columns`).
        """
        from accelcal.outputs import reduction_rows

        return reduction_rows(self, engineering=engineering)

    def to_frame(self):
        """The rows as a pandas DataFrame indexed by sensor and coefficient (pandas lazily)."""
        import pandas as pd

        rows = [{k: v for k, v in r.items() if k != "engineering"} for r in self.rows()]
        return pd.DataFrame(rows).set_index(["sensor", "coefficient"])

    def to_dict(self) -> dict:
        """Everything as JSON-ready data (NaN as None): see :func:`accelcal.outputs.to_dict`."""
        from accelcal.outputs import to_dict

        return to_dict(self)

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text."""
        import json

        return json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"

    @classmethod
    def from_dict(cls, data: dict, *, source: str = "<dict>") -> "Reduction":
        """Read :meth:`to_dict` back: see :func:`accelcal.outputs.from_dict`."""
        from accelcal.outputs import from_dict

        return from_dict(data, source=source, reduction=cls, estimate=Estimate,
                         assumption=Assumption)

    @classmethod
    def from_json(cls, text: str, *, source: str = "<string>") -> "Reduction":
        """Read :meth:`to_json` back (decoded with the bounded JSON reader)."""
        from accelcal.io.limits import load_json

        return cls.from_dict(load_json(text, source), source=source)

    def to_records(self, info, *, input_files=(), date: str | None = None) -> list:
        """One calibration record per sensor (:func:`accelcal.calibration.records`)."""
        from accelcal.calibration import records

        return records(self, info, input_files=input_files, date=date)

    def figures(self, **context) -> list:
        """The method's figures: ``(stem, title, matplotlib figure, caption)`` tuples.

        ``context`` passes what the reduction does not hold (e.g. ``truth``,
        a simulated head error to draw beside the separated one).
        """
        from accelcal.methods import figures_of

        return figures_of(self, **context)

    def plot(self, directory, **context) -> list:
        """Write :meth:`figures` to ``directory`` as PNG and SVG; return the paths."""
        from accelcal.plotting import save_figure

        paths = []
        for stem, _title, fig, _caption in self.figures(**context):
            paths += save_figure(fig, directory, stem)
        return paths
