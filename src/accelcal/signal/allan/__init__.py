"""Allan-family deviations of rate samples, their confidence intervals and noise identification.

The stability analysis of a still recording, as NIST SP 1065 defines it,
for any method that needs it (the noise method's IEEE 952 fit, a thermal
test's bias stability at a plateau):

- :mod:`~accelcal.signal.allan.taus`: the averaging factors (octave,
  decade, all, or given taus) each kind allows;
- :mod:`~accelcal.signal.allan.kernels`: sums of squared differences of the
  phase (the cumulative sum of the samples), O(N) per tau, bounded memory;
- :mod:`~accelcal.signal.allan.deviations`: :func:`deviation` (ADEV, OADEV,
  MDEV, HDEV, OHDEV, TOTDEV with intervals) and :func:`compute`;
- :mod:`~accelcal.signal.allan.identify`: the power-law exponent per tau
  (lag-1 autocorrelation, B1 ratio) and the exponent the intervals use
  (identified from 128 averages, carried past them);
- :mod:`~accelcal.signal.allan.edf`: equivalent degrees of freedom
  (Greenhall & Riley) and chi-square intervals;
- :mod:`~accelcal.signal.allan.exact`: the exact EDF of discrete white PM,
  white FM and random-walk FM at short taus.

References
----------
.. [SP1065] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   Special Publication 1065, 2008.
.. [GR2003] Greenhall C. A., Riley W. J., Uncertainty of stability variances
   based on finite differences, PTTI 2003.
"""

from accelcal.signal.allan.deviations import KINDS, Deviation, compute, deviation

__all__ = ["KINDS", "Deviation", "compute", "deviation"]
