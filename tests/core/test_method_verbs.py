"""One verb set: every method's ``simulate`` takes ``seed=`` (int, SeedSequence, Generator)."""

import numpy as np
import pytest

from accelcal import AccelcalError, default_model

THETA = np.deg2rad(np.arange(0.0, 360.0, 45.0))


def _simulations():
    """(name, call taking seed=, array of what it drew) of every method's simulate."""
    from accelcal.methods import (
        centrifuge,
        dividing_head,
        noise,
        thermal,
        transverse,
        triad,
        tumble,
        vre,
    )
    from accelcal.rigs.dividing_head import DividingHeadRig, dong2014_models
    from accelcal.rigs.shaker import ShakerRig
    from accelcal.rigs.thermal import Programme

    model = default_model()
    shaker = ShakerRig(amplitude=5.0, sample_rate=2560.0, periods=4.0)
    head = DividingHeadRig.uniform(8, dong2014_models(2), noise=1e-6)
    return {
        "tumble": lambda seed: tumble.simulate(THETA, model, noise=1e-6, seed=seed).outputs,
        "dividing_head": lambda seed: dividing_head.simulate(head, seed=seed).outputs,
        "transverse": lambda seed: transverse.simulate(
            model.replace(sigma=1e-6), THETA, rig=shaker, seed=seed).u,
        "vre": lambda seed: vre.simulate(model, [1.0, 2.0], [5.0, 5.0], frequency=50.0,
                                         sample_rate=2000.0, duration=0.1, noise=1e-6,
                                         seed=seed).vibrating,
        "triad": lambda seed: triad.simulate(triad.TriadCalibration(
            [0.0] * 3, [1.0] * 3, [0.0] * 3), 6, still=5.0, noise_sd=0.01, seed=seed).acc,
        "noise": lambda seed: noise.simulate(N=2e-5, rate=10.0, duration=20.0,
                                             seed=seed).values,
        "thermal": lambda seed: thermal.simulate(
            model, Programme(points=8, dwell=30.0, warmup=600.0), seed=seed).output,
        "centrifuge": lambda seed: centrifuge.simulate(
            model, ["IA-in", "IA-out"], [2.0, 4.0], noise=1e-6, seed=seed).output,
    }


@pytest.mark.parametrize("name", sorted(_simulations()))
def test_simulate_takes_an_int_a_seed_sequence_or_a_generator(name):
    simulate = _simulations()[name]
    by_int = np.asarray(simulate(7), dtype=float)
    assert np.array_equal(by_int, np.asarray(simulate(7), dtype=float))
    sequence = np.asarray(simulate(np.random.SeedSequence(7)), dtype=float)
    generator = np.asarray(simulate(np.random.default_rng(7)), dtype=float)
    np.testing.assert_array_equal(sequence, by_int)   # default_rng(7) draws the same
    np.testing.assert_array_equal(generator, by_int)
    assert not np.array_equal(np.asarray(simulate(8), dtype=float), by_int)


def test_rng_stays_an_alias_of_seed():
    from accelcal.rigs import vibrafuge
    from accelcal.rigs.shaker import ShakerRig

    rig = ShakerRig(amplitude=5.0, sample_rate=2560.0, periods=4.0)
    sensor = default_model().replace(sigma=1e-6)
    old = rig.simulate(sensor, THETA, rng=np.random.default_rng(3)).u
    np.testing.assert_array_equal(old, rig.simulate(sensor, THETA, seed=3).u)
    assert np.array_equal(rig.simulate(default_model(), THETA).u,
                          rig.simulate(default_model(), THETA).u)  # no seed: noise-free
    args = (default_model(), [1.0], [5.0])
    kw = {"frequency": 50.0, "sample_rate": 2000.0, "duration": 0.1, "noise": 1e-6}
    np.testing.assert_array_equal(
        vibrafuge.simulate(*args, rng=np.random.default_rng(4), **kw).vibrating,
        vibrafuge.simulate(*args, seed=4, **kw).vibrating)
    with pytest.raises(AccelcalError) as info:
        vibrafuge.simulate(*args, seed=4, rng=np.random.default_rng(4), **kw)
    assert info.value.parameter == "rng"
    with pytest.raises(AccelcalError) as info:
        vibrafuge.simulate(*args, **kw)  # noise without a seed
    assert info.value.parameter == "seed"


def test_a_noise_record_keeps_an_int_seed_only():
    from accelcal.methods import noise

    assert noise.simulate(N=2e-5, rate=10.0, duration=20.0, seed=5).metadata["seed"] == 5
    gen = noise.simulate(N=2e-5, rate=10.0, duration=20.0, seed=np.random.default_rng(5))
    assert gen.metadata["seed"] is None
