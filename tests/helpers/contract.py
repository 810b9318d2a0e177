"""The reduction contract every method passes (after scikit-rf's ``CalibrationTest``).

A method joins by subclassing :class:`ReductionContract` in its own test
module (``class TestContract(ReductionContract)``) and supplying four
small methods:

``truth(rng)``
    A random true sensor set-up (whatever the method's rig needs).
``simulate(truth, rng, noisy)``
    The method's rig: data of that truth, with or without noise.
``reduce(data)``
    The method's reduction: a :class:`~accelcal.results.Reduction`.
``expected(truth)``
    Per sensor, the true values of the coefficients the reduction reports
    (name -> value, in the reduction's units).

and, where the defaults do not fit, ``noise_free_tolerance(name, value)``
(the absolute agreement noise-free data must reach: rounding of the
method's arithmetic, derived in the subclass), ``Z_MAX``, ``TYPE_B`` (True
where the truths set terms the reduction takes as zero and bounds by priors:
noise-free data then agree within the stated uncertainty, not to rounding)
and ``default_case()`` (noise-free data of the embedded default
accelerometer, every term non-zero, and the truth of each row by its name:
a combination's name, e.g. ``K0+Kpp``, states what the row estimates).

The contract then checks: the result is a Reduction with one estimate per
sensor; noise-free data recover the truth to rounding (within the stated
uncertainty with ``TYPE_B``); the default accelerometer's rows equal their
truths within ``DEFAULT_K`` stated SDs; noisy data recover
it within the stated uncertainty (every |z| below ``Z_MAX`` over several
seeds, and the mean of z^2 consistent with 1); the result survives a
calibration record (JSON round trip), the records store and a report; its
rows and JSON are complete; its figures draw.
"""

import json
import re

import numpy as np
import pytest

from accelcal.results import Reduction


def true_value(model, name: str) -> float:
    """The true value of a row name such as ``K0+Kpp`` or ``Ko-Kop`` from an ErrorModel."""
    total = 0.0
    for sign, weight, term in re.findall(r"([+-]?)(?:([0-9.eE+-]+)\*)?([A-Za-z][A-Za-z0-9_]*)",
                                         name):
        total += (-1.0 if sign == "-" else 1.0) * (float(weight) if weight else 1.0) * \
            getattr(model, term)
    return total


def default_terms(model, rng, names) -> dict:
    """The default accelerometer's magnitude of each term, with a random sign."""
    return {t: abs(getattr(model, t)) * rng.choice([-1.0, 1.0]) for t in names}


SPREAD = 2.0
"""Factor within which :func:`spread_terms` draws a term's magnitude about the default's."""


def spread_terms(model, rng, names) -> dict:
    """Each term at the default accelerometer's magnitude times a factor, with a random sign.

    The factor is log-uniform in ``[1/SPREAD, SPREAD]``: sensors of one type
    whose terms lie within a factor of two of the default one's, as the
    several axes of a triad do. Its root mean square, ``a sqrt((SPREAD^2 -
    SPREAD^-2) / (4 ln SPREAD))`` = 1.163 a, is that of the population the
    embedded default prior describes (uniform within ``+-2a``: 2a/sqrt(3) =
    1.155 a, :data:`accelcal.aliasing.DEFAULT_PRIOR_FACTOR`); at exactly
    ``+-a`` (:func:`default_terms`) a Type B dominated row's SD ratio is
    sqrt(3)/2 by arithmetic (docs/coverage.md).
    """
    out = {}
    for t in names:
        factor = np.exp(rng.uniform(-np.log(SPREAD), np.log(SPREAD)))
        out[t] = abs(getattr(model, t)) * factor * rng.choice([-1.0, 1.0])
    return out


