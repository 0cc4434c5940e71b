# Copyright 2026 torquefree_ros maintainers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Instants for the environment models: UTC seconds since J2000.0, and the scales the models read.

An instant is a float: UTC seconds since 2000-01-01T12:00:00 UTC, every day counted as 86 400 s
(SOFA's "quasi-JD" convention for UTC, and Python's ``datetime`` arithmetic): a leap second is
not counted, so an instant's Julian date is ``2451545 + seconds / 86400`` exactly. A float keeps
~0.1 µs at 2026 (ulp of 8e8 s), well below what any model here resolves.

The models read three scales from it:

- TT (precession, nutation, the Sun): ``TT = UTC + 69.184 s``, TAI - UTC = 37 s since
  2017-01-01 (IERS Bulletin C) plus TT - TAI = 32.184 s. Before 2017 the offset was smaller
  (32.184 s + 10 to 36 s since 1972): at most 59 s of error, 2.4 arcsec in the Sun's longitude and
  0.001 arcsec of precession.
- UT1 (the Earth's rotation) is taken equal to UTC: |UT1 - UTC| < 0.9 s (IERS keeps it so), at
  most 13.5 arcsec of Earth rotation (0.42 km along the equator at the surface).
- The decimal year (IGRF): the year plus the fraction of that calendar year elapsed, as the IGRF
  defines its time argument.
"""

from __future__ import annotations

import datetime as _datetime

import numpy as np

from .environment_kernels import TT_MINUS_UTC
from ..checks.schema import FieldError, shown

#: Julian date of J2000.0 (2000-01-01T12:00:00)
J2000_JD = 2451545.0
SECONDS_PER_DAY = 86400.0
#: seconds in a Julian century (36 525 days)
SECONDS_PER_CENTURY = 86400.0 * 36525.0
#: J2000.0 as an aware datetime
J2000 = _datetime.datetime(2000, 1, 1, 12, tzinfo=_datetime.timezone.utc)


def utc_seconds(value, path: str = 'epoch') -> float:
    """
    Return the UTC instant ``value`` as seconds since J2000.0 (days of 86 400 s).

    ``value``: an ISO 8601 string (``'2026-03-20T12:00:00Z'``; no offset means UTC), a
    ``datetime`` (naive means UTC, as PyYAML reads an unquoted timestamp) or a ``date``
    (midnight UTC). A bad value raises :class:`~..checks.schema.FieldError` naming ``path``.
    """
    moment = value
    if isinstance(value, str):
        try:
            moment = _datetime.datetime.fromisoformat(value.strip())
        except ValueError:
            raise FieldError(
                path, f"expected an ISO 8601 UTC time such as '2026-03-20T12:00:00Z', got "
                f'{shown(value)}'
            ) from None
    elif isinstance(value, _datetime.date) and not isinstance(value, _datetime.datetime):
        moment = _datetime.datetime(value.year, value.month, value.day)
    if not isinstance(moment, _datetime.datetime):
        raise FieldError(path, f'expected an ISO 8601 UTC time or a datetime, got {shown(value)}')
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=_datetime.timezone.utc)
    return (moment - J2000).total_seconds()


def utc_datetime(seconds: float) -> _datetime.datetime:
    """Return the instant ``seconds`` (UTC since J2000.0) as an aware ``datetime`` (to 1 µs)."""
    return J2000 + _datetime.timedelta(seconds=float(seconds))


def julian_centuries_tt(seconds):
    """Return TT Julian centuries since J2000.0 at the UTC instants ``seconds``."""
    return (np.asarray(seconds, dtype=float) + TT_MINUS_UTC) / SECONDS_PER_CENTURY


def year_start_days(year):
    """
    Return the days from 2000-01-01 to January 1 of ``year`` (proleptic Gregorian).

    Integer arithmetic with floor division: the same code for an int and an int64 array.
    """
    before = year - 1
    return (
        365 * (year - 2000)
        + (before // 4 - 1999 // 4)
        - (before // 100 - 1999 // 100)
        + (before // 400 - 1999 // 400)
    )


def decimal_year(seconds):
    """
    Return the decimal year at the UTC instants ``seconds``.

    The calendar year plus the fraction of it elapsed (its own length, 365 or 366 days), the time
    argument the IGRF is defined on.
    """
    seconds = np.asarray(seconds, dtype=float)
    # whole days since 2000-01-01T00:00 (J2000.0 is noon)
    days = np.floor((seconds + 43200.0) / SECONDS_PER_DAY).astype(np.int64)
    year = 2000 + np.floor(days / 365.2425).astype(np.int64)
    # the estimate is off by at most one year near a January 1: correct it both ways
    year = np.where(year_start_days(year) > days, year - 1, year)
    year = np.where(year_start_days(year + 1) <= days, year + 1, year)
    start = year_start_days(year)
    length = year_start_days(year + 1) - start
    elapsed = seconds + 43200.0 - start * SECONDS_PER_DAY
    return year + elapsed / (length * SECONDS_PER_DAY)
