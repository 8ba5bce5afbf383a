"""Time: TDB seconds since J2000 (JD 2451545.0 TDB) throughout planetnav.

Calendar dates given to these helpers are read as TDB. Converting UTC to TDB
(about 69 s in 2020s) is left to the caller: it shifts an epoch, never the physics.
"""

from __future__ import annotations

import numpy as np

J2000_JD = 2451545.0
SECONDS_PER_DAY = 86400.0
DAYS_PER_JULIAN_CENTURY = 36525.0


def julian_date(year: int, month: int, day: int, hour: float = 0.0) -> float:
    """Julian date of a Gregorian calendar date (Meeus, Astronomical Algorithms, ch. 7)."""
    if not 1 <= month <= 12:
        raise ValueError(f"month must be 1..12, got {month}")
    y, m = (year - 1, month + 12) if month <= 2 else (year, month)
    a = y // 100
    b = 2 - a + a // 4
    return int(365.25 * (y + 4716)) + int(30.6001 * (m + 1)) + day + b - 1524.5 + hour / 24.0


def tdb_seconds(year: int, month: int, day: int, hour: float = 0.0) -> float:
    """TDB seconds since J2000 of a calendar date read as TDB."""
    return (julian_date(year, month, day, hour) - J2000_JD) * SECONDS_PER_DAY


def jd_from_seconds(t: np.ndarray | float) -> np.ndarray:
    """Julian date (TDB) from TDB seconds since J2000."""
    return J2000_JD + np.asarray(t, dtype=float) / SECONDS_PER_DAY


def centuries_from_seconds(t: np.ndarray | float) -> np.ndarray:
    """Julian centuries (TDB) since J2000 from TDB seconds since J2000."""
    return np.asarray(t, dtype=float) / (SECONDS_PER_DAY * DAYS_PER_JULIAN_CENTURY)
