"""The embedded default accelerometer.

A plausible navigation-grade pendulous servo accelerometer, used wherever a
user gives no model. Magnitudes come from the seed papers' tables:

========  ==============  ===========================================================
term      value           source
========  ==============  ===========================================================
K1        1.2993698 V/g   Dong2014 Table 1, sensor 1 (K_I)
K0        -6.4154e-4 g    Dong2014 Table 1, sensor 1 (K_F / K_I = -8.336e-4 V / K_I)
K2        7.87e-6 g/g^2   Guan2021 Table 1
K3        1.19e-7 g/g^3   Guan2021 Table 1
K4        0               Guan2021 omits it as negligible; IEEE 1293 keeps the term
Ko        -9.435e-6 g/g   Dong2014 Table 1, sensor 1 (K_O / K_I)
Kp        6.0e-6 g/g      same order as Ko (no seed value; GuanTang's table was lost)
Koo       4.0e-6 g/g^2    order of K2 (no seed value)
Kpp       3.0e-6 g/g^2    order of K2 (no seed value)
Kio       -2.1926e-5      Dong2014 Table 1, sensor 1 (K_IO / K_I), g/g^2
Kip       1.0e-5 g/g^2    order of Kio (no seed value)
Kop       2.0e-6 g/g^2    order of K2 (no seed value)
K0_asym   2.26e-6 g       Guan2021 Table 1 (K0')
K1_asym   1.45e-6         Guan2021 Table 1 (K1')
sigma     1.0e-6 g        order of Dong2014's formal standard deviations
========  ==============  ===========================================================

References
----------
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021, Table 1.
.. [Dong2014] Dong C., Liu Q., Ren S., 2014, Table 1.
"""

from accelcal.model import ErrorModel

DEFAULT_MODEL = ErrorModel(
    K0=-8.336e-4 / 1.2993698,
    K1=1.2993698,
    K2=7.87e-6,
    K3=1.19e-7,
    K4=0.0,
    Ko=-1.226e-5 / 1.2993698,
    Kp=6.0e-6,
    Koo=4.0e-6,
    Kpp=3.0e-6,
    Kio=-2.849e-5 / 1.2993698,
    Kip=1.0e-5,
    Kop=2.0e-6,
    K0_asym=2.26e-6,
    K1_asym=1.45e-6,
    sigma=1.0e-6,
    output_unit="V",
)


def default_model() -> ErrorModel:
    """The embedded default accelerometer (see the module docstring for its sources)."""
    return DEFAULT_MODEL
