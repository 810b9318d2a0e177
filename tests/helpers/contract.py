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
method's arithmetic, derived in the subclass) and ``Z_MAX``.

The contract then checks: the result is a Reduction with one estimate per
sensor; noise-free data recover the truth to rounding; noisy data recover
it within the stated uncertainty (every |z| below ``Z_MAX`` over several
seeds, and the mean of z^2 consistent with 1); the result survives a
calibration record (JSON round trip), the records store and a report; its
rows and JSON are complete; its figures draw.
"""

import json

import numpy as np

from accelcal.results import Reduction


class ReductionContract:
    """Mixin: random truth -> rig -> reduction -> truth recovered, for every method."""

    SEEDS = (11, 12, 13, 14, 15)
    Z_MAX = 4.5
    """Largest |z| accepted: for ~100 Gaussian z-scores, P(max |z| > 4.5) < 1e-3."""

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

    # ------------------------------------------------------------- helpers
    def _run(self, seed: int, noisy: bool):
        rng = np.random.default_rng(seed)
        truth = self.truth(rng)
        return truth, self.reduce(self.simulate(truth, rng, noisy))

    def _pairs(self, truth, red):
        for k, want in enumerate(self.expected(truth)):
            est = red.sensors[k]
            for name, value in want.items():
                yield k, name, value, est[name], est.std_of(name)

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
        for k, name, want, got, _ in self._pairs(truth, red):
            tol = self.noise_free_tolerance(name, want)
            assert abs(got - want) <= tol, f"sensor {k} {name}: {got!r} vs {want!r} (tol {tol})"

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
