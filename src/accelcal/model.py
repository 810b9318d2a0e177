"""The accelerometer error model: IEEE 1293 style terms plus asymmetry.

One model covers the three seed papers. With specific force components
a_i, a_o, a_p in g along the input (IA), output (OA) and pendulum (PA) axes,
the indicated acceleration in g is ::

    E/K1 = K0 + a_i + K2 a_i^2 + K3 a_i^3 + K4 a_i^4 + Ko a_o + Kp a_p
           + Koo a_o^2 + Kpp a_p^2 + Kio a_i a_o + Kip a_i a_p + Kop a_o a_p
           + 1/2 sgn(a_i) (K0' + K1' a_i) + eps

with sgn(0) = 0 and eps ~ N(0, sigma^2) in g; the output E is that times the
scale factor K1 in the model's output unit per g. A model may carry
:class:`~accelcal.terms.TemperatureTerms`: K0, K1, K2, Ko, Kp as polynomials
in the sensor temperature about T0 (evaluated when a temperature is given).

References
----------
.. [Guan2021] Guan W., Asymmetry coefficient errors of accelerometer under
   overload-vibration environment, Metrology & Measurement Technology 41(3),
   2021, eqs. (1)-(3).
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eq. (13).
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [IEEE1293] IEEE Std 1293-2018, model equation with K4.
.. [DOMAIN] accelcal domain notes, section 8 (temperature polynomials).
"""

import numbers
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.physics.equation import MAX_SPECIFIC_FORCE_G, check_output, indicated_g
from accelcal.terms import (
    TERMS,
    TemperatureTerms,
    Term,
    check_temperature,
    term_unit,
    unknown_term,
    unknown_term_message,
)
from accelcal.units import OUTPUT_UNITS, OutputUnit
from accelcal.validation import shown

__all__ = ["MAX_SPECIFIC_FORCE_G", "TERMS", "ErrorModel", "TemperatureTerms", "Term", "term_unit",
           "unknown_term_message"]


_GUANTANG = {
    "k_i": "K1",
    "k_0": "K0",
    "k_ii": "K2",
    "k_iii": "K3",
    "k_o": "Ko",
    "k_p": "Kp",
    "k_oo": "Koo",
    "k_pp": "Kpp",
    "k_op": "Kop",
    "k_io": "Kio",
    "k_ip": "Kip",
}
"""GuanTang eq. (13) notation -> accelcal term names (no asymmetry terms)."""

_DONG2014 = ("K_F", "K_I", "K_O", "K_IO", "K_II")
"""Dong2014 eq. (5) coefficients, all in the output unit (volts)."""


