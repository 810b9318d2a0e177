"""Harmonic design sums of long uniformly sampled records, without the n x p design.

The least-squares fit of DC and harmonics ``k = 1..H`` of a known frequency
(:class:`accelcal.signal.sinefit.HarmonicFit`) needs, of the design ``D``
(columns ``1, cos(k w t_n), sin(k w t_n)``), only ``D'y`` and ``D'D``.
:class:`BlockSums` forms both from blocks of ``L ~ 4 sqrt(n)`` samples:
block ``j`` starts ``j L`` samples later than the first, so its design rows
are the first block's rotated, harmonic by harmonic, by the phase
``k w j L / fs`` (``cos(a + b)`` and ``sin(a + b)`` expanded)::

    D'y = sum_j T_j (E' y_j),        D'D = sum_j T_j (E'E) T_j',       # Eq. (1)

with ``E`` the ``L x p`` design of the first block and ``T_j`` the
``p x p`` block-diagonal rotation. Set-up costs O(sqrt(n)) sines and
cosines and O(sqrt(n) p^2) memory; ``D'y`` costs one matrix-vector product
per column over the samples (the speed of reading them).

Phases are carried in cycles and reduced to ``[0, 1)`` from the exact
rational ``f / fs`` of the two floats, so no rounding grows with the time of
a sample (as it does in ``2 pi f t`` for long records).

References
----------
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.3.1 (the three-parameter fit and
   its design).
.. [GVL] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., Johns
   Hopkins, 2013, sec. 5.3 (normal equations).
"""

from fractions import Fraction

import numpy as np


class BlockSums:
    """``D'v`` and ``D'D`` of the harmonic design of ``length`` samples.

    Parameters
    ----------
    length : int
        Samples ``n`` of the vectors summed.
    ratio : fractions.Fraction
        Cycles of the fundamental per sample, ``f / fs`` (exact).
    start : float
        Phase of the first sample, cycles.
    harmonics : int
        Highest harmonic ``H``; the design has ``p = 1 + 2 H`` columns
        ``(1, cos, sin of harmonic 1, ..., cos, sin of harmonic H)``.

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.1.
    """

    def __init__(self, length: int, ratio: Fraction, start: float, harmonics: int) -> None:
        self.length = int(length)
        self.block = int(min(self.length, max(256, np.sqrt(16.0 * self.length))))
        blocks = self.length // self.block
        self.columns = _block_design(self.block, ratio, start, harmonics)  # (p, L)
        offsets = (np.arange(blocks + 1) * float((ratio * self.block) % 1)) % 1.0
        self.rotations = rotations(offsets, harmonics)  # (blocks + 1, p, p)
        for shared in (self.columns, self.rotations):
            shared.setflags(write=False)

    def sums(self, v: np.ndarray) -> np.ndarray:
        """``D'v`` of vectors ``v`` of shape ``(..., length)``: shape ``(..., p)``."""
        blocks, rest = divmod(self.length, self.block)
        head = v[..., : blocks * self.block].reshape(*v.shape[:-1], blocks, self.block)
        # one matrix-vector product per column: as fast as reading the samples
        per_block = np.stack([head @ column for column in self.columns], axis=-1)
        out = np.einsum("...jq,jpq->...p", per_block, self.rotations[:blocks])  # Eq. (1)
        if rest:
            tail = v[..., blocks * self.block:] @ self.columns[:, :rest].T
            out = out + tail @ self.rotations[blocks].T
        return out

    def gram(self, count: int) -> np.ndarray:
        """``D'D`` over the first ``count`` samples, ``(p, p)``."""
        blocks, rest = divmod(int(count), self.block)
        rot = self.rotations
        whole = self.columns @ self.columns.T
        part = self.columns[:, :rest] @ self.columns[:, :rest].T
        # Eq. (1) as one product: with E'E = S S', sum_j T_j S (T_j S)' = W W'
        w, v = np.linalg.eigh(whole)
        turned = rot[:blocks] @ (v * np.sqrt(np.maximum(w, 0.0)))  # (blocks, p, p)
        flat = turned.transpose(1, 0, 2).reshape(whole.shape[0], -1)
        return flat @ flat.T + rot[blocks] @ part @ rot[blocks].T

    def design(self, count: int) -> np.ndarray:
        """The design rows of the first ``count`` samples, ``(count, p)`` (built on request)."""
        blocks, rest = divmod(int(count), self.block)
        p = self.columns.shape[0]
        rows = np.einsum("jpq,ql->jlp", self.rotations[:blocks], self.columns).reshape(-1, p)
        return np.concatenate([rows, (self.rotations[blocks] @ self.columns[:, :rest]).T])


def _block_design(length: int, ratio: Fraction, start: float, harmonics: int) -> np.ndarray:
    """The ``(p, length)`` design of one block, from ~sqrt(length) sub-blocks rotated."""
    sub = max(1, int(np.sqrt(length)))
    first = design((start + np.arange(sub) * float(ratio % 1)) % 1.0, harmonics)  # (sub, p)
    turns = rotations((np.arange(-(-length // sub)) * float((ratio * sub) % 1)) % 1.0,
                      harmonics)
    rows = (first @ turns.transpose(0, 2, 1)).reshape(-1, first.shape[1])[:length]
    return np.ascontiguousarray(rows.T)


def design(cycles, harmonics: int) -> np.ndarray:
    """Columns ``1, cos(2 pi k c), sin(2 pi k c)``, ``k = 1..H``, of phases ``c`` in cycles."""
    cycles = np.asarray(cycles, dtype=float)
    cols = [np.ones_like(cycles)]
    for k in range(1, harmonics + 1):
        wt = 2 * np.pi * ((k * cycles) % 1.0)
        cols += [np.cos(wt), np.sin(wt)]
    return np.stack(cols, axis=-1)


def rotations(cycles, harmonics: int) -> np.ndarray:
    """``(m, p, p)`` maps of design rows at phase ``c`` to ``c + cycles[j]``."""
    p = 1 + 2 * harmonics
    rot = np.zeros((len(cycles), p, p))
    rot[:, 0, 0] = 1.0
    for k in range(1, harmonics + 1):
        wt = 2 * np.pi * ((k * np.asarray(cycles, dtype=float)) % 1.0)
        c, s = np.cos(wt), np.sin(wt)
        i = 2 * k - 1  # cos(a + b) = cos a cos b - sin a sin b, sin(a + b) = sin a cos b + ...
        rot[:, i, i], rot[:, i, i + 1], rot[:, i + 1, i], rot[:, i + 1, i + 1] = c, -s, s, c
    return rot
