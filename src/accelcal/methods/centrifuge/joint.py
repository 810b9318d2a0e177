"""Joint reduction of a centrifuge record with a 1 g record of the same sensor.

The 1 g test (a multipoint tumble, or one sensor column of an indexing-head
record) sees the same coefficients at specific forces that do not depend
on the centrifuge's radius: stacked with the centrifuge's step means in one
weighted least-squares problem with shared coefficients
(:mod:`~accelcal.methods.centrifuge.core`, each record weighted by its own
residual variance), it fixes K1 and K0, and the centrifuge then yields K2,
K3, K4, the cross-coupling and the radius error (DOMAIN section 9: "a joint
reduction of both tests' records with shared coefficients is the clean
way"). The coefficients are assumed the same in both tests (no bias shift
between them); the 1 g record's head or position errors are not modelled.

References
----------
.. [IEEE836] IEEE Std 836-2009, Recommended Practice for Precision Centrifuge
   Testing of Linear Accelerometers.
.. [IEEE1293] IEEE Std 1293-2018, multipoint tumble test.
.. [Dong2014] Dong C., Liu Q., Ren S., 2014, eqs. (1)-(5) (indexing head).
.. [DOMAIN] accelcal domain notes, sections 4, 5 and 9.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.centrifuge.core import Block
from accelcal.methods.centrifuge.reduce import (
    centrifuge_block,
    rig_parameters,
    solve_and_reduce,
)
from accelcal.validation import shown

METHOD = "centrifuge/joint"
ONE_G_KINDS = ("tumble", "dividing-head")


def read_one_g(path):
    """Read a 1 g record (kind ``tumble`` or ``dividing-head``) with its format's reader.

    Raises
    ------
    AccelcalError
        For a file of another kind (or any reader error).
    """
    from accelcal.io.lab_metadata import read_metadata

    kind = read_metadata(path).get("kind")
    if kind == "tumble":
        from accelcal.io.formats.tumble import read

        return read(path)
    if kind == "dividing-head":
        from accelcal.io.formats.dividing_head import read_head_record

        return read_head_record(path)
    raise AccelcalError(f"{path}: kind {shown(kind)} is not a 1 g record "
                        f"({', '.join(ONE_G_KINDS)})", parameter="one_g")


def one_g_block(one_g, *, sensor: str | None = None) -> tuple[Block, str]:
    """The 1 g observations (position means) of a tumble or indexing-head record, and its unit.

    Parameters
    ----------
    one_g : TumbleRecord or HeadRecord
    sensor : str, optional
        Sensor column of an indexing-head record (required when it has several).

    References
    ----------
    .. [1] IEEE1293 (tumble about OA or PA); Dong2014 eqs. (1)-(5) (a_i = sin beta,
       a_o = cos beta).
    """
    from accelcal.io.formats.dividing_head import HeadRecord
    from accelcal.io.formats.tumble import TumbleRecord

    if isinstance(one_g, TumbleRecord):
        from accelcal.physics.tumble import specific_force

        a = specific_force(one_g.angles_rad, one_g.rotation_axis)
        y = one_g.outputs.mean(axis=1)
        count = np.full(y.size, float(one_g.repeats))
        return Block("1 g", y, count, fixed=a), one_g.output_unit
    if isinstance(one_g, HeadRecord):
        names = list(one_g.sensors)
        if sensor is None and len(names) > 1:
            raise AccelcalError(f"the indexing-head record has {len(names)} sensor columns "
                                f"({', '.join(names)}); name the one on the centrifuge",
                                parameter="sensor")
        k = 0 if sensor is None else _index(names, sensor)
        beta = one_g.positions + one_g.mounts[k]
        a = (np.sin(beta), np.cos(beta), np.zeros_like(beta))  # Eq. (5) [Dong2014]
        y = one_g.outputs[:, k, :].mean(axis=0)
        count = np.full(y.size, float(one_g.outputs.shape[0]))
        return Block("1 g", y, count, fixed=a), one_g.output_unit
    raise AccelcalError(f"{type(one_g).__name__} is not a tumble or indexing-head record",
                        parameter="one_g")


def _index(names, sensor) -> int:
    if sensor not in names:
        raise AccelcalError(f"{shown(sensor)} is not a sensor column ({', '.join(names)})",
                            parameter="sensor")
    return names.index(sensor)


def reduce_joint(record, one_g, *, terms=None, estimate=("radius_error",), rig_errors=None,
                 sensor: str | None = None, priors="default"):
    """Reduce a centrifuge record jointly with a 1 g record of the same sensor.

    Parameters
    ----------
    record : CentrifugeRecord
    one_g : TumbleRecord or HeadRecord
        The 1 g test (:func:`read_one_g` reads either kind).
    terms : sequence of str, optional
        Default: the largest identifiable subset of the symmetric terms.
    estimate : sequence of str
        Rig errors to estimate (default the radius error); the others given.
    rig_errors : mapping, optional
        Given rig errors, name -> ``(value, sd)`` (override the survey).
    sensor : str, optional
        Sensor column of an indexing-head record.
    priors : "default", "none" or None
        As for :func:`~accelcal.methods.centrifuge.reduce.reduce_centrifuge`.

    Returns
    -------
    Reduction
        Family ``"centrifuge"``, method ``"centrifuge/joint"``; ``shared``
        holds the estimated rig errors; ``dof`` the residual degrees of freedom
        of both records together.

    Raises
    ------
    AccelcalError
        Different output units, a 1 g record of another kind, plus those of
        :func:`~accelcal.methods.centrifuge.reduce.reduce_centrifuge`.

    References
    ----------
    .. [1] DOMAIN section 9 (joint reduction); IEEE836.
    """
    block = centrifuge_block(record)
    ones, unit = one_g_block(one_g, sensor=sensor)
    if unit != record.output_unit:
        raise AccelcalError(f"the 1 g record's outputs are in {unit}, the centrifuge's in "
                            f"{record.output_unit}: give records of the same output unit",
                            parameter="one_g")
    rig, est, sds = rig_parameters(record, rig_errors, estimate)
    note = (f"joint with a 1 g record ({ones.y.size} positions): coefficients shared, "
            "each record weighted by its own residual noise"),
    return solve_and_reduce([block, ones], record, rig, est, sds, terms=terms, sigma=None,
                            method=METHOD, extra_notes=note, priors=priors)
