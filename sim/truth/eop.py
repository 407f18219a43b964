"""Earth orientation parameters for truth: pole coordinates, UT1-UTC and celestial pole offsets.

Daily values of the IERS EOP 20 C04 series (Bizouard et al. 2019; consistent with ITRF2020),
shipped for the spans the scenarios fly (``data/eop_c04.csv`` says which), interpolated with a
cubic spline. UT1-UTC jumps by 1 s at a leap second, so the spline runs through UT1-TAI, which
is smooth. Daily sampling leaves the sub-daily ocean-tide and libration terms (< 0.1 ms in UT1,
< 0.5 mas in the pole, i.e. < 5 cm and < 1.5 cm at the surface) out, as the series does.
A time outside the shipped spans is refused: truth never silently assumes zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import erfa
import numpy as np

from fsw.astro.constants import SECONDS_PER_DAY

_FILE = Path(__file__).with_name("data") / "eop_c04.csv"
_AS = math.pi / (180.0 * 3600.0)
_MJD_J2000_TAI = 51544.5  # MJD of 2000-01-01T12:00:00 (on the TAI scale for TAI arguments)


class EopError(ValueError):
    """A time outside the shipped EOP spans."""


@dataclass(frozen=True)
class EopSample:
    """Interpolated EOP at N epochs: radians and seconds."""

    xp: np.ndarray
    yp: np.ndarray
    ut1_minus_tai: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    ut1_rate: np.ndarray  # d(UT1-TAI)/dt [s/s]: minus the excess length of day over 86400 s


class _Span:
    def __init__(self, tai_s: np.ndarray, cols: np.ndarray) -> None:
        # imported here: the scenario configuration imports this module in every process (0.3 s)
        from scipy.interpolate import CubicSpline

        self.lo, self.hi = float(tai_s[0]), float(tai_s[-1])
        self.spline = CubicSpline(tai_s, cols, axis=0)
        self.slope = self.spline.derivative()


@lru_cache(maxsize=1)
def _spans() -> tuple[_Span, ...]:
    data = np.loadtxt(_FILE, delimiter=",", comments="#", skiprows=5)
    mjd = data[:, 0]
    dat = np.array([erfa.dat(*erfa.jd2cal(2400000.5, m)[:3], 0.0) for m in mjd])
    tai_s = (mjd - _MJD_J2000_TAI) * SECONDS_PER_DAY + dat  # 0h UTC of each row, as TAI seconds past J2000
    cols = np.column_stack([data[:, 1] * _AS, data[:, 2] * _AS, data[:, 3] - dat, data[:, 4] * _AS,
                            data[:, 5] * _AS])
    breaks = np.flatnonzero(np.diff(mjd) != 1.0) + 1
    return tuple(_Span(t, c) for t, c in zip(np.split(tai_s, breaks), np.split(cols, breaks)))


def coverage() -> tuple[tuple[float, float], ...]:
    """(first, last) TAI seconds past J2000 of each shipped span."""
    return tuple((s.lo, s.hi) for s in _spans())


def eop_at_tai(tai_s) -> EopSample:
    """EOP at TAI seconds past J2000 (N,); raises :class:`EopError` outside the shipped spans."""
    t = np.atleast_1d(np.asarray(tai_s, dtype=float))
    out = np.full((t.size, 6), np.nan)
    for span in _spans():
        inside = (t >= span.lo) & (t <= span.hi)
        if inside.any():
            out[inside, :5] = span.spline(t[inside])
            out[inside, 5] = span.slope(t[inside])[:, 2]
    if np.isnan(out).any():
        bad = float(t[np.isnan(out[:, 0])][0])
        spans = ", ".join(f"[{a:.0f}, {b:.0f}]" for a, b in coverage())
        raise EopError(f"no Earth orientation data at TAI {bad:.0f} s past J2000; shipped spans (TAI s): {spans}")
    return EopSample(out[:, 0], out[:, 1], out[:, 2], out[:, 3], out[:, 4], out[:, 5])
