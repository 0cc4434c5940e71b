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
The Earth's magnetic field: IGRF-14, and the tilted dipole as a cheap choice.

**IGRF-14** (IAGA 2024, doi:10.5281/zenodo.14012302; the model's equations are those of the
IGRF-13 paper, Alken et al. 2021, Earth Planets Space 73:49): the internal field's potential
``V = a sum_{n=1}^{13} sum_{m=0}^{n} (a/r)^{n+1} (g_n^m cos m phi + h_n^m sin m phi) P_n^m(cos
theta)`` (Schmidt semi-normalised, ``a`` = 6371.2 km, geocentric), ``B = -grad V``, its
coefficients linear in time between the 5-yearly epochs of 1900.0-2025.0 and by the predicted
secular variation to 2030.0 (:mod:`.igrf14_coefficients`, the released table). An instant outside
1900.0-2030.0 is refused with :class:`~..checks.schema.FieldError`. The model is the main
(core) field: crustal fields (up to ~20 nT at 400 km) and the ionospheric and magnetospheric
currents (tens of nT in quiet times, hundreds in storms) are not in it. This code agrees with
``ppigrf`` to 1e-6 nT at the epochs and 0.1 nT between them, where ppigrf interpolates in elapsed
days and the IGRF (and this code) in decimal years (test/test_magnetic_field.py). UT1 = UTC costs
at most 13.5 arcsec of longitude: below ``|B|`` times that angle, 3 nT.

Evaluated as Cunningham's Cartesian solid harmonics and their gradient (Montenbruck and Gill,
*Satellite Orbits*, 2000, section 3.2, with the magnetic potential ``a sum (C V + S W)`` in place
of ``GM/R sum (C V + S W)``): the coefficients unnormalised, ``C_n^m = g_n^m sqrt((2 -
delta_m0) (n-m)!/(n+m)!)``; no division by ``sin theta``, so the poles are ordinary points.

**The tilted dipole**: IGRF's degree 1 alone at the same instant, ``B = (a/r)^3 (3 (g.r^) r^ -
g)`` with ``g = (g_1^1, h_1^1, g_1^0)`` (the centred dipole of moment ``4 pi a^3 |g| / mu0``,
7.7e22 A m^2 at 2025.0): tens of percent off IGRF in places (the South Atlantic Anomaly), a few
percent on average.

