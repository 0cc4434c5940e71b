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
The environment models as scalar kernels, compiled by numba together (one family).

For integrators that evaluate the environment at every stage: one instant, one position, no
allocation beyond two small work arrays, no Python. Each kernel repeats what its numpy reference
computes (:mod:`.orbit`, :mod:`.earth`, :mod:`.magnetic`, :mod:`.sun`, vectorised over instants),
in the same order; the tests hold the two together to rounding.

The numbers the models read (the nutation series, the radii, TT - UTC) are defined here and read
by the numpy path from here: numba rebuilds a kernel's cache when its own file changes, so a
constant kept in another file could go stale in a compiled kernel. The IGRF coefficients are an
argument (:func:`.magnetic.kernel_table`), for the same reason and because they are large.

Kernels:

- :func:`kepler_state`: position and velocity on a Keplerian orbit (a row of
  :data:`ORBIT_WIDTH` constants, :meth:`.orbit.KeplerOrbit.kernel_row`), t since its epoch;
- :func:`earth_fixed_matrix`: ``W`` with ``r_EF = W r_N`` at a UTC instant; its two halves
  :func:`celestial_matrix` (precession-nutation, slow: an integrator may hold it over a sample)
  and :func:`earth_fixed_matrix_held` (the Earth's rotation, per stage);
- :func:`igrf_earth_fixed`, :func:`igrf_inertial`: IGRF-14 in the Earth-fixed and inertial
  frames, tesla; :func:`dipole_earth_fixed`, :func:`dipole_inertial`: the tilted dipole;
  :func:`field_inertial_with`: either, inertial, through a given ``W`` and year;
  :func:`fields_inertial`: either at many instants, one by one (a sensor's samples);
  :func:`environment_one`: the orbit's position and the field there at one instant (a sensor's
  sample in a closed loop), :func:`environments` at each of many;
- :func:`sun_position`: the Sun in the inertial frame, m; :func:`shadow_fraction`: 0 lit to 1
  umbra.

The caller validates first (orbits, the field's years): out of its range a kernel returns NaN.
Call :func:`compile_kernels` before the first use (or read the kernels through :func:`kernel`).
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.kernels import KernelFamily

#: TT - UTC since 2017-01-01: 32.184 s + 37 leap seconds (IERS Bulletin C); see :mod:`.epochs`
TT_MINUS_UTC = 69.184
#: WGS 84 equatorial radius, m (the Earth's sphere for the shadow)
EQUATORIAL_RADIUS = 6378137.0
#: the Sun's nominal radius, m (IAU 2015 Resolution B3)
SUN_RADIUS = 6.957e8
#: the astronomical unit, m (IAU 2012 Resolution B2)
ASTRONOMICAL_UNIT = 149597870700.0
#: the annual aberration in the Sun's longitude, deg (20.4898" / R; Meeus eq. 25.10's 0.00569)
ABERRATION_DEGREES = 0.00569
#: IGRF's reference radius, m, its degree, its first epoch and the step between epochs (years)
IGRF_RADIUS = 6371200.0
IGRF_DEGREE = 13
IGRF_FIRST_EPOCH = 1900.0
IGRF_EPOCH_STEP = 5.0
# Cunningham's recursion V_nm = A_nm (z a/r^2) V_n-1,m - B_nm (a/r)^2 V_n-2,m (n >= m + 2), with
# A = (2n - 1)/(n - m) and B = (n + m - 1)/(n - m) as numbers (a product, not a division, a step)
RECURSION_A = np.zeros((IGRF_DEGREE + 2, IGRF_DEGREE + 2))
RECURSION_B = np.zeros((IGRF_DEGREE + 2, IGRF_DEGREE + 2))
for _n in range(IGRF_DEGREE + 2):
    for _m in range(_n - 1):
        RECURSION_A[_n, _m] = (2 * _n - 1) / (_n - _m)
        RECURSION_B[_n, _m] = (_n + _m - 1) / (_n - _m)
del _n, _m

# IAU 1980 nutation, its largest terms (Meeus, Astronomical Algorithms, 2nd ed., table 22.A):
# multipliers of D, M, M', F, Omega; dpsi = (A + A' T) sin(arg), deps = (B + B' T) cos(arg), in
# 0.0001 arcsec (and per Julian century T). The 72 terms left out are each 0.001 arcsec or less
# (together 0.009 arcsec at most over 1970-2035, against SOFA's nut80).
NUTATION_TERMS = np.array([
    (0, 0, 0, 0, 1, -171996.0, -174.2, 92025.0, 8.9),
    (-2, 0, 0, 2, 2, -13187.0, -1.6, 5736.0, -3.1),
    (0, 0, 0, 2, 2, -2274.0, -0.2, 977.0, -0.5),
    (0, 0, 0, 0, 2, 2062.0, 0.2, -895.0, 0.5),
    (0, 1, 0, 0, 0, 1426.0, -3.4, 54.0, -0.1),
    (0, 0, 1, 0, 0, 712.0, 0.1, -7.0, 0.0),
    (-2, 1, 0, 2, 2, -517.0, 1.2, 224.0, -0.6),
    (0, 0, 0, 2, 1, -386.0, -0.4, 200.0, 0.0),
    (0, 0, 1, 2, 2, -301.0, 0.0, 129.0, -0.1),
    (-2, -1, 0, 2, 2, 217.0, -0.5, -95.0, 0.3),
    (-2, 0, 1, 0, 0, -158.0, 0.0, 0.0, 0.0),
    (-2, 0, 0, 2, 1, 129.0, 0.1, -70.0, 0.0),
    (0, 0, -1, 2, 2, 123.0, 0.0, -53.0, 0.0),
    (2, 0, 0, 0, 0, 63.0, 0.0, 0.0, 0.0),
    (0, 0, 1, 0, 1, 63.0, 0.1, -33.0, 0.0),
    (2, 0, -1, 2, 2, -59.0, 0.0, 26.0, 0.0),
    (0, 0, -1, 0, 1, -58.0, -0.1, 32.0, 0.0),
    (0, 0, 1, 2, 1, -51.0, 0.0, 27.0, 0.0),
    (-2, 0, 2, 0, 0, 48.0, 0.0, 0.0, 0.0),
    (0, 0, -2, 2, 1, 46.0, 0.0, -24.0, 0.0),
    (2, 0, 0, 2, 2, -38.0, 0.0, 16.0, 0.0),
    (0, 0, 2, 2, 2, -31.0, 0.0, 13.0, 0.0),
    (0, 0, 2, 0, 0, 29.0, 0.0, 0.0, 0.0),
    (-2, 0, 1, 2, 2, 29.0, 0.0, -12.0, 0.0),
    (0, 0, 0, 2, 0, 26.0, 0.0, 0.0, 0.0),
    (-2, 0, 0, 2, 0, -22.0, 0.0, 0.0, 0.0),
    (0, 0, -1, 2, 1, 21.0, 0.0, -10.0, 0.0),
    (0, 2, 0, 0, 0, 17.0, -0.1, 0.0, 0.0),
    (2, 0, -1, 0, 1, 16.0, 0.0, -8.0, 0.0),
    (-2, 2, 0, 2, 2, -16.0, 0.1, 7.0, 0.0),
    (0, 1, 0, 0, 1, -15.0, 0.0, 9.0, 0.0),
    (-2, 0, 1, 0, 1, -13.0, 0.0, 7.0, 0.0),
    (0, -1, 0, 0, 1, -12.0, 0.0, 6.0, 0.0),
    (0, 0, 2, -2, 0, 11.0, 0.0, 0.0, 0.0),
])
# the Delaunay arguments' polynomials in degrees (IAU 1980; Meeus ch. 22): D, M, M', F, Omega
FUNDAMENTAL_ARGUMENTS = np.array([
    (297.85036, 445267.111480, -0.0019142, 1.0 / 189474.0),
    (357.52772, 35999.050340, -0.0001603, -1.0 / 300000.0),
    (134.96298, 477198.867398, 0.0086972, 1.0 / 56250.0),
    (93.27191, 483202.017538, -0.0036825, 1.0 / 327270.0),
    (125.04452, -1934.136261, 0.0020708, 1.0 / 450000.0),
])

# Kepler's equation (see kepler_eccentric_anomaly)
KEPLER_ITERATIONS = 50
KEPLER_TOLERANCE = float(np.finfo(float).eps)
# 2 pi in two parts (Cody and Waite): HI has 24 bits, so k * HI is exact for |k| < 2^29
TWO_PI_HI = float(np.float32(2.0 * math.pi))
TWO_PI_LO = (2.0 * math.pi - TWO_PI_HI) + 2.4492935982947064e-16
# 1 - pi^2/20: (E - sin E) >= E^3/6 (1 - E^2/20) >= E^3/6 * CUBIC_BOUND on [0, pi]
CUBIC_BOUND = 1.0 - math.pi ** 2 / 20.0
# E - sin E for E < 1: E^3 (1/3! - E^2/5! + ...), to E^17/17! (the next term is below eps)
E_MINUS_SIN_SERIES = np.array([
    (-1.0) ** k / math.factorial(2 * k + 3) for k in range(8)
])

# a Keplerian orbit's kernel row (KeplerOrbit.kernel_row): semi-major axis (m), eccentricity,
# mean motion (rad/s, with J2's secular part), mean anomaly at the epoch (rad), the node and the
# argument of perigee at the epoch (rad) and their rates (rad/s), cos and sin of the inclination,
# GM (m^3/s^2), then the perifocal axes P and Q at the epoch (used while both rates are 0)
A, ECC, MEAN_MOTION, MEAN_ANOMALY, RAAN, RAAN_RATE, ARGP, ARGP_RATE, COS_I, SIN_I, GM = range(11)
PX, PY, PZ, QX, QY, QZ = range(11, 17)
ORBIT_WIDTH = 17

ARCSECOND = math.pi / (180.0 * 3600.0)
SECONDS_PER_DAY = 86400.0
SECONDS_PER_CENTURY = 86400.0 * 36525.0


def kernel(name: str):
    """Return the compiled kernel ``name`` (compiling the family on the first call)."""
    if not _FAMILY.compiled:  # set once every kernel is compiled: no lock a call after that
        compile_kernels()
    return globals()[name]


# ---------------------------------------------------------------------------------------------
# The orbit


def e_minus_sin(e_anomaly, sin_e):
    """Return ``E - sin E`` for ``E >= 0`` without cancellation (the series below 1)."""
    if e_anomaly >= 1.0:
        return e_anomaly - sin_e
    x = e_anomaly * e_anomaly
    total = 0.0
    for k in range(E_MINUS_SIN_SERIES.shape[0] - 1, -1, -1):
        total = total * x + E_MINUS_SIN_SERIES[k]
    return total * x * e_anomaly


def kepler_eccentric_anomaly(mean_anomaly, e):
    """
    Return ``(E, sin(E/2), cos(E/2), k)``: ``E - e sin E = M - 2 pi k``, ``E`` in ``[-pi, pi]``.

    For ``0 <= e < 1``.
    ``M`` is reduced to ``[-pi, pi]`` (2 pi in two parts); by symmetry the solver works on
    ``m = |M|`` in ``[0, pi]``, where ``f(E) = E - e sin E - m`` increases and is convex, so
    Newton's method started at or above the root decreases to it without overshoot. The start is
    the least of three upper bounds: ``m + e``, ``pi``, and the root of the cubic ``(1 - e) E +
    e CUBIC_BOUND E^3 / 6 = m`` (below ``E - e sin E`` on ``[0, pi]``): the cubic tracks the root
    where ``e -> 1`` and ``m -> 0`` (there ``E ~ (6 m)^(1/3)``). ``f`` is evaluated as ``(E - sin
    E) + (1 - e) sin E - m`` and ``f'`` as ``(1 - e) + 2 e sin^2(E/2)``, so neither cancels near
    ``e = 1``, ``E = 0``. The iteration stops when Newton's next correction (``e sin E / (2 f')
    step^2``) is below an ulp of ``E``: the residual is then at float64's floor
    (test/test_orbit.py); the half angle's sine and cosine, which the state needs, come with it.
    """
    k = math.floor(mean_anomaly / (TWO_PI_HI + TWO_PI_LO) + 0.5)
    reduced = (mean_anomaly - k * TWO_PI_HI) - k * TWO_PI_LO
    m = abs(reduced)
    e_anomaly = min(m + e, math.pi)
    if e > 0.5:
        # the cubic a E^3 + b E = m, a = e C / 6, b = 1 - e: Cardano's root in the form
        # 2q / (w^2 + p + p^2/w^2), w^3 = q + sqrt(q^2 + p^3), which cannot cancel
        a = e * CUBIC_BOUND / 6.0
        p = (1.0 - e) / (3.0 * a)
        q = m / (2.0 * a)
        w2 = (q + math.sqrt(q * q + p * p * p)) ** (2.0 / 3.0)
        if w2 > 0.0:
            e_anomaly = min(e_anomaly, 2.0 * q / (w2 + p + p * p / w2))
    sh = math.sin(0.5 * e_anomaly)
    ch = math.cos(0.5 * e_anomaly)
    for _ in range(KEPLER_ITERATIONS):
        sin_e = 2.0 * sh * ch
        slope = (1.0 - e) + 2.0 * e * sh * sh
        step = ((e_minus_sin(e_anomaly, sin_e) + (1.0 - e) * sin_e) - m) / slope
        e_anomaly = e_anomaly - step
        # Newton's next correction is about e sin(E) / (2 f') step^2: below an ulp of E, stop;
        # then step^2 <= eps E also makes the first-order half-angle update below exact to
        # rounding (its error is step^2 / 8)
        if step * step * max(1.0, e * abs(sin_e) / (2.0 * slope)) <= KEPLER_TOLERANCE * e_anomaly:
            sh, ch = sh - 0.5 * step * ch, ch + 0.5 * step * sh
            break
        sh = math.sin(0.5 * e_anomaly)
        ch = math.cos(0.5 * e_anomaly)
    if reduced < 0.0:
        return -e_anomaly, -sh, ch, k
    return e_anomaly, sh, ch, k


def perifocal_axes(node, perigee, cos_i, sin_i):
    """
    Return the perifocal axes ``P`` (to perigee) and ``Q`` in the inertial frame, 6 numbers.

    The first two columns of ``R3(-node) R1(-i) R3(-perigee)`` (Vallado 2013, algorithm 10,
    COE2RV): :func:`.orbit.perifocal_axes`.
    """
    cos_node, sin_node = math.cos(node), math.sin(node)
    cos_perigee, sin_perigee = math.cos(perigee), math.sin(perigee)
    return (
        cos_node * cos_perigee - sin_node * sin_perigee * cos_i,
        sin_node * cos_perigee + cos_node * sin_perigee * cos_i,
        sin_perigee * sin_i,
        -cos_node * sin_perigee - sin_node * cos_perigee * cos_i,
        -sin_node * sin_perigee + cos_node * cos_perigee * cos_i,
        cos_perigee * sin_i,
    )


def kepler_state(t, row, out):
    """
    Write the position (m) and velocity (m/s) at ``t`` s after the epoch into ``out[0:6]``.

    Two-body motion on the orbit ``row`` (:data:`ORBIT_WIDTH`), whose node and perigee drift at
    the row's rates (0 without J2): :meth:`.orbit.KeplerOrbit.state`, operation for operation.
    """
    a = row[A]
    e = row[ECC]
    _, sh, ch, _ = kepler_eccentric_anomaly(row[MEAN_ANOMALY] + row[MEAN_MOTION] * t, e)
    sin_e = 2.0 * sh * ch
    one_minus_cos = 2.0 * sh * sh
    beta = math.sqrt((1.0 - e) * (1.0 + e))
    radius = a * ((1.0 - e) + e * one_minus_cos)
    x = a * ((1.0 - e) - one_minus_cos)
    y = a * beta * sin_e
    speed = math.sqrt(row[GM] * a) / radius
    vx = -speed * sin_e
    vy = speed * beta * (1.0 - one_minus_cos)
    if row[RAAN_RATE] == 0.0 and row[ARGP_RATE] == 0.0:
        px, py, pz, qx, qy, qz = row[PX], row[PY], row[PZ], row[QX], row[QY], row[QZ]
    else:
        px, py, pz, qx, qy, qz = perifocal_axes(
            row[RAAN] + row[RAAN_RATE] * t, row[ARGP] + row[ARGP_RATE] * t, row[COS_I], row[SIN_I]
        )
    out[0] = x * px + y * qx
    out[1] = x * py + y * qy
    out[2] = x * pz + y * qz
    out[3] = vx * px + vy * qx
    out[4] = vx * py + vy * qy
    out[5] = vx * pz + vy * qz


def kepler_states(times, row, out):
    """Write :func:`kepler_state` at each of ``times`` into the rows of ``out`` ``(N, 6)``."""
    for i in range(times.shape[0]):
        kepler_state(times[i], row, out[i])


# ---------------------------------------------------------------------------------------------
# Time and the Earth's orientation


def year_start_days(year):
    """Return the days from 2000-01-01 to January 1 of ``year`` (:mod:`.epochs`' own)."""
    before = year - 1
    return (
        365 * (year - 2000)
        + (before // 4 - 1999 // 4)
        - (before // 100 - 1999 // 100)
        + (before // 400 - 1999 // 400)
    )


def decimal_year(seconds):
    """Return the decimal year at the UTC instant ``seconds``: :func:`.epochs.decimal_year`."""
    days = int(math.floor((seconds + 43200.0) / SECONDS_PER_DAY))
    year = 2000 + int(math.floor(days / 365.2425))
    if year_start_days(year) > days:
        year -= 1
    if year_start_days(year + 1) <= days:
        year += 1
    start = year_start_days(year)
    length = year_start_days(year + 1) - start
    elapsed = seconds + 43200.0 - start * SECONDS_PER_DAY
    return year + elapsed / (length * SECONDS_PER_DAY)


def _rotate(axis, angle, matrix, work):
    """Set ``matrix = R_axis(angle) @ matrix`` (passive rotation), ``work`` a 3x3 scratch."""
    c = math.cos(angle)
    s = math.sin(angle)
    i = (axis + 1) % 3
    j = (axis + 2) % 3
    for column in range(3):
        work[i, column] = c * matrix[i, column] + s * matrix[j, column]
        work[j, column] = -s * matrix[i, column] + c * matrix[j, column]
    for column in range(3):
        matrix[i, column] = work[i, column]
        matrix[j, column] = work[j, column]


def _precession_angles(t):
    """Return IAU 1976's ``zeta, theta, z`` (rad) at TT centuries ``t`` (:mod:`.earth`)."""
    zeta = ((0.017998 * t + 0.30188) * t + 2306.2181) * t * ARCSECOND
    theta = ((-0.041833 * t - 0.42665) * t + 2004.3109) * t * ARCSECOND
    z = ((0.018203 * t + 1.09468) * t + 2306.2181) * t * ARCSECOND
    return zeta, theta, z


def _nutation(t):
    """
    Return ``(dpsi, deps, eps_mean, omega)`` (rad) at TT centuries ``t``: :mod:`.earth`.

    Each term's ``exp(i arg)`` is a product of the five arguments' ``exp(i k a)``, ``|k| <= 2``
    (five sines and cosines, not one pair a term): the same sums as the numpy path's ``sin`` and
    ``cos`` of each argument, to rounding.
    """
    powers = np.empty((5, 5), dtype=np.complex128)
    omega = 0.0
    for j in range(5):
        c = FUNDAMENTAL_ARGUMENTS[j]
        degrees = ((c[3] * t + c[2]) * t + c[1]) * t + c[0]
        angle = math.radians(np.fmod(degrees, 360.0))
        one = complex(math.cos(angle), math.sin(angle))
        two = one * one
        powers[j, 0] = two.conjugate()
        powers[j, 1] = one.conjugate()
        powers[j, 2] = 1.0
        powers[j, 3] = one
        powers[j, 4] = two
        omega = angle
    dpsi = 0.0
    deps = 0.0
    for row in range(NUTATION_TERMS.shape[0]):
        term = NUTATION_TERMS[row]
        phase = complex(1.0, 0.0)
        for j in range(5):
            if term[j] != 0.0:
                phase = phase * powers[j, int(term[j]) + 2]
        dpsi += (term[5] + term[6] * t) * phase.imag
        deps += (term[7] + term[8] * t) * phase.real
    eps_mean = _mean_obliquity(t)
    return dpsi * 1e-4 * ARCSECOND, deps * 1e-4 * ARCSECOND, eps_mean, omega


def _gmst(seconds):
    """Return GMST 1982 (rad, in ``[0, 2 pi)``), UT1 = UTC: :func:`.earth.gmst`."""
    t = seconds / SECONDS_PER_CENTURY
    day_seconds = np.fmod(seconds, SECONDS_PER_DAY)
    angle = (((-6.2e-6 * t + 0.093104) * t + 8640184.812866) * t + (24110.54841 - 43200.0)
             + day_seconds) * (2.0 * math.pi / SECONDS_PER_DAY)
    angle = np.fmod(angle, 2.0 * math.pi)
    return angle + 2.0 * math.pi if angle < 0.0 else angle


def _identity(matrix):
    for i in range(3):
        for j in range(3):
            matrix[i, j] = 1.0 if i == j else 0.0


def celestial_matrix(seconds, out):
    """
    Write ``N P`` (EME2000 -> true of date) into ``out``; return the equation of the equinoxes.

    At the UTC instant ``seconds``: :func:`.earth.nutation_matrix` ``@``
    :func:`.earth.precession_matrix` and :func:`.earth.equation_of_equinoxes`. Both drift by at
    most ~5e-6 arcsec/s (precession 1.6e-6, nutation's fastest terms ~3e-6), so an integrator may
    hold them over a sample interval (0.02 arcsec an hour held) and turn the Earth per stage by
    :func:`earth_fixed_matrix_held`.
    """
    t = (seconds + TT_MINUS_UTC) / SECONDS_PER_CENTURY
    zeta, theta, z = _precession_angles(t)
    dpsi, deps, eps_mean, omega = _nutation(t)
    work = np.empty((3, 3))
    _identity(out)
    _rotate(2, -zeta, out, work)
    _rotate(1, theta, out, work)
    _rotate(2, -z, out, work)
    _rotate(0, eps_mean, out, work)
    _rotate(2, -dpsi, out, work)
    _rotate(0, -(eps_mean + deps), out, work)
    kinematic = (0.00264 * math.sin(omega) + 0.000063 * math.sin(2.0 * omega)) * ARCSECOND
    return dpsi * math.cos(eps_mean) + kinematic


def earth_fixed_matrix_held(seconds, celestial, equation_of_equinoxes, out):
    """
    Write ``R3(GMST(seconds) + Eq_eq) celestial`` into ``out``: ``W`` with ``N P`` held.

    ``celestial`` and ``equation_of_equinoxes`` from :func:`celestial_matrix` at a nearby instant;
    the Earth's rotation itself (GMST) is evaluated at ``seconds``.
    """
    angle = _gmst(seconds) + equation_of_equinoxes
    c = math.cos(angle)
    s = math.sin(angle)
    for column in range(3):
        out[0, column] = c * celestial[0, column] + s * celestial[1, column]
        out[1, column] = -s * celestial[0, column] + c * celestial[1, column]
        out[2, column] = celestial[2, column]


def earth_fixed_matrix(seconds, out):
    """Write ``W = R3(GAST) N P`` (``r_EF = W r_N``) at the UTC instant ``seconds``."""
    celestial = np.empty((3, 3))
    equation_of_equinoxes = celestial_matrix(seconds, celestial)
    earth_fixed_matrix_held(seconds, celestial, equation_of_equinoxes, out)


def earth_fixed_matrices(seconds, out):
    """Write :func:`earth_fixed_matrix` at each of the UTC ``seconds`` into ``out[i]``."""
    for i in range(seconds.shape[0]):
        earth_fixed_matrix(seconds[i], out[i])


# ---------------------------------------------------------------------------------------------
# The magnetic field


def igrf_earth_fixed(x, y, z, year, table, out):
    """
    Write IGRF's field (tesla) at the Earth-fixed point ``(x, y, z)`` (m) in ``year`` into ``out``.

    ``table``: :func:`.magnetic.kernel_table` (the coefficients unnormalised, by epoch). The
    solid harmonics by Cunningham's recursions and the field as their gradient (Montenbruck and
    Gill, *Satellite Orbits*, 2000, section 3.2, with the magnetic potential ``a sum(C V + S
    W)``): Cartesian throughout, so the poles are ordinary points.
    :func:`.magnetic.igrf_earth_fixed` operation for operation. A year outside the table gives NaN.
    """
    epochs = table.shape[0]
    last = IGRF_FIRST_EPOCH + IGRF_EPOCH_STEP * (epochs - 1)
    if not (IGRF_FIRST_EPOCH <= year <= last):
        out[0] = out[1] = out[2] = math.nan
        return
    k = min(int((year - IGRF_FIRST_EPOCH) / IGRF_EPOCH_STEP), epochs - 2)
    fraction = (year - (IGRF_FIRST_EPOCH + IGRF_EPOCH_STEP * k)) / IGRF_EPOCH_STEP
    size = IGRF_DEGREE + 2
    v = np.empty((size, size))
    w = np.empty((size, size))
    r2 = x * x + y * y + z * z
    scale = IGRF_RADIUS / r2
    xs = x * scale
    ys = y * scale
    zs = z * scale
    rho = IGRF_RADIUS * scale
    v[0, 0] = IGRF_RADIUS / math.sqrt(r2)
    w[0, 0] = 0.0
    for m in range(size):
        if m > 0:
            v[m, m] = (2 * m - 1) * (xs * v[m - 1, m - 1] - ys * w[m - 1, m - 1])
            w[m, m] = (2 * m - 1) * (xs * w[m - 1, m - 1] + ys * v[m - 1, m - 1])
        if m + 1 < size:
            v[m + 1, m] = (2 * m + 1) * zs * v[m, m]
            w[m + 1, m] = (2 * m + 1) * zs * w[m, m]
        for n in range(m + 2, size):
            v[n, m] = RECURSION_A[n, m] * zs * v[n - 1, m] - RECURSION_B[n, m] * rho * v[n - 2, m]
            w[n, m] = RECURSION_A[n, m] * zs * w[n - 1, m] - RECURSION_B[n, m] * rho * w[n - 2, m]
    gx = 0.0
    gy = 0.0
    gz = 0.0
    for n in range(1, IGRF_DEGREE + 1):
        c = table[k, 0, n, 0] + fraction * (table[k + 1, 0, n, 0] - table[k, 0, n, 0])
        gx -= c * v[n + 1, 1]
        gy -= c * w[n + 1, 1]
        gz -= (n + 1) * c * v[n + 1, 0]
        for m in range(1, n + 1):
            c = table[k, 0, n, m] + fraction * (table[k + 1, 0, n, m] - table[k, 0, n, m])
            s = table[k, 1, n, m] + fraction * (table[k + 1, 1, n, m] - table[k, 1, n, m])
            factor = (n - m + 1) * (n - m + 2)
            gx += 0.5 * ((-c * v[n + 1, m + 1] - s * w[n + 1, m + 1])
                         + factor * (c * v[n + 1, m - 1] + s * w[n + 1, m - 1]))
            gy += 0.5 * ((-c * w[n + 1, m + 1] + s * v[n + 1, m + 1])
                         + factor * (-c * w[n + 1, m - 1] + s * v[n + 1, m - 1]))
            gz += (n - m + 1) * (-c * v[n + 1, m] - s * w[n + 1, m])
    # B = -grad(potential); the coefficients are nT
    out[0] = -gx * 1e-9
    out[1] = -gy * 1e-9
    out[2] = -gz * 1e-9


def dipole_earth_fixed(x, y, z, year, table, out):
    """
    Write the tilted dipole's field (tesla) at ``(x, y, z)`` (m, Earth-fixed) into ``out``.

    IGRF's degree 1 alone: ``B = (a/r)^3 (3 (g.r^) r^ - g)``, ``g = (g11, h11, g10)``:
    :func:`.magnetic.dipole_earth_fixed`. A year outside the table gives NaN.
    """
    epochs = table.shape[0]
    last = IGRF_FIRST_EPOCH + IGRF_EPOCH_STEP * (epochs - 1)
    if not (IGRF_FIRST_EPOCH <= year <= last):
        out[0] = out[1] = out[2] = math.nan
        return
    k = min(int((year - IGRF_FIRST_EPOCH) / IGRF_EPOCH_STEP), epochs - 2)
    fraction = (year - (IGRF_FIRST_EPOCH + IGRF_EPOCH_STEP * k)) / IGRF_EPOCH_STEP
    gx = table[k, 0, 1, 1] + fraction * (table[k + 1, 0, 1, 1] - table[k, 0, 1, 1])
    gy = table[k, 1, 1, 1] + fraction * (table[k + 1, 1, 1, 1] - table[k, 1, 1, 1])
    gz = table[k, 0, 1, 0] + fraction * (table[k + 1, 0, 1, 0] - table[k, 0, 1, 0])
    r = math.sqrt(x * x + y * y + z * z)
    ux = x / r
    uy = y / r
    uz = z / r
    ratio = IGRF_RADIUS / r
    scale = ratio * ratio * ratio * 1e-9
    along = 3.0 * (gx * ux + gy * uy + gz * uz)
    out[0] = scale * (along * ux - gx)
    out[1] = scale * (along * uy - gy)
    out[2] = scale * (along * uz - gz)


def field_inertial_with(model, position, matrix, year, table, out):
    """
    Write the field (T, inertial) at the inertial ``position`` given ``W`` (``matrix``).

    ``model`` 0: IGRF, 1: the tilted dipole; ``matrix`` from :func:`earth_fixed_matrix` or
    :func:`earth_fixed_matrix_held`, ``year`` from :func:`decimal_year` (it may be held too: the
    field changes ~100 nT a year at most, 3e-6 nT a second).
    """
    fixed = np.empty(3)
    for i in range(3):
        fixed[i] = (matrix[i, 0] * position[0] + matrix[i, 1] * position[1]
                    + matrix[i, 2] * position[2])
    field = np.empty(3)
    if model == 0:
        igrf_earth_fixed(fixed[0], fixed[1], fixed[2], year, table, field)
    else:
        dipole_earth_fixed(fixed[0], fixed[1], fixed[2], year, table, field)
    for i in range(3):
        out[i] = matrix[0, i] * field[0] + matrix[1, i] * field[1] + matrix[2, i] * field[2]


def igrf_inertial(position, seconds, table, out):
    """Write IGRF's field (T, inertial) at the inertial ``position`` (m) and UTC ``seconds``."""
    matrix = np.empty((3, 3))
    earth_fixed_matrix(seconds, matrix)
    field_inertial_with(0, position, matrix, decimal_year(seconds), table, out)


def dipole_inertial(position, seconds, table, out):
    """Write the tilted dipole's field (T, inertial) at the inertial ``position`` (m)."""
    matrix = np.empty((3, 3))
    earth_fixed_matrix(seconds, matrix)
    field_inertial_with(1, position, matrix, decimal_year(seconds), table, out)


def fields_inertial(model, positions, seconds, table, out):
    """
    Write the field (T, inertial) of ``model`` (0: IGRF, 1: the dipole) at each instant.

    Row ``i`` of ``out`` at ``positions[i]`` (m, inertial) and UTC ``seconds[i]``: the samples of a
    sensor, each by itself (:func:`igrf_inertial`, :func:`dipole_inertial`), so a row does not
    depend on the others.
    """
    matrix = np.empty((3, 3))
    for i in range(seconds.shape[0]):
        earth_fixed_matrix(seconds[i], matrix)
        field_inertial_with(model, positions[i], matrix, decimal_year(seconds[i]), table, out[i])


def environment_one(model, orbit_t, seconds, row, table, out):
    """
    Write the position (m) into ``out[0]`` and the field (T) into ``out[1]`` at one instant.

    Both inertial: the Keplerian orbit ``row`` at ``orbit_t`` s after its epoch, and the field of
    ``model`` (0: IGRF, 1: the dipole) there at the UTC instant ``seconds``. One call for a
    sensor's sample in a closed loop: :func:`kepler_state` then :func:`fields_inertial`'s row,
    the same operations, so the same floats as the two of them.
    """
    state = np.empty(6)
    kepler_state(orbit_t, row, state)
    for i in range(3):
        out[0, i] = state[i]
    matrix = np.empty((3, 3))
    earth_fixed_matrix(seconds, matrix)
    field_inertial_with(model, state, matrix, decimal_year(seconds), table, out[1])


def environments(model, orbit_ts, seconds, row, table, out):
    """Write :func:`environment_one` at each instant into ``out[i]`` (``(N, 2, 3)``)."""
    for i in range(seconds.shape[0]):
        environment_one(model, orbit_ts[i], seconds[i], row, table, out[i])


# ---------------------------------------------------------------------------------------------
# The Sun and the shadow


def _mean_obliquity(t):
    """Return the IAU 1980 mean obliquity (rad) at TT centuries ``t`` (:mod:`.earth`)."""
    return (((0.001813 * t - 0.00059) * t - 46.8150) * t + 84381.448) * ARCSECOND


def sun_position(seconds, out):
    """Write the Sun's geocentric position (m, inertial) at the UTC ``seconds`` (:mod:`.sun`)."""
    t = (seconds + TT_MINUS_UTC) / SECONDS_PER_CENTURY
    mean_longitude = np.fmod((0.0003032 * t + 36000.76983) * t + 280.46646, 360.0)
    anomaly = math.radians(np.fmod((-0.0001537 * t + 35999.05029) * t + 357.52911, 360.0))
    e = (-0.0000001267 * t - 0.000042037) * t + 0.016708634
    centre = (((-0.000014 * t - 0.004817) * t + 1.914602) * math.sin(anomaly)
              + (-0.000101 * t + 0.019993) * math.sin(2.0 * anomaly)
              + 0.000289 * math.sin(3.0 * anomaly))
    longitude = math.radians(mean_longitude + centre - ABERRATION_DEGREES)
    distance = 1.000001018 * (1.0 - e * e) / (1.0 + e * math.cos(anomaly + math.radians(centre))) \
        * ASTRONOMICAL_UNIT
    obliquity = _mean_obliquity(t)
    # mean equator and equinox of date, then back to EME2000 by precession's transpose
    date = np.empty(3)
    date[0] = distance * math.cos(longitude)
    date[1] = distance * math.cos(obliquity) * math.sin(longitude)
    date[2] = distance * math.sin(obliquity) * math.sin(longitude)
    zeta, theta, z = _precession_angles(t)
    matrix = np.empty((3, 3))
    work = np.empty((3, 3))
    _identity(matrix)
    _rotate(2, -zeta, matrix, work)
    _rotate(1, theta, matrix, work)
    _rotate(2, -z, matrix, work)
    for i in range(3):
        out[i] = matrix[0, i] * date[0] + matrix[1, i] * date[1] + matrix[2, i] * date[2]


def shadow_fraction(position, sun):
    """
    Return the Sun's fraction hidden by the Earth at ``position`` (m), the Sun at ``sun`` (m).

    0 lit, 1 umbra: :func:`.sun.shadow_fraction` (Montenbruck and Gill, section 3.4), one point.
    """
    r = math.sqrt(position[0] ** 2 + position[1] ** 2 + position[2] ** 2)
    if r <= EQUATORIAL_RADIUS:
        return 1.0
    dx = sun[0] - position[0]
    dy = sun[1] - position[1]
    dz = sun[2] - position[2]
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    a = math.asin(SUN_RADIUS / d)
    b = math.asin(EQUATORIAL_RADIUS / r)
    # the angle between the Earth's centre (-position) and the Sun, as seen from the point
    cx = -position[1] * dz + position[2] * dy
    cy = -position[2] * dx + position[0] * dz
    cz = -position[0] * dy + position[1] * dx
    c = math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz),
                   -(position[0] * dx + position[1] * dy + position[2] * dz))
    if c >= a + b:
        return 0.0
    if c <= b - a:
        return 1.0
    if c <= a - b:
        return (b * b) / (a * a)
    # the lens where the discs overlap, as two circular segments of half-angles phi_a, phi_b
    # about the common chord of half-length y (Heron's product: no cancellation near a contact),
    # each segment r^2 (phi - sin phi cos phi) = r^2 (u - sin u) / 2, u = 2 phi (the series for
    # small u): the hidden fraction stays positive and accurate up to the contacts
    y = math.sqrt((a + b - c) * (a - b + c) * (b + c - a) * (a + b + c)) / (2.0 * c)
    phi_a = math.atan2(y, (c * c + a * a - b * b) / (2.0 * c))
    phi_b = math.atan2(y, (c * c - a * a + b * b) / (2.0 * c))
    area = 0.5 * (a * a * e_minus_sin(2.0 * phi_a, math.sin(2.0 * phi_a))
                  + b * b * e_minus_sin(2.0 * phi_b, math.sin(2.0 * phi_b)))
    return min(area / (math.pi * a * a), 1.0)


# ---------------------------------------------------------------------------------------------

_FAMILY = KernelFamily(
    globals(),
    (
        'e_minus_sin',
        'kepler_eccentric_anomaly',
        'perifocal_axes',
        'kepler_state',
        'kepler_states',
        'year_start_days',
        'decimal_year',
        '_rotate',
        '_precession_angles',
        '_mean_obliquity',
        '_nutation',
        '_gmst',
        '_identity',
        'celestial_matrix',
        'earth_fixed_matrix_held',
        'earth_fixed_matrix',
        'earth_fixed_matrices',
        'igrf_earth_fixed',
        'dipole_earth_fixed',
        'field_inertial_with',
        'igrf_inertial',
        'dipole_inertial',
        'fields_inertial',
        'environment_one',
        'environments',
        'sun_position',
        'shadow_fraction',
    ),
)
compile_kernels = _FAMILY.load
