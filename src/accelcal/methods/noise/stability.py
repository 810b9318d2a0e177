"""Stability across runs: turn-on to turn-on bias repeatability beside in-run stability.

Several still recordings of one accelerometer, each switched on anew, give
one IEEE 952 fit each (:func:`accelcal.methods.noise.fit.fit_deviation`):
its run mean (coefficient ``bias``) and its bias instability ``B``. Stored
as calibration records (method ``noise/ieee952-fit``), :func:`from_store`
collects them by serial number and :func:`run_to_run` sets side by side:

``bias_repeatability``
    The sample SD of the k run means (turn-on to turn-on repeatability,
    IEEE 1293 annex), with ``k - 1`` degrees of freedom; its standard
    uncertainty ``s / sqrt(2 (k - 1))`` (the SD of a sample SD of Gaussian
    values, to first order).
``B_in_run``
    The mean of the runs' ``B`` and its standard uncertainty (the SD of the
    runs' ``B`` over sqrt(k), or their stated uncertainties combined when
    larger).
``bias_mean``
    The mean of the run means, with ``s / sqrt(k)``.

The result is a :class:`~accelcal.results.Reduction` (family ``"noise"``,
method ``"noise/run-to-run"``, ``dof = k - 1``); observations ``run_bias``,
``run_bias_std``, ``run_B``, ``run_B_std``.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex (bias repeatability: turn-on to
   turn-on, and in-run bias stability).
.. [IEEE952] IEEE Std 952-1997, Annex C.
"""

import math

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.results import Assumption, Estimate, Reduction

METHOD = "noise/run-to-run"
"""The reduction's name."""


def run_to_run(bias, bias_std, b, b_std, *, unit: str = "", runs=()) -> Reduction:
    """Turn-on to turn-on repeatability and in-run stability from k runs.

    Parameters
    ----------
    bias, bias_std : array_like, shape (k,)
        Run means and their standard uncertainties, in ``unit``.
    b, b_std : array_like, shape (k,)
        Runs' bias instability and its standard uncertainty, in ``unit``.
    unit : str
        Unit of the samples.
    runs : sequence of str
        Labels of the runs (record ids, dates), for the provenance.

    Returns
    -------
    Reduction

    Raises
    ------
    AccelcalError
        With fewer than two runs.
    """
    arrays = [np.asarray(v, dtype=float).reshape(-1) for v in (bias, bias_std, b, b_std)]
    k = arrays[0].size
    if k < 2 or any(a.size != k for a in arrays):
        raise AccelcalError(f"run-to-run repeatability needs two or more runs with a bias and a "
                            f"B each; got {k}", parameter="runs")
    means, mean_std, bs, bs_std = arrays
    s = float(np.std(means, ddof=1))
    b_unc = max(float(np.std(bs, ddof=1)) / math.sqrt(k), float(np.sqrt(np.sum(bs_std**2))) / k)
    names = ("bias_repeatability", "B_in_run", "bias_mean")
    values = np.array([s, float(np.mean(bs)), float(np.mean(means))])
    std = np.array([s / math.sqrt(2 * (k - 1)), b_unc, s / math.sqrt(k)])
    est = Estimate(names=names, values=values, covariance=np.diag(std**2),
                   units=dict.fromkeys(names, unit), method=METHOD, dof=k - 1)
    return Reduction(
        family="noise", method=METHOD, sensors=(est,), dof=k - 1,
        assumptions=(Assumption("run_to_run", s, unit, f"SD of {k} run means ({k - 1} dof)"),),
        observations={"run_bias": means, "run_bias_std": mean_std, "run_B": bs,
                      "run_B_std": bs_std},
        provenance={"runs": [str(r) for r in runs] or list(range(k)), "unit": unit},
    )


def from_store(store, serial: str) -> Reduction:
    """:func:`run_to_run` of every ``noise/ieee952-fit`` record of ``serial`` in a store."""
    from accelcal.methods.noise.fit import METHOD as FIT

    pairs = [(row, store.record(row["id"])) for row in store.calibrations(serial)
             if row["method"] == FIT]
    pairs = [(row, rec) for row, rec in pairs if {"bias", "B"} <= set(rec.names)]
    records = [rec for _, rec in pairs]
    if len(records) < 2:
        raise AccelcalError(f"the store holds {len(records)} noise fit(s) with bias and B of "
                            f"{serial}; run-to-run repeatability needs two or more (fit "
                            "each run with the terms N,B,K: the default N,K has no B)",
                            parameter="serial")

    def column(name):
        return ([rec.estimates[rec.names.index(name)] for rec in records],
                [math.sqrt(rec.covariance[rec.names.index(name), rec.names.index(name)])
                 for rec in records])

    bias, bias_std = column("bias")
    b, b_std = column("B")
    return run_to_run(bias, bias_std, b, b_std, unit=records[0].units.get("bias", ""),
                      runs=[f"{row['id']} {row['date']}" for row, _ in pairs])