Frames: the field is computed in the Earth-fixed frame (:mod:`.earth`, PEF) and rotated into the
inertial frame (EME2000) at the same instant; local north-east-down axes are geocentric (down to
the Earth's centre; geodetic down differs by up to 0.19 deg). Positions in m, fields in tesla,
one position per instant (``(..., 3)`` and ``(...)``).
:func:`.environment_kernels.igrf_earth_fixed` and its siblings are the compiled forms.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from . import earth, epochs
from . import environment_kernels as _k
from .igrf14_coefficients import EPOCHS, ROWS
from ..checks.schema import FieldError

#: the years the model covers
FIRST_YEAR = EPOCHS[0]
LAST_YEAR = EPOCHS[-1]


@functools.lru_cache(maxsize=None)
def schmidt_table() -> np.ndarray:
    """Return the released coefficients, ``(epochs, 2, 14, 14)``: ``[k, 0|1, n, m]`` = g|h, nT."""
    table = np.zeros((len(EPOCHS), 2, _k.IGRF_DEGREE + 1, _k.IGRF_DEGREE + 1))
    for n, m, values in ROWS:
        table[:, 0 if m >= 0 else 1, n, abs(m)] = values
    table.setflags(write=False)
    return table


@functools.lru_cache(maxsize=None)
def kernel_table() -> np.ndarray:
    """
    Return the coefficients unnormalised (``C = g sqrt((2 - delta_m0)(n-m)!/(n+m)!)``), nT.

    ``(epochs, 2, 14, 14)``, the ``table`` argument of the compiled kernels.
    """
    factor = np.zeros((_k.IGRF_DEGREE + 1, _k.IGRF_DEGREE + 1))
    for n in range(_k.IGRF_DEGREE + 1):
        for m in range(n + 1):
            factor[n, m] = math.sqrt(
                (2.0 if m else 1.0) * math.factorial(n - m) / math.factorial(n + m)
            )
    table = np.ascontiguousarray(schmidt_table() * factor)
    table.setflags(write=False)
    return table


def _year_start_seconds(year: float) -> float:
    """Return the UTC instant (s since J2000.0) where :func:`.epochs.decimal_year` is ``year``."""
    return float(epochs.year_start_days(int(year))) * _k.SECONDS_PER_DAY - 43200.0


#: the instants that bound the model's years (integral years: January 1, 00:00 UTC)
FIRST_INSTANT = _year_start_seconds(FIRST_YEAR)
LAST_INSTANT = _year_start_seconds(LAST_YEAR)


def check_instants(seconds, path: str = 'time', years: bool = True) -> np.ndarray | None:
    """
    Return the decimal years of the UTC instants ``seconds``, each inside IGRF-14's 1900-2030.

    Outside, :class:`~..checks.schema.FieldError` at ``path`` names the first one and the range.
    ``years=False``: check only, against the bounding instants (the decimal year is monotonic in
    the instant; a sample in a closed loop does not pay for the calendar), and return None.
    """
    if not years and np.size(seconds) == 1:  # one instant (a sensor's sample): floats
        instant = float(np.reshape(seconds, -1)[0])
        if FIRST_INSTANT <= instant <= LAST_INSTANT:  # (False for NaN: checked below)
            return None
    seconds = np.atleast_1d(np.asarray(seconds, dtype=float))
    if not np.isfinite(seconds).all():
        raise FieldError(path, 'every instant must be finite')
    if not years and ((seconds >= FIRST_INSTANT) & (seconds <= LAST_INSTANT)).all():
        return None
    years = epochs.decimal_year(seconds)
    outside = ~((years >= FIRST_YEAR) & (years <= LAST_YEAR))
    if outside.any():
        first = float(years[outside][0])
        raise FieldError(
            path,
            f'IGRF-14 covers {FIRST_YEAR:.1f} to {LAST_YEAR:.1f} (decimal years); {first:.4f} is '
            'outside it (the model is not defined there: its secular variation is a 5-year '
            'forecast)',
        )
    return years


class _Coefficients:
    """The unnormalised coefficients at ``years`` (``(N,)``), one ``(n, m)`` at a time."""

    def __init__(self, years):
        self._columns = np.moveaxis(kernel_table(), 0, -1)  # (2, 14, 14, epochs)
        self._k = np.minimum(
            ((years - _k.IGRF_FIRST_EPOCH) / _k.IGRF_EPOCH_STEP).astype(np.int64),
            len(EPOCHS) - 2,
        )
        self._fraction = (
            (years - (_k.IGRF_FIRST_EPOCH + _k.IGRF_EPOCH_STEP * self._k)) / _k.IGRF_EPOCH_STEP
        )

    def __call__(self, kind: int, n: int, m: int) -> np.ndarray:
        """``C_n^m`` (``kind`` 0) or ``S_n^m`` (1) at each year: the kernel's interpolation."""
        column = self._columns[kind, n, m]
        low, high = column[self._k], column[self._k + 1]
        return low + self._fraction * (high - low)


def _flatten(position, seconds):
    position = np.asarray(position, dtype=float)
    shape = position.shape[:-1]
    seconds = np.broadcast_to(np.asarray(seconds, dtype=float), shape).reshape(-1)
    return position.reshape(-1, 3), seconds, shape


def igrf_earth_fixed(position_EF, seconds, path: str = 'time') -> np.ndarray:
    """
    Return IGRF-14's field (T, Earth-fixed) at the Earth-fixed ``position_EF`` (m).

    ``seconds``: the UTC instants (:mod:`.epochs`), one per position or one for all; an instant
    outside 1900-2030 is refused naming ``path``.
    """
    points, seconds, shape = _flatten(position_EF, seconds)
    years = check_instants(seconds, path)
    return _igrf(points, years).reshape(shape + (3,))


def _igrf(points, years):
    """Return the field at Earth-fixed ``points`` (N, 3) in ``years`` (N,): the kernel's sums."""
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    coefficient = _Coefficients(years)
    size = _k.IGRF_DEGREE + 2
    v = np.zeros((size, size, points.shape[0]))
    w = np.zeros((size, size, points.shape[0]))
    r2 = x * x + y * y + z * z
    scale = _k.IGRF_RADIUS / r2
    xs, ys, zs = x * scale, y * scale, z * scale
    rho = _k.IGRF_RADIUS * scale
    v[0, 0] = _k.IGRF_RADIUS / np.sqrt(r2)
    for m in range(size):
        if m > 0:
            v[m, m] = (2 * m - 1) * (xs * v[m - 1, m - 1] - ys * w[m - 1, m - 1])
            w[m, m] = (2 * m - 1) * (xs * w[m - 1, m - 1] + ys * v[m - 1, m - 1])
        if m + 1 < size:
            v[m + 1, m] = (2 * m + 1) * zs * v[m, m]
            w[m + 1, m] = (2 * m + 1) * zs * w[m, m]
        for n in range(m + 2, size):
            a, b = _k.RECURSION_A[n, m], _k.RECURSION_B[n, m]
            v[n, m] = a * zs * v[n - 1, m] - b * rho * v[n - 2, m]
            w[n, m] = a * zs * w[n - 1, m] - b * rho * w[n - 2, m]
    gx = np.zeros(points.shape[0])
    gy = np.zeros(points.shape[0])
    gz = np.zeros(points.shape[0])
    for n in range(1, _k.IGRF_DEGREE + 1):
        cn = coefficient(0, n, 0)
        gx -= cn * v[n + 1, 1]
        gy -= cn * w[n + 1, 1]
        gz -= (n + 1) * cn * v[n + 1, 0]
        for m in range(1, n + 1):
            cn, sn = coefficient(0, n, m), coefficient(1, n, m)
            factor = (n - m + 1) * (n - m + 2)
            gx += 0.5 * ((-cn * v[n + 1, m + 1] - sn * w[n + 1, m + 1])
                         + factor * (cn * v[n + 1, m - 1] + sn * w[n + 1, m - 1]))
            gy += 0.5 * ((-cn * w[n + 1, m + 1] + sn * v[n + 1, m + 1])
                         + factor * (-cn * w[n + 1, m - 1] + sn * v[n + 1, m - 1]))
            gz += (n - m + 1) * (-cn * v[n + 1, m] - sn * w[n + 1, m])
    return np.stack([-gx * 1e-9, -gy * 1e-9, -gz * 1e-9], axis=-1)


def dipole_earth_fixed(position_EF, seconds, path: str = 'time') -> np.ndarray:
    """Return the tilted dipole's field (T, Earth-fixed) at ``position_EF`` (m)."""
    points, seconds, shape = _flatten(position_EF, seconds)
    return _dipole(points, check_instants(seconds, path)).reshape(shape + (3,))


def _dipole(points, years):
    coefficient = _Coefficients(years)
    g = np.stack([coefficient(0, 1, 1), coefficient(1, 1, 1), coefficient(0, 1, 0)], axis=-1)
    r = np.sqrt((points * points).sum(axis=-1))
    unit = points / r[:, None]
    ratio = _k.IGRF_RADIUS / r
    scale = ratio * ratio * ratio * 1e-9
    along = 3.0 * (g * unit).sum(axis=-1)
    return scale[:, None] * (along[:, None] * unit - g)


def igrf_inertial(position_N, seconds, path: str = 'time') -> np.ndarray:
    """
    Return IGRF-14's field (T, inertial) at the inertial ``position_N`` (m).

    The position is rotated into the Earth-fixed frame at its instant, the field evaluated there
    and rotated back (:func:`.earth.earth_fixed_matrix`).
    """
    return _inertial(_igrf, position_N, seconds, path)


def dipole_inertial(position_N, seconds, path: str = 'time') -> np.ndarray:
    """Return the tilted dipole's field (T, inertial) at the inertial ``position_N`` (m)."""
    return _inertial(_dipole, position_N, seconds, path)


def _inertial(model, position_N, seconds, path):
    points, seconds, shape = _flatten(position_N, seconds)
    years = check_instants(seconds, path)
    matrix = earth.earth_fixed_matrix(seconds)
    fixed = np.einsum('nij,nj->ni', matrix, points)
    field = model(fixed, years)
    return np.einsum('nji,nj->ni', matrix, field).reshape(shape + (3,))


def ned_axes(position_EF) -> np.ndarray:
    """
    Return the local geocentric north, east and down axes at ``position_EF``, as rows.

    Shape ``(..., 3, 3)``.
    ``B_NED = ned_axes(r) @ B_EF``. Down points to the Earth's centre; at a pole (where east is
    undefined) east is taken as the y axis's direction at longitude 0.
    """
    position = np.asarray(position_EF, dtype=float)
    x, y, z = position[..., 0], position[..., 1], position[..., 2]
    horizontal = np.hypot(x, y)
    r = np.hypot(horizontal, z)
    longitude = np.arctan2(y, x)
    cos_lon, sin_lon = np.cos(longitude), np.sin(longitude)
    cos_lat, sin_lat = horizontal / r, z / r
    north = np.stack([-sin_lat * cos_lon, -sin_lat * sin_lon, cos_lat], axis=-1)
    east = np.stack([-sin_lon, cos_lon, np.zeros_like(x)], axis=-1)
    down = np.stack([-cos_lat * cos_lon, -cos_lat * sin_lon, -sin_lat], axis=-1)
    return np.stack([north, east, down], axis=-2)


def igrf_ned(position_EF, seconds, path: str = 'time') -> np.ndarray:
    """Return IGRF-14's field (T) in local geocentric north, east, down at ``position_EF``."""
    field = igrf_earth_fixed(position_EF, seconds, path)
    return np.einsum('...ij,...j->...i', ned_axes(position_EF), field)
