"""accelcal: testing and calibration of inertial (pendulous) accelerometers.

The package root stays light: it imports numpy, the error model and the
result types only.
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

from accelcal.defaults import default_model
from accelcal.errors import AccelcalError
from accelcal.identifiability import Combination, Identifiability
from accelcal.model import TERMS, ErrorModel
from accelcal.results import Assumption, Estimate, Reduction

__version__ = "0.1.0"

__all__ = [
    "TERMS", "AccelcalError", "Assumption", "Combination", "ErrorModel", "Estimate",
    "Identifiability", "Reduction", "__version__", "default_model",
]