@dataclass(frozen=True, slots=True)
class ErrorModel:
    """Error model of a single-axis pendulous accelerometer.

    Every coefficient is a finite float. Coefficients are in g per g^n (so the
    model is independent of the output unit) except the scale factor ``K1``,
    in ``output_unit`` per g, and the noise ``sigma``, in g. See
    :data:`TERMS` for each term's unit and meaning.

    Parameters
    ----------
    K0 : float
        Bias, g.
    K1 : float
        Scale factor, output unit per g. Must be non-zero.
    K2, K3, K4 : float
        Second-, third- and fourth-order nonlinearity, g/g^2, g/g^3, g/g^4.
    Ko, Kp : float
        Cross-axis sensitivities to the output and pendulum axes, g/g.
    Koo, Kpp : float
        Cross-axis nonlinearities, g/g^2.
    Kio, Kip, Kop : float
        Cross-coupling coefficients, g/g^2.
    K0_asym : float
        Bias asymmetry K0', g.
    K1_asym : float
        Scale-factor asymmetry K1', dimensionless.
    sigma : float
        Standard deviation of the output noise, g. Must be >= 0.
    output_unit : {"V", "mV", "mA", "g"}
        Unit of the output E.
    temperature : TemperatureTerms, optional
        Temperature coefficients about a reference T0; the terms above hold
        at T0. None (the default): the coefficients do not depend on
        temperature.

    References
    ----------
    .. [1] Guan2021, eqs. (1)-(3); IEEE Std 1293-2018 model equation.

    Examples
    --------
    >>> m = ErrorModel(K0=1e-4, K1=1.25, K2=1e-5, K0_asym=2e-6)
    >>> m.output([-1.0, 0.0, 1.0]).round(9)  # volts; sgn(0) = 0 drops K0' at zero
    array([-1.24986375e+00,  1.25000000e-04,  1.25013875e+00])
    """

    K0: float = 0.0
    K1: float = 1.0
    K2: float = 0.0
    K3: float = 0.0
    K4: float = 0.0
    Ko: float = 0.0
    Kp: float = 0.0
    Koo: float = 0.0
    Kpp: float = 0.0
    Kio: float = 0.0
    Kip: float = 0.0
    Kop: float = 0.0
    K0_asym: float = 0.0
    K1_asym: float = 0.0
    sigma: float = 0.0
    output_unit: OutputUnit = "V"
    temperature: TemperatureTerms | None = None

    def __post_init__(self) -> None:
        for name in TERMS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise AccelcalError(
                    f"ErrorModel term {name} must be a real number, "
                    f"got {_shown_repr(value)} ({type(value).__name__})"
                )
            value = float(value)
            if not np.isfinite(value):
                raise AccelcalError(
                    f"ErrorModel term {name} = {value} is not finite; give a finite number"
                )
            object.__setattr__(self, name, value)
        if self.K1 == 0.0:
            raise AccelcalError(
                "ErrorModel term K1 (scale factor) is 0; it must be non-zero "
                "(use K1 = 1 for an output in g)"
            )
        if self.sigma < 0.0:
            raise AccelcalError(f"ErrorModel term sigma = {self.sigma} is negative; give >= 0")
        if self.output_unit not in OUTPUT_UNITS:
            raise AccelcalError(
                f"ErrorModel output_unit {shown(self.output_unit)} is not one of "
                f"{', '.join(OUTPUT_UNITS)}"
            )
        if self.temperature is not None and not isinstance(self.temperature, TemperatureTerms):
            raise AccelcalError("ErrorModel temperature must be a TemperatureTerms or None")

    # ------------------------------------------------------------------ output
    def output_g(self, a_i, a_o=0.0, a_p=0.0, *, rng: np.random.Generator | None = None,
                 temperature=None):
        """Indicated acceleration E/K1 in g.

        Parameters
        ----------
        a_i, a_o, a_p : array_like
            Specific force along IA, OA and PA in g. They broadcast against
            each other with numpy rules (any leading shape).
        rng : numpy.random.Generator, optional
            When given and ``sigma > 0``, adds independent Gaussian noise of
            standard deviation ``sigma`` to every output. Without it the
            output is the noise-free model.
        temperature : array_like, optional
            Sensor temperature, degC (broadcast with the inputs): the
            coefficients are evaluated there (:meth:`terms_at`). Without it,
            or without temperature terms, they are the model's own.

        Returns
        -------
        numpy.ndarray or float
            E/K1 in g (E/K1(T) with a temperature), of the broadcast shape
            of the inputs.

        Raises
        ------
        AccelcalError
            If an input is not finite or beyond :data:`MAX_SPECIFIC_FORCE_G`
            in magnitude, or the output overflows (coefficients too large
            for the inputs).

        References
        ----------
        .. [1] Guan2021, eqs. (1)-(3).
        """
        return self._output_g(self._coefficients(temperature), a_i, a_o, a_p, rng)

    def _coefficients(self, temperature) -> dict:
        return self.terms() if temperature is None else self.terms_at(temperature)

    @staticmethod
    def _output_g(c: dict, a_i, a_o, a_p, rng):
        u = indicated_g(c, a_i, a_o, a_p)
        sigma = c["sigma"]
        if rng is not None and sigma > 0.0:
            u = u + rng.normal(0.0, sigma, size=np.shape(u))
        return u

    def output(self, a_i, a_o=0.0, a_p=0.0, *, rng: np.random.Generator | None = None,
               temperature=None):
        """Output E in the model's output unit: ``K1 * output_g(...)`` (K1(T) at a temperature).

        Parameters and noise are as in :meth:`output_g`.

        References
        ----------
        .. [1] Guan2021, eq. (1): E = K1 U.
        """
        c = self._coefficients(temperature)
        with np.errstate(over="ignore"):
            out = c["K1"] * self._output_g(c, a_i, a_o, a_p, rng)
        return check_output(out)

    def terms_at(self, temperature) -> dict:
        """Every coefficient at sensor temperature T (degC), by name (arrays for array T).

        ``K(T) = K + sum_k K_Tk (T - T0)^k`` for the additive terms and
        ``K1(T) = K1 (1 + sum_k K1_Tk (T - T0)^k)`` [DOMAIN section 8]; terms
        without temperature coefficients are the model's own.

        Raises
        ------
        AccelcalError
            For temperatures that are not finite, or outside the temperature
            terms' valid range.
        """
        c = self.terms()
        if self.temperature is None:
            check_temperature(temperature)
            return c
        return self.temperature.apply(c, temperature)

    def at_temperature(self, temperature: float) -> "ErrorModel":
        """The model at one sensor temperature (degC), without temperature terms."""
        c = self.terms_at(float(temperature))
        return ErrorModel.from_terms({k: float(v) for k, v in c.items()},
                                     output_unit=self.output_unit)

    # ------------------------------------------------------------------ terms
    def terms(self) -> dict[str, float]:
        """Every coefficient by name, in :data:`TERMS` order."""
        return {name: getattr(self, name) for name in TERMS}

    def units(self) -> dict[str, str]:
        """The unit of every coefficient, with the output unit filled in."""
        return {name: term_unit(name, self.output_unit) for name in TERMS}

    @classmethod
    def from_terms(
        cls, terms: Mapping[str, object], output_unit: OutputUnit = "V", *, base=None
    ) -> "ErrorModel":
        """Build a model from a mapping of term names to values.

        Parameters
        ----------
        terms : mapping
            Term name (see :data:`TERMS`) to value. Terms not given take the
            value of ``base``, or zero (``K1 = 1``) without one.
        output_unit : {"V", "mV", "mA", "g"}
            Output unit, when ``base`` is not given.
        base : ErrorModel, optional
            Model whose terms and output unit fill in what ``terms`` omits.

        Raises
        ------
        AccelcalError
            For a name that is not a term (the message lists the valid ones)
            or an invalid value.
        """
        for name in terms:
            if name not in TERMS:
                raise AccelcalError(unknown_term(name))
        if base is not None:
            return cls(**{**base.terms(), **terms}, output_unit=base.output_unit,
                       temperature=base.temperature)
        return cls(**terms, output_unit=output_unit)

    def replace(self, **terms) -> "ErrorModel":
        """A copy with some terms changed, validated like the constructor.

        ``output_unit`` may be given too; it relabels the unit without
        rescaling K1; so may ``temperature`` (TemperatureTerms or None).
        """
        unit = terms.pop("output_unit", self.output_unit)
        temperature = terms.pop("temperature", self.temperature)
        model = ErrorModel.from_terms({**self.terms(), **terms}, output_unit=unit)
        return model if temperature is None else ErrorModel(
            **model.terms(), output_unit=unit, temperature=temperature)

    # -------------------------------------------------------- paper notations
    @classmethod
    def from_guantang(cls, *, output_unit: OutputUnit = "mV", sigma=0.0, **coefficients):
        """Model from GuanTang's notation, eq. (13).

        Parameters
        ----------
        output_unit : {"V", "mV", "mA", "g"}
            Unit of k_i's numerator (the paper uses mV/g).
        sigma : float
            Noise standard deviation in g (the paper's epsilon).
        **coefficients
            Any of k_i (output unit per g), k_0, k_ii, k_iii, k_o, k_p, k_oo,
            k_pp, k_op, k_io, k_ip (g per g^n). Missing ones are zero
            (k_i = 1).

        References
        ----------
        .. [1] GuanTang, eq. (13); mapping in docs/domain.md section 1.
        """
        mapped = {}
        for name, value in coefficients.items():
            if name not in _GUANTANG:
                raise AccelcalError(unknown_term(name, _GUANTANG))
            mapped[_GUANTANG[name]] = value
        return cls.from_terms({**mapped, "sigma": sigma}, output_unit=output_unit)

    def to_guantang(self) -> dict[str, float]:
        """Coefficients in GuanTang's notation (eq. (13)).

        Raises
        ------
        AccelcalError
            If the model has terms GuanTang's model lacks (K4, asymmetry).
        """
        _require_zero(self, ("K4", "K0_asym", "K1_asym"), "GuanTang eq. (13)")
        return {paper: getattr(self, ours) for paper, ours in _GUANTANG.items()}

    @classmethod
    def from_dong2014(
        cls, K_F, K_I, K_O=0.0, K_IO=0.0, K_II=0.0, *, output_unit: OutputUnit = "V", sigma=0.0
    ) -> "ErrorModel":
        """Model from Dong2014's notation, eq. (5), all in the output unit.

        ``U = K_F + K_I a_i + K_O a_o + K_IO a_i a_o + K_II a_i^2``, so
        K1 = K_I, K0 = K_F/K_I, Ko = K_O/K_I, Kio = K_IO/K_I, K2 = K_II/K_I.

        Parameters
        ----------
        K_F, K_I, K_O, K_IO, K_II : float
            Bias, scale factor (per g), cross-axis, cross-coupling and
            second-order coefficients in the output unit.
        output_unit : {"V", "mV", "mA", "g"}
            The unit they are given in (volts in the paper).
        sigma : float
            Noise standard deviation in the output unit (the paper's epsilon);
            stored in g as ``sigma / K_I``.

        References
        ----------
        .. [1] Dong2014, eq. (5).
        """
        K_I = _real("K_I", K_I)
        if K_I == 0.0:
            raise AccelcalError("Dong2014 scale factor K_I is 0; it must be non-zero")
        return cls(
            K0=_real("K_F", K_F) / K_I,
            K1=K_I,
            Ko=_real("K_O", K_O) / K_I,
            Kio=_real("K_IO", K_IO) / K_I,
            K2=_real("K_II", K_II) / K_I,
            sigma=abs(_real("sigma", sigma) / K_I),
            output_unit=output_unit,
        )

    def to_dong2014(self) -> dict[str, float]:
        """Coefficients in Dong2014's notation (eq. (5)), in the output unit.

        Raises
        ------
        AccelcalError
            If the model has terms Dong2014's model lacks (K3, K4, PA terms,
            Koo, Kop, asymmetry): the notation cannot carry them.
        """
        _require_zero(
            self,
            ("K3", "K4", "Kp", "Koo", "Kpp", "Kip", "Kop", "K0_asym", "K1_asym"),
            "Dong2014 eq. (5)",
        )
        return {
            "K_F": self.K1 * self.K0,
            "K_I": self.K1,
            "K_O": self.K1 * self.Ko,
            "K_IO": self.K1 * self.Kio,
            "K_II": self.K1 * self.K2,
        }

    # -------------------------------------------------------------- files
    # The model file's format and its reading and writing belong to io
    # (:mod:`accelcal.io.model_file`, which imports this module's floor, never
    # the model): these entry points reach it only when called.
    def to_dict(self, description: str | None = None) -> dict:
        """The model as the JSON-ready contents of a model file (:mod:`accelcal.io.model_file`)."""
        return _model_file().model_to_dict(self, description)

    @classmethod
    def from_dict(cls, data, *, source: str = "<dict>") -> "ErrorModel":
        """Validate decoded model-file contents and build the model; errors name ``source``."""
        model_file = _model_file()
        coefficients, unit = model_file.validate(data, source=source)
        try:
            model = cls.from_terms(coefficients, output_unit=unit)
            temperature = model_file.temperature_terms(data, source=source)
            return model if temperature is None else model.replace(temperature=temperature)
        except model_file.ModelFileError:
            raise
        except ValueError as exc:
            raise model_file.ModelFileError(f"{source}: {exc}") from None

    def to_json(self) -> str:
        """The model as the text of a model file (JSON; floats round-trip exactly)."""
        return _model_file().dumps(self.to_dict())

    @classmethod
    def from_json(cls, text: str, *, source: str = "<string>") -> "ErrorModel":
        """Parse the text of a model file; errors name ``source``."""
        return cls.from_dict(_model_file().loads(text, source=source), source=source)

    def save(self, path) -> None:
        """Write the model file atomically (nothing half-written on failure)."""
        _model_file().write_text(path, self.to_json())

    @classmethod
    def load(cls, path) -> "ErrorModel":
        """Read and validate a model file."""
        return cls.from_json(_model_file().read_text(path), source=str(path))


def _model_file():
    """:mod:`accelcal.io.model_file`, imported when a model is read or written."""
    from accelcal.io import model_file

    return model_file


def _real(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise AccelcalError(f"{name} must be a real number, got {_shown_repr(value)}")
    value = float(value)
    if not np.isfinite(value):
        raise AccelcalError(f"{name} = {value} is not finite; give a finite number")
    return value


def _shown_repr(value, limit: int = 60) -> str:
    """``repr(value)`` cut to about ``limit`` characters, for a message."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def _require_zero(model: ErrorModel, names, notation: str) -> None:
    extra = [n for n in names if getattr(model, n) != 0.0]
    if extra:
        raise AccelcalError(
            f"{notation} has no term for {', '.join(extra)}; the model's non-zero "
            "values there cannot be expressed in that notation"
        )
