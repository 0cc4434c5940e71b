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
The Earth: its constants, the inertial frame and the Earth's orientation in it.

**The inertial frame is EME2000**: the mean equator and mean equinox of J2000.0 (the FK5
system's), geocentric. It differs from the GCRF by the frame bias, a fixed rotation of 0.023
arcsec at most (IERS Conventions 2010, 5.5.1), which nothing here resolves: read it as the GCRF
to 0.03 arcsec.

**The Earth-fixed frame is the PEF** (pseudo Earth-fixed, the IERS terrestrial frame without
polar motion): ``r_EF = W(t) r_N`` with ``W = R3(GAST) N P``, the IAU-76/FK5 reduction of
Vallado, *Fundamentals of Astrodynamics and Applications* (4th ed., 2013), ch. 3:

- ``P``: IAU 1976 precession (Lieske et al. 1977, A&A 58, 1), exact for the model;
- ``N``: IAU 1980 nutation (Seidelmann 1982), the largest :data:`NUTATION_TERMS` of its 106 terms
  (Meeus, *Astronomical Algorithms*, 2nd ed., 1998, table 22.A); the terms left out add up to
  0.01 arcsec at most (measured against SOFA's full series in test/test_earth_frames.py);
- ``GAST = GMST + Eq_eq``: GMST 1982 (Aoki et al. 1982, A&A 105, 359) and the equation of
  the equinoxes with its two IAU 1994 terms (IERS Conventions 1996), UT1 taken as UTC (at most
  13.5 arcsec of rotation, :mod:`.epochs`);
- polar motion left out: 0.5 arcsec at most (15 m on the ground).

IAU 1976/1980 against today's IAU 2006/2000A with the measured celestial pole offsets: about
0.05 arcsec over 1995-2026, frame bias included (test/test_earth_frames.py, with astropy).

**SGP4's TEME** (true equator, mean equinox of date; Vallado et al. 2006, "Revisiting Spacetrack
Report #3", AIAA 2006-6753) reaches EME2000 as ``r_N = Pᵀ Nᵀ R3(-Eq_eq) r_TEME`` (TEME's x axis
lies ``Eq_eq`` from the true equinox along the true equator): the same rotation as
``Wᵀ R3(GMST)``, TEME -> PEF -> EME2000. TEME turns at most ~1e-11 rad/s against EME2000, so
velocities take the same rotation (the neglected ``Ẇ`` term is below 0.1 mm/s).

Also :func:`earth_rotation_angle` (IAU 2000, the CIO-based angle) for users of the IAU 2006
reduction. Rotation matrices are passive (frame rotations): ``R3(a) = [[c, s, 0], [-s, c, 0],
[0, 0, 1]]``. Every function takes UTC instants (:mod:`.epochs`), one or an array, and returns
one value or matrix per instant.
"""

from __future__ import annotations

import numpy as np

from . import environment_kernels as _k
from . import epochs
from .environment_kernels import FUNDAMENTAL_ARGUMENTS, NUTATION_TERMS

#: GM of the Earth, m^3/s^2 (WGS 84, NGA.STND.0036 (2014); the IERS's value too)
GM = 3.986004418e14
#: equatorial radius, m (WGS 84): the Earth's sphere for the shadow and the orbits' checks
EQUATORIAL_RADIUS = _k.EQUATORIAL_RADIUS
#: J2 = -sqrt(5) C20 of EGM2008 (normalised C20 = -0.484165143790815e-3; Pavlis et al. 2012)
J2 = 1.0826261738522e-3

ARCSECOND = np.pi / (180.0 * 3600.0)
TWO_PI = 2.0 * np.pi


def _rotation(axis: int, angle) -> np.ndarray:
    """Return the passive rotations ``R_axis(angle)``, shape ``angle.shape + (3, 3)``."""
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    matrix = np.zeros(angle.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis - 1]
    matrix[..., axis - 1, axis - 1] = 1.0
    matrix[..., i, i] = c
    matrix[..., j, j] = c
    matrix[..., i, j] = s
    matrix[..., j, i] = -s
    return matrix


def precession_matrix(seconds) -> np.ndarray:
    """
    Return IAU 1976 precession ``P``: EME2000 -> mean equator and equinox of date.

    ``P = R3(-z) R2(theta) R3(-zeta)`` with Lieske's angles in TT centuries (SOFA's pmat76).
    """
    t = epochs.julian_centuries_tt(seconds)
    zeta = ((0.017998 * t + 0.30188) * t + 2306.2181) * t * ARCSECOND
    theta = ((-0.041833 * t - 0.42665) * t + 2004.3109) * t * ARCSECOND
    z = ((0.018203 * t + 1.09468) * t + 2306.2181) * t * ARCSECOND
    return _rotation(3, -z) @ _rotation(2, theta) @ _rotation(3, -zeta)


def mean_obliquity(seconds):
    """Return the IAU 1980 mean obliquity of the ecliptic, rad (Lieske et al. 1977; SOFA obl80)."""
    t = epochs.julian_centuries_tt(seconds)
    return (((0.001813 * t - 0.00059) * t - 46.8150) * t + 84381.448) * ARCSECOND


def fundamental_arguments(t):
    """
    Return the Delaunay arguments ``D, M, M', F, Omega`` (rad) at TT centuries ``t``.

    IAU 1980 (Meeus ch. 22; SOFA's nut80 uses the same polynomials in arcseconds).
    """
    degrees = FUNDAMENTAL_ARGUMENTS
    t = np.asarray(t, dtype=float)[..., None]
    values = ((degrees[:, 3] * t + degrees[:, 2]) * t + degrees[:, 1]) * t + degrees[:, 0]
    return np.deg2rad(np.fmod(values, 360.0))


def nutation(seconds):
    """
    Return IAU 1980 nutation ``(dpsi, deps)`` in longitude and obliquity, rad.

    The largest terms of the series (:data:`NUTATION_TERMS`: multipliers of ``D, M, M', F,
    Omega``, then ``dpsi`` and ``deps`` coefficients and their rates, 0.0001 arcsec and per
    century).
    """
    t = epochs.julian_centuries_tt(seconds)
    arguments = fundamental_arguments(t) @ NUTATION_TERMS[:, :5].T
    t = t[..., None]
    dpsi = ((NUTATION_TERMS[:, 5] + NUTATION_TERMS[:, 6] * t) * np.sin(arguments)).sum(axis=-1)
    deps = ((NUTATION_TERMS[:, 7] + NUTATION_TERMS[:, 8] * t) * np.cos(arguments)).sum(axis=-1)
    return dpsi * 1e-4 * ARCSECOND, deps * 1e-4 * ARCSECOND


def nutation_matrix(seconds) -> np.ndarray:
    """Return ``N = R1(-eps) R3(-dpsi) R1(eps_mean)``: mean of date -> true of date."""
    dpsi, deps = nutation(seconds)
    eps_mean = mean_obliquity(seconds)
    return _rotation(1, -(eps_mean + deps)) @ _rotation(3, -dpsi) @ _rotation(1, eps_mean)


def equation_of_equinoxes(seconds):
    """
    Return the equation of the equinoxes (IAU 1994), rad.

    ``dpsi cos(eps_mean) + 0.00264" sin(Omega) + 0.000063" sin(2 Omega)`` (IERS Conventions
    1996; SOFA's eqeq94).
    """
    dpsi, _ = nutation(seconds)
    omega = fundamental_arguments(epochs.julian_centuries_tt(seconds))[..., 4]
    kinematic = (0.00264 * np.sin(omega) + 0.000063 * np.sin(2.0 * omega)) * ARCSECOND
    return dpsi * np.cos(mean_obliquity(seconds)) + kinematic


def gmst(seconds):
    """
    Return Greenwich mean sidereal time (IAU 1982), rad in ``[0, 2 pi)``, with UT1 = UTC.

    Aoki et al. (1982), written as SOFA's gmst82 (the day's fraction apart,
    so the large rate does not cost digits).
    """
    seconds = np.asarray(seconds, dtype=float)
    t = seconds / epochs.SECONDS_PER_CENTURY
    day_seconds = np.fmod(seconds, epochs.SECONDS_PER_DAY)
    # 24110.54841 s at 0h UT1; J2000.0 is 12h, hence the half day
    angle = (((-6.2e-6 * t + 0.093104) * t + 8640184.812866) * t + (24110.54841 - 43200.0)
             + day_seconds) * (TWO_PI / epochs.SECONDS_PER_DAY)
    return np.mod(angle, TWO_PI)


def gast(seconds):
    """Return Greenwich apparent sidereal time, ``GMST + Eq_eq``, rad in ``[0, 2 pi)``."""
    return np.mod(gmst(seconds) + equation_of_equinoxes(seconds), TWO_PI)


def earth_rotation_angle(seconds):
    """
    Return the Earth rotation angle (IAU 2000), rad in ``[0, 2 pi)``, with UT1 = UTC.

    ``2 pi (0.7790572732640 + 1.00273781191135448 Du)``, ``Du`` days since J2000.0 (IERS
    Conventions 2010, eq. 5.15), the day's fraction apart as in SOFA's era00.
    """
    days = np.asarray(seconds, dtype=float) / epochs.SECONDS_PER_DAY
    turns = np.fmod(days, 1.0) + 0.7790572732640 + 0.00273781191135448 * days
    return np.mod(TWO_PI * turns, TWO_PI)


def earth_fixed_matrix(seconds) -> np.ndarray:
    """Return ``W = R3(GAST) N P``: ``r_EF = W r_N`` (EME2000 -> PEF), shape ``(..., 3, 3)``."""
    return _rotation(3, gast(seconds)) @ nutation_matrix(seconds) @ precession_matrix(seconds)


def teme_matrix(seconds) -> np.ndarray:
    """Return ``Pᵀ Nᵀ R3(-Eq_eq)``: ``r_N = M r_TEME`` (SGP4's TEME -> EME2000)."""
    rotation = _rotation(3, -equation_of_equinoxes(seconds))
    return np.swapaxes(nutation_matrix(seconds) @ precession_matrix(seconds), -1, -2) @ rotation


def to_earth_fixed(vectors_N, seconds) -> np.ndarray:
    """Return inertial ``vectors_N`` (``(..., 3)``, one per instant) in the Earth-fixed frame."""
    return np.einsum('...ij,...j->...i', earth_fixed_matrix(seconds), vectors_N)


def from_earth_fixed(vectors_EF, seconds) -> np.ndarray:
    """Return Earth-fixed ``vectors_EF`` (``(..., 3)``, one per instant) in the inertial frame."""
    return np.einsum('...ji,...j->...i', earth_fixed_matrix(seconds), vectors_EF)
