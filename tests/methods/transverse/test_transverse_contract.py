"""The reduction contract for the shaker identification (GuanTang, beyond the paper).

Random cross-axis coefficients, the shaker rig (GuanTang eqs. (5)-(6) with
gravity and the output at rest), :func:`accelcal.methods.transverse.identify`
by every route.
"""

import numpy as np

import accelcal
from accelcal.methods.transverse import identify
from accelcal.model import ErrorModel
from accelcal.rigs.shaker import ShakerRig
from helpers.contract import ReductionContract, spread_terms

THETA = np.deg2rad(np.arange(0.0, 360.0, 30.0))
NAMES = ("Ko", "Kp", "Koo", "Kpp", "Kop")
UNFITTED = ("K2", "K3", "Kio", "Kip", "K0_asym", "K1_asym")
"""The terms of a_i: the vibration lies in the transverse plane (a_i = 0 without the
shaker's own IA motion), so they do not enter and every row is its plain coefficient."""


class TestContract(ReductionContract):
    """Route ``2w``: the w and 2w phasors."""

    ROUTE = "2w"

    def truth(self, rng):
        ko, kp = rng.uniform(-3e-4, 3e-4, 2)
        koo, kpp, kop = rng.uniform(-5e-5, 5e-5, 3)
        # every other term non-zero too, at the default accelerometer's magnitudes
        return ErrorModel.from_guantang(k_i=1000.0, k_0=4e-5, k_o=ko, k_p=kp, k_oo=koo,
                                        k_pp=kpp, k_op=kop, output_unit="mV").replace(
            **spread_terms(accelcal.default_model(), rng, UNFITTED))

    def simulate(self, truth, rng, noisy: bool):
        # gravity along the vibration (vertical shaker) and the output at rest:
        # every route identifies all five terms
        return self.rig(noisy).simulate(truth, THETA, rng=rng if noisy else None)

    @staticmethod
    def rig(noisy: bool) -> ShakerRig:
        return ShakerRig(amplitude=5.0, gravity=1.0, rest=True, frequency=160.0,
                         sample_rate=10240.0, periods=4.0, noise=2e-5 if noisy else 0.0)

    def default_case(self):
        model = accelcal.default_model()
        return self.rig(noisy=False).simulate(model, THETA), self.expected(model)

    def reduce(self, data):
        return identify(data, route=self.ROUTE)

    def expected(self, truth):
        return [{name: getattr(truth, name) for name in NAMES}]


class TestContractDC(TestContract):
    """Route ``dc``: the w phasor and the DC shift from rest."""

    ROUTE = "dc"


class TestContractBoth(TestContract):
    """Route ``both``: w, 2w and the DC shift."""

    ROUTE = "both"


class TestContractW(TestContract):
    """Route ``w``: the w phasor alone (the second-order terms through 2 G C)."""

    ROUTE = "w"


def test_reduction_fields():
    contract = TestContract()
    rng = np.random.default_rng(3)
    truth = contract.truth(rng)
    data = contract.simulate(truth, rng, noisy=True)
    red = contract.reduce(data)
    assert red.family == "transverse"
    assert red.method == "transverse/2w"
    assert red.assumed("amplitude") == 5.0
    assert red.assumption("amplitude").unit == "g"
    assert red.assumption("amplitude").text == "shaker vibration amplitude 5 g"
    assert red.assumed("gravity") == 1.0
    assert red.assumed("frequency") == 160.0
    assert red.assumed("route") == "2w"
    assert red.assumed("scale_factor") == 1000.0
    assert red.scale_factor() == 1000.0
    assert red.quantities == {"Ko": "transverse", "Kp": "transverse"}
    assert red.fixed == {}  # without a base model every term not fitted is zero
    np.testing.assert_array_equal(red.observations["angle_deg"], np.rad2deg(THETA))
    # the fundamental s_T per angle: K1 |B + 2 G C| (GuanTang eq. (16), gravity)
    from accelcal.methods.transverse import cross_axis_B, cross_axis_C

    expected = 1000.0 * np.abs(cross_axis_B(THETA, truth) + 2 * cross_axis_C(THETA, truth))
    # noise 2e-5 g on 256 samples: about 3.5e-4 mV/g per angle; 2e-3 is over 5 SDs
    np.testing.assert_allclose(red.observations["sT"], expected, rtol=0, atol=2e-3)
    assert float(red.observations["s_I"]) == 1000.0  # no axial sensitivity in the records
    assert red.identifiability.full_rank
    # a base model's non-zero terms not fitted are held: the fixed terms
    base = truth.replace(**dict.fromkeys(NAMES, 0.0))
    held = identify(data, base=base)
    assert held.fixed == {"K0": 4e-5, **{t: getattr(truth, t) for t in UNFITTED}}
    np.testing.assert_array_equal(held.estimate.values, red.estimate.values)  # K0: DC only
    rows = {r["coefficient"]: r for r in held.rows()}
    assert rows["Ko"]["eng_unit"] == "mg/g"
    assert rows["Ko"]["eng_estimate"] == rows["Ko"]["estimate"] * 1e3
    assert rows["K0"]["status"] == "fixed"
