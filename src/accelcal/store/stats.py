"""Repeatability and drift of stored coefficients, in one pass over the store's rows.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, definitions of repeatability (run-to-run
   spread under the same conditions) and of drift.
"""

import datetime as dt
import math
from dataclasses import dataclass
from operator import itemgetter

import numpy as np

SECONDS_PER_YEAR = 365.25 * 86400.0
"""A Julian year, the unit of the drift."""


@dataclass(frozen=True)
class CoefficientStats:
    """Repeatability and drift of one coefficient across calibrations.

    Attributes
    ----------
    method : str
        Calibration method; coefficients of different methods (or different
        tests: a VRE fit's K2 is not a tumble's K2) are never pooled.
    name, unit : str
    n : int
        Calibrations.
    mean : float
    repeatability : float
        Sample standard deviation across calibrations (run-to-run).
    mean_std : float
        Mean of the calibrations' own standard uncertainties; a repeatability
        well above it means the coefficient moves more than each calibration
        claims.
    drift_per_year : float
        Slope of a straight-line fit against the calibration dates (NaN with
        fewer than 3 calibrations).
    drift_std : float
        Standard uncertainty of the slope (NaN with fewer than 3 calibrations).
    """

    method: str
    name: str
    unit: str
    n: int
    mean: float
    repeatability: float
    mean_std: float
    drift_per_year: float
    drift_std: float


def summarise(calibrations: list[tuple], coefficients: list[tuple]) -> list[CoefficientStats]:
    """Statistics of each (method, coefficient), in one pass over the store's rows.

    Parameters
    ----------
    calibrations : list of tuple
        (id, date, method) of each calibration, in date order; the date is
        ISO 8601.
    coefficients : list of tuple
        (calibration id, name, unit, estimate, standard uncertainty or None)
        of each of their coefficients, in date order, then in order within
        the calibration. A row of a calibration not in ``calibrations`` is
        left out.

    Returns
    -------
    list of CoefficientStats
        One per (method, coefficient), in order of first appearance.

    References
    ----------
    .. [1] IEEE Std 1293-2018, definitions of repeatability and drift.
    """
    if not (calibrations and coefficients):
        return []
    cal_ids, dates, methods = (list(map(itemgetter(i), calibrations)) for i in range(3))
    row_cal, names, x_all, s_all = (list(map(itemgetter(i), coefficients))
                                    for i in (0, 1, 3, 4))
    cal_ids, row_cal = np.array(cal_ids), np.array(row_cal)
    by_id = np.argsort(cal_ids)
    at = by_id[np.searchsorted(cal_ids, row_cal, sorter=by_id).clip(max=len(cal_ids) - 1)]
    known = cal_ids[at] == row_cal
    method_names, method_code = _codes(methods)
    coefficient_names, name_code = _codes(names)
    codes = np.where(known, method_code[at] * len(coefficient_names) + name_code, -1)
    x_all = np.array(x_all, dtype=float)
    s_all = np.array(s_all, dtype=float)  # None -> NaN
    t_all = _seconds(dates)[at]
    order = np.argsort(codes, kind="stable")  # stable: each group keeps its date order
    values, first, counts = np.unique(codes[order], return_index=True, return_counts=True)
    out = []
    for g in np.argsort(order[first]):  # groups in order of their first row
        if values[g] < 0:
            continue
        rows = order[first[g]:first[g] + counts[g]]
        x, s, t = x_all[rows], s_all[rows], t_all[rows]
        slope, slope_std = _drift((t - t.min()) / SECONDS_PER_YEAR, x)
        out.append(CoefficientStats(
            method=method_names[values[g] // len(coefficient_names)],
            name=coefficient_names[values[g] % len(coefficient_names)],
            unit=coefficients[rows[0]][2],
            n=len(x), mean=float(x.mean()),
            repeatability=float(x.std(ddof=1)) if len(x) > 1 else math.nan,
            mean_std=float(np.nanmean(s)) if np.isfinite(s).any() else math.nan,
            drift_per_year=slope, drift_std=slope_std,
        ))
    return out


def _codes(labels: list[str]) -> tuple[list[str], np.ndarray]:
    """The distinct labels in order of first appearance, and each label's index among them."""
    distinct = list(dict.fromkeys(labels))
    index = {label: i for i, label in enumerate(distinct)}
    return distinct, np.fromiter(map(index.__getitem__, labels), dtype=np.intp,
                                 count=len(labels))


def _seconds(dates: list[str]) -> np.ndarray:
    """Seconds since 1970 of ISO 8601 dates (naive ones taken as UTC).

    The store writes every date in UTC (``+00:00``); those are parsed by
    numpy at once, any other one by :meth:`datetime.datetime.fromisoformat`.
    Both give the same microseconds, exactly.
    """
    if all(d.endswith("+00:00") for d in dates):
        try:
            us = np.array([d[:-6] for d in dates], dtype="datetime64[us]")
        except ValueError:
            pass
        else:
            return (us - np.datetime64(0, "us")).astype(np.int64) / 1e6
    out = []
    for d in dates:
        moment = dt.datetime.fromisoformat(d)
        if moment.tzinfo is None:
            moment = moment.replace(tzinfo=dt.UTC)
        out.append(moment.timestamp())
    return np.array(out)


def _drift(years: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """Least-squares slope of x against time and its standard uncertainty.

    NaN for fewer than three calibrations at distinct dates: a slope through
    two points has no uncertainty to judge it by (two calibrations minutes
    apart would give a meaningless "drift per year").
    """
    if len(x) < 3 or np.unique(years).size < 2:
        return math.nan, math.nan
    A = np.column_stack([np.ones_like(years), years])
    coef, *_ = np.linalg.lstsq(A, x, rcond=None)
    resid = x - A @ coef
    cov = np.linalg.inv(A.T @ A) * (resid @ resid) / (len(x) - 2)
    return float(coef[1]), float(np.sqrt(cov[1, 1]))
