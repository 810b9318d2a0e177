"""What a centrifuge design (with or without a 1 g record) can separate.

The design is the first-order sensitivity of the outputs to the
output-unit coefficients ``b_t = K1 K_t`` and to the rig errors (at a unit
sensor, K1 = 1: the rank does not depend on the sensor), analysed with the
shared :func:`accelcal.identifiability.analyse` (one tolerance). Facts it
finds, and the tests check (DOMAIN section 9):

* a radius error scales every centripetal input: on the centrifuge alone it
  is aliased with K1 (and stretch with K2), unless some position puts
  gravity on IA both up and down; a 1 g record of the same sensor fixes K1
  and separates them;
* IA radial inward and outward separate the odd from the even terms; a
  proof-mass offset along IA then looks like scale-factor asymmetry K1';
* cross-coupling needs OA or PA radial.

References
----------
.. [IEEE836] IEEE Std 836-2009, Recommended Practice for Precision Centrifuge
   Testing of Linear Accelerometers.
.. [DOMAIN] accelcal domain notes, section 9.
.. [Searle] Searle S. R., Linear Models, Wiley, 1971, sec. 5.4 (estimable functions).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import NULL_ATOL, Identifiability, analyse
from accelcal.methods.centrifuge.core import design, unit_coefficients
from accelcal.physics.centrifuge import FULL_TERMS, RIG_ERRORS

PRIORITY = ("K1", "K0", "Ko", "Kp", "K2", "Kio", "Kip", "K3", "K4", "Koo", "Kpp", "Kop",
            "K0_asym", "K1_asym")
"""Order in which terms are preferred when aliased terms must be dropped."""


@dataclass(frozen=True)
class CentrifugeIdentifiability:
    """What a design separates.

    Attributes
    ----------
    candidates : tuple of str
        The model terms considered.
    estimated : tuple of str
        Rig errors estimated with them.
    analysis : Identifiability
        Of the candidate terms and estimated rig errors together.
    suggested : tuple of str
        A largest identifiable subset of the candidates (in :data:`PRIORITY`
        order), with the estimated rig errors.
    rig_aliases : dict
        For each rig error not estimated: the terms (of ``suggested``) it is
        aliased with, ``()`` when the design would separate it.
    absorbed : dict
        For each candidate left out: ``{term: weight}`` of the suggested terms
        whose estimates absorb it (``K_s`` stands for ``K_s + w K_t``).
    """

    candidates: tuple
    estimated: tuple
    analysis: Identifiability
    suggested: tuple
    rig_aliases: dict
    absorbed: dict

    def statements(self) -> tuple[str, ...]:
        """Sentences: what cannot be separated, and which rig errors could be estimated."""
        out = []
        for name, partners in self.rig_aliases.items():
            if partners:
                fix = ("give it from a survey, or add a 1 g record of the same sensor (joint "
                       "reduction)" if "K1" in partners else
                       "give it from a survey, or change the positions")
                out.append(f"{name} cannot be separated from {', '.join(partners)} by these "
                           f"records: {fix}")
            else:
                out.append(f"{name} could be estimated from these records")
        for t, weights in self.absorbed.items():
            parts = [f"{s} stands for {s} {'+' if w > 0 else '-'} {_times(abs(w))}{t}"
                     for s, w in weights.items()]
            out.append(f"{t} is not separable from the other terms (taken as zero): "
                       f"{'; '.join(parts)}" if parts else
                       f"{t} is not excited by these positions (taken as zero)")
        return tuple(out)

    def rows(self) -> list[dict]:
        """One row per term and rig error: ``name``, ``status``."""
        rows = [{"name": t, "status": "identifiable" if t in self.suggested else
                 "aliased (taken as zero)"} for t in self.candidates]
        rows += [{"name": r, "status": "estimated"} for r in self.estimated]
        rows += [{"name": r, "status": "aliased with " + ", ".join(p) if p else
                  "separable (not estimated)"} for r, p in self.rig_aliases.items()]
        return rows


def identifiability(blocks, rig: dict, candidates=FULL_TERMS, estimated=()
                    ) -> CentrifugeIdentifiability:
    """Analyse the design of ``blocks`` for ``candidates`` and the ``estimated`` rig errors.

    Raises
    ------
    AccelcalError
        When an estimated rig error is aliased with K1 (nothing can then be
        given in g/g^n): the message says so and what to do.

    References
    ----------
    .. [1] DOMAIN section 9 (identifiability); Searle 1971 sec. 5.4.
    """
    candidates, estimated = tuple(candidates), tuple(estimated)
    phi, jac = design(blocks, candidates, rig, unit_coefficients(candidates),
                      (*estimated, *RIG_ERRORS))
    w = np.sqrt(np.concatenate([blk.count for blk in blocks]))[:, None]
    phi, jac = phi * w, jac * w
    m = len(estimated)
    est_cols = jac[:, :m]
    analysis = analyse(np.hstack([phi, est_cols]), (*candidates, *estimated))
    suggested = _suggest(phi, est_cols, candidates, estimated)
    cols = np.hstack([phi[:, [candidates.index(t) for t in suggested]], est_cols])
    aliases = {}
    for j, name in enumerate(RIG_ERRORS):
        if name in estimated:
            continue
        col = jac[:, m + j:m + j + 1]
        if not np.any(col):
            continue
        ident = analyse(np.hstack([cols, col]), (*suggested, *estimated, name))
        partners = () if ident.full_rank else tuple(
            n for n, v in zip(ident.names, np.abs(ident.null_space).max(axis=1), strict=True)
            if v >= NULL_ATOL and n != name)
        aliases[name] = partners
    absorbed = {}
    for t in candidates:
        if t not in suggested:
            coef = np.linalg.lstsq(cols, phi[:, candidates.index(t)], rcond=None)[0]
            absorbed[t] = {s: float(c) for s, c in zip(suggested, coef, strict=False)
                           if abs(c) > 1e-9}
    return CentrifugeIdentifiability(candidates, estimated, analysis, suggested, aliases,
                                     absorbed)


def _times(w: float) -> str:
    return "" if abs(w - 1.0) < 1e-9 else f"{w:.6g} "


def _suggest(phi, est_cols, candidates, estimated) -> tuple[str, ...]:
    """Greedy largest identifiable subset of ``candidates`` beside the estimated rig errors."""
    chosen, cols = [], [est_cols[:, j] for j in range(est_cols.shape[1])]
    for t in sorted(candidates, key=PRIORITY.index):
        trial = [*cols, phi[:, candidates.index(t)]]
        if analyse(np.column_stack(trial), [*estimated, *chosen, t]).full_rank:
            chosen.append(t)
            cols.append(phi[:, candidates.index(t)])
        elif t == "K1":
            lost = analyse(np.column_stack(trial), [*estimated, t])
            partners = [n for n in estimated if n in lost.unidentifiable]
            raise AccelcalError(
                f"{', '.join(partners) or 'a rig error'} cannot be separated from K1 by these "
                "records (a radius error scales every centripetal input as K1 does); give it "
                "from a survey, or reduce jointly with a 1 g record of the same sensor",
                parameter="estimate")
    return tuple(t for t in candidates if t in chosen)
