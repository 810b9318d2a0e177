"""accelcal: testing and calibration of inertial (pendulous) accelerometers.

The package root stays light: it imports numpy and the error model only.
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
from accelcal.model import TERMS, ErrorModel

__version__ = "0.1.0"

__all__ = ["TERMS", "AccelcalError", "ErrorModel", "__version__", "default_model"]
