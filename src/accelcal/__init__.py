"""accelcal: testing and calibration of inertial (pendulous) accelerometers.

The package root stays light: it imports nothing but the standard library;
its public names (the error model, the result types, the default model) are
imported when first used, so ``accelcal --help`` never loads numpy.
Plotting (matplotlib), tables (pandas), the command line (typer, rich) and
the distributed engine (dask) are imported lazily by the modules that need
them.

Examples
--------
>>> import accelcal
>>> model = accelcal.default_model()
>>> round(float(model.output_g(1.0)), 6)
0.999368
"""

import importlib
import importlib.util

__version__ = "0.1.0"

_EXPORTS = {
    "TERMS": "accelcal.model", "ErrorModel": "accelcal.model",
    "AccelcalError": "accelcal.errors",
    "Combination": "accelcal.identifiability", "Identifiability": "accelcal.identifiability",
    "Assumption": "accelcal.results", "Estimate": "accelcal.results",
    "Reduction": "accelcal.results",
    "default_model": "accelcal.defaults",
}
"""Public name -> the module defining it, imported on first use (PEP 562)."""

__all__ = [
    "TERMS", "AccelcalError", "Assumption", "Combination", "ErrorModel", "Estimate",
    "Identifiability", "Reduction", "__version__", "default_model",
]


def __getattr__(name: str):
    """The public names of :data:`_EXPORTS` and the subpackages, imported when first asked for.

    ``accelcal.ErrorModel`` imports :mod:`accelcal.model`; ``accelcal.model``
    (a submodule not yet imported) imports it, as an eager root would have.
    """
    module = _EXPORTS.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module), name)
    elif not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}"):
        value = importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module 'accelcal' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
