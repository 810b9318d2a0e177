"""The VRE test's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

The VRE coefficients are identified by least squares from the measured
rectification at each overload ``b`` and vibration amplitude ``A`` [Guan2021]_
(DOMAIN section 2: ``dU1 = (K2 + 3 K3 b) A² / 2`` and the asymmetry terms'
arcsine formulas, not proportional to ``A`` or ``b``). The lab's inputs
enter through the design and the data, re-run with the closed-form design
columns:

- the reference accelerometer's sensitivity sets ``A``: a relative error
  ``delta`` makes every amplitude ``(1 + delta) A``;
- the centrifuge's rate and radius set the overload ``b = Omega² R``: a
  relative rate error ``delta`` makes it ``(1 + delta)² b``, a radius
  error ``delta R / R`` makes it ``(1 + delta R / R) b``;
- the DAQ's gain scales the measured rectification and its uncertainty.

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [Guan2021] Guan et al., vibration rectification error of pendulous
   accelerometers with asymmetry (docs/references.md).
"""


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` of vibrafuge runs (None without them)."""
    if records is None or (isinstance(records, list | tuple) and not records):
        return None
    import numpy as np

    from accelcal.budget.engine import DataModel
    from accelcal.methods.vre.identify import identify
    from accelcal.methods.vre.measure import measure_runs

    runs = list(records) if isinstance(records, list | tuple) else [records]
    m = measure_runs(runs)
    terms = tuple(reduction.estimate.names)

    def rerun(*, gain=0.0, amplitude=0.0, rate=0.0, radius_relative=0.0):
        scale = (1 + rate) ** 2 * (1 + radius_relative)
        return identify(np.asarray(m["overload"]) * scale,
                        np.asarray(m["amplitude"]) * (1 + amplitude),
                        np.asarray(m["vre"]) * (1 + gain),
                        np.asarray(m["uncertainty"]) * (1 + gain), direction=m["direction"],
                        terms=terms, fixed=dict(reduction.fixed), priors="none")

    return DataModel(rerun, 0, "", parameters={
        "reference_sensitivity": {"sensitivity": ("amplitude", "/value"),
                                  "charge sensitivity": ("amplitude", "/value"),
                                  "relative": ("amplitude", "1")},
        "centrifuge_rate": {"relative": ("rate", "1")},
        "centrifuge_radius": {"length": ("radius_relative", "/value")},
        "daq_gain": {"relative": ("gain", "1")}})
