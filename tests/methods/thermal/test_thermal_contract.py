"""The thermal reduction under the reduction contract (tests/helpers/contract.py).

Random temperature coefficients (bias, scale factor, K2 and misalignment
up to second order), random hysteresis, a lagging sensor and noisy
temperature readings -> the chamber rig (:mod:`accelcal.rigs.thermal`) ->
:func:`accelcal.methods.thermal.reduce_thermal` with a fixed order 2 ->
the truth within the stated uncertainty. The coverage harness
(tests/helpers/coverage.py) runs this class; the same with the order
chosen by the F-test is :class:`AutoOrder` below, run by
the coverage harness as an extra case (not a ``Test`` class: its intervals are
conditional on the choice, see docs/thermal.md).
"""


from scipy import stats

import accelcal
from accelcal import ErrorModel
from accelcal.methods.thermal import reduce_thermal
from accelcal.rigs.thermal import Programme, simulate
from accelcal.terms import TemperatureTerms
from helpers.contract import ReductionContract, spread_terms, true_value

PROGRAMME = Programme(setpoints=(-40.0, -25.0, -10.0, 5.0, 20.0, 35.0, 50.0, 70.0,
                                 60.0, 45.0, 30.0, 15.0, 0.0, -15.0, -30.0),
                      soak=3600.0, warmup=600.0, points=12, dwell=30.0, step=10.0)
"""Fifteen plateaus heating then cooling; 12 positions, 3 readings each. At order 2 with
the hysteresis term each polynomial keeps 15 - 4 = 11 degrees of freedom."""

DOF = 11

TC_RANGES = {"K0_T1": 5e-6, "K0_T2": 2e-8, "K1_T1": 5e-5, "K1_T2": 2e-7,
             "K2_T1": 2e-7, "K2_T2": 2e-9, "Kp_T1": 2e-7, "Kp_T2": 2e-9}
"""Half-widths of the uniform draws of the temperature coefficients (per degC^k)."""


def random_truth(rng, order: int = 2):
    terms = {"K0": rng.uniform(-2e-3, 2e-3), "K2": rng.uniform(-2e-5, 2e-5),
             "K3": rng.uniform(-2e-6, 2e-6), "K4": rng.uniform(-1e-6, 1e-6),
             "Kp": rng.uniform(-2e-4, 2e-4), "Kip": rng.uniform(-2e-5, 2e-5)}
    # every term the tumbles take as zero, at the default accelerometer's magnitudes
    terms |= spread_terms(accelcal.default_model(), rng, ("Kpp", "K0_asym", "K1_asym"))
    k1 = rng.uniform(0.5, 3.0) * rng.choice([-1.0, 1.0])
    tc = {n: rng.uniform(-h, h) for n, h in TC_RANGES.items() if int(n[-1]) <= order}
    model = ErrorModel(K1=k1, **terms, temperature=TemperatureTerms(25.0, tc))
    return {"model": model, "hysteresis": rng.uniform(-2e-5, 2e-5),
            "hysteresis_scale": rng.uniform(-1e-5, 1e-5)}


ROWS = {"K0": "K0+Kpp", "K2": "K2-Kpp"}
"""Row names of the terms that carry the cross-axis nonlinearity (rotation about OA)."""


class _ThermalContract(ReductionContract):
    ORDER = 2
    NOISE = 2e-5  # output unit per reading
    Z_MAX = float(stats.t.ppf(1 - 0.5e-3 / 80, DOF))
    """The scale of each polynomial comes from its residuals (11 dof), so the scores are
    Student-t, not normal: the largest of 80 (16 coefficients x 5 seeds) exceeds this
    with probability < 1e-3 (Bonferroni), 7.5; the mean z^2 is then 11/9 = 1.22, inside
    the contract's band about 1."""

    def truth(self, rng):
        return random_truth(rng)

    def simulate(self, truth, rng, noisy):
        # Noise-free: no lag either (tau = 0), so every plateau's coefficients are constant
        # and the recovery is exact to rounding; noisy: the sensor lags by 600 s.
        return simulate(truth["model"], PROGRAMME, tau=600.0 if noisy else 0.0,
                        noise=self.NOISE if noisy else 0.0,
                        temperature_noise=0.01 if noisy else 0.0,
                        hysteresis=truth["hysteresis"],
                        hysteresis_scale=truth["hysteresis_scale"], seed=rng)

    def reduce(self, data):
        return reduce_thermal(data, order=self.ORDER)

    def expected(self, truth):
        m = truth["model"]
        tc = m.temperature.as_dict() if m.temperature is not None else {}
        out = {}
        for b in ("K0", "K1", "K2", "Kp"):
            row = ROWS.get(b, b)  # about OA, the tumbles' K0 is K0 + Kpp and K2 is K2 - Kpp
            out[row] = true_value(m, row)
            out |= {f"{b}_T{k}": tc.get(f"{b}_T{k}", 0.0) for k in range(1, self.ORDER + 1)}
        out |= {"K0_hyst": truth["hysteresis"], "K1_hyst": truth["hysteresis_scale"],
                "K2_hyst": 0.0, "Kp_hyst": 0.0}
        return [out]

    TYPE_B = True  # K0' and K1' bounded by their priors at T0

    def default_case(self):
        model = accelcal.default_model()
        data = simulate(model, PROGRAMME, tau=0.0, noise=0.0, temperature_noise=0.0,
                        hysteresis=0.0, hysteresis_scale=0.0, seed=1)
        return data, self.expected({"model": model, "hysteresis": 0.0,
                                    "hysteresis_scale": 0.0})

    def noise_free_tolerance(self, name, value):
        # Rounding of outputs of magnitude <= 3 (1e-16 relative) through the tumble (factor
        # <= 100, test_tumble_contract) and the polynomial fit over dT up to 65 degC (a power
        # k coefficient carries the rounding divided by about 30^k): 1e-13 g at k = 0.
        k = int(name[-1]) if "_T" in name else 0
        return 1e-9 * abs(value) + 1e-13 / 30.0**k


class TestContractOrder2(_ThermalContract):
    pass


class AutoOrder(_ThermalContract):
    """The same with ``order="auto"`` (F-test): the truth is of order 2, so the chosen order
    is 2 unless the test misses a small second-order term (then the estimates of order 1
    carry its bias); ``expected`` compares the coefficients every choice reports."""

    def reduce(self, data):
        return reduce_thermal(data, order="auto")

    def expected(self, truth):
        full = super().expected(truth)[0]
        return [{n: v for n, v in full.items() if "_T2" not in n}]