class ReductionContract:
    """Mixin: random truth -> rig -> reduction -> truth recovered, for every method."""

    SEEDS = (11, 12, 13, 14, 15)
    Z_MAX = 4.5
    """Largest |z| accepted: for ~100 Gaussian z-scores, P(max |z| > 4.5) < 1e-3."""

    TYPE_B = False
    """True where the truths set terms the reduction bounds by priors instead of estimating."""

    DEFAULT_K = 1.0
    """Stated SDs within which the default accelerometer's rows must equal their truths."""

    NOISE_FREE_K = 3.0
    """Stated SDs within which noise-free rows must equal their truths with ``TYPE_B``: the
    truths draw the bounded terms within a factor 2 of the default's magnitude
    (:func:`spread_terms`), so the error is a draw from the stated Type B distribution
    (one term alone reaches at most sqrt(3) of its contribution; several rarely 3)."""

    # ------------------------------------------------------- supplied by a method
    def truth(self, rng):  # pragma: no cover - supplied by subclasses
        raise NotImplementedError

    def simulate(self, truth, rng, noisy: bool):  # pragma: no cover
        raise NotImplementedError

    def reduce(self, data) -> Reduction:  # pragma: no cover
        raise NotImplementedError

    def expected(self, truth) -> list[dict]:  # pragma: no cover
        raise NotImplementedError

    def noise_free_tolerance(self, name: str, value: float) -> float:
        """Absolute tolerance of a noise-free estimate: 1e-9 relative, 1e-15 absolute."""
        return 1e-9 * abs(value) + 1e-15

    def default_case(self):
        """``(data, expected)`` of the default accelerometer, noise-free; None: no such case."""

    def row_truth(self, truth, row: str, value: float) -> float:
        """The truth of the row named ``row`` (``value``: ``expected``'s, by plain name).

        A method whose row names depend on the data (a combination's weights
        from the alias matrix) computes the truth of the name here.
        """
        del truth, row
        return value

    # ------------------------------------------------------------- helpers
    def _run(self, seed: int, noisy: bool):
        rng = np.random.default_rng(seed)
        truth = self.truth(rng)
        return truth, self.reduce(self.simulate(truth, rng, noisy))

    def _pairs(self, truth, red):
        for k, want in enumerate(self.expected(truth)):
            est = red.sensors[k]
            for name, value in want.items():
                yield k, name, self.row_truth(truth, est.label(name), value), est[name], \
                    est.std_of(name)

    # --------------------------------------------------------------- the tests
    def test_returns_one_reduction(self):
        truth, red = self._run(self.SEEDS[0], noisy=True)
        assert isinstance(red, Reduction)
        assert red.n_sensors == len(self.expected(truth))
        assert red.family
        assert red.method
        for est in red.sensors:
            assert est.values.shape == (len(est.names),)
            assert set(est.units) >= set(est.names)

    def test_noise_free_recovers_truth(self):
        truth, red = self._run(self.SEEDS[0], noisy=False)
        for k, name, want, got, std in self._pairs(truth, red):
            tol = self.noise_free_tolerance(name, want) + \
                (self.NOISE_FREE_K * std if self.TYPE_B else 0.0)
            assert abs(got - want) <= tol, f"sensor {k} {name}: {got!r} vs {want!r} (tol {tol})"

    def test_default_accelerometer_rows_equal_their_truths(self):
        case = self.default_case()
        if case is None:
            pytest.skip("no noise-free case of the default accelerometer for this method yet")
        data, expected = case
        red = self.reduce(data)
        for k, want in enumerate(expected):
            est = red.sensors[k]
            assert {r["coefficient"] for r in red.rows() if r["sensor"] == red.sensor_names[k]
                    and r["status"] == "fitted"} <= {est.label(n) for n in want}, \
                "a row without its truth"
            for name, plain_value in want.items():
                got, std = est[name], est.std_of(name)
                value = self.row_truth(data, est.label(name), plain_value)
                tol = self.DEFAULT_K * std + self.noise_free_tolerance(name, value)
                assert abs(got - value) <= tol, f"sensor {k} {name}: {got!r} vs {value!r} ({tol})"

    def test_noisy_within_stated_uncertainty(self):
        z = []
        for seed in self.SEEDS:
            truth, red = self._run(seed, noisy=True)
            for _k, _name, want, got, std in self._pairs(truth, red):
                assert std > 0
                assert np.isfinite(std)
                z.append((got - want) / std)
        z = np.asarray(z)
        assert np.abs(z).max() < self.Z_MAX, z
        # mean z^2 of m independent-ish scores: 1 +- a few sqrt(2/m)
        m = z.size
        assert abs(np.mean(z**2) - 1.0) < max(4.0 * np.sqrt(2.0 / m), 0.5), np.mean(z**2)

    def test_record_store_report_round_trip(self, tmp_path):
        from accelcal.io.calibration_record import CalibrationRecord
        from accelcal.io.lab_metadata import LabInfo
        from accelcal.report import render_report
        from accelcal.report.sections import reduction_sections
        from accelcal.store import Store

        _, red = self._run(self.SEEDS[1], noisy=True)
        serials = tuple(f"SN-{k}" for k in range(red.n_sensors))
        records = red.to_records(LabInfo(serials, "op", "2026-01-02T03:04:05+00:00"))
        assert [r.serial for r in records] == list(serials)
        for rec, est in zip(records, red.sensors, strict=True):
            back = CalibrationRecord.from_json(rec.to_json())
            assert back.names == rec.names
            np.testing.assert_array_equal(back.estimates, rec.estimates)
            for name in rec.names:
                assert back.estimates[back.names.index(name)] == est[name]
        with Store(tmp_path / "store.sqlite") as store:
            ids = [store.add(r) for r in records]
            for i, rec in zip(ids, records, strict=True):
                got = store.record(i)
                np.testing.assert_array_equal(got.estimates, rec.estimates)
                assert got.method == red.method
        html = render_report(reduction_sections(red, records), title="contract")
        for serial in serials:
            assert serial in html
        assert html.count("<svg") >= 1

    def test_rows_and_json_complete(self):
        _, red = self._run(self.SEEDS[2], noisy=True)
        rows = red.rows()
        assert len(rows) == sum(len(e.names) for e in red.sensors) + \
            red.n_sensors * len(red.fixed)
        for r in rows:
            assert {"sensor", "coefficient", "estimate", "std", "unit", "status", "dof"} <= set(r)
        doc = json.loads(red.to_json())
        assert doc["method"] == red.method
        assert len(doc["sensors"]) == red.n_sensors
        frame = red.to_frame()
        assert len(frame) == len(rows)
