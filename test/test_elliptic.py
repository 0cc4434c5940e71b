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
Jacobi functions, amplitude and the integral ``S`` against mpmath at 60 digits.

More digits where ``mc`` is so small that ``m = 1 - mc`` needs them.

Tolerance, per value ``f`` at argument ``u``: ``|error| <= 8 eps (|f| + |u| |f'|)``. The first term
is a few rounding units of the value; the second is what rounding ``u`` (and the period it is
reduced by) can move it, since every ``u`` carries a relative error ``~eps`` before any function is
evaluated. (The reference itself is good to ~1e-60 absolute, allowed for where a value is 0.) Next
to the separatrix this demands ``cn`` and ``dn`` to relative precision at the turning points, where
they are as small as ``k' = sqrt(mc)``.
"""

from hypothesis import given, settings
from hypothesis import strategies as st
import mpmath as mp
import numpy as np
import pytest
from torquefree_ros.core.exact.elliptic import JacobiElliptic

EPS = np.finfo(float).eps
TOLERANCE_FACTOR = 8.0
REFERENCE_ABSOLUTE_ERROR = 1e-55
# mc: from a circle (1) through both sides of the switch between trigonometric and hyperbolic theta
# series (1/2) to the separatrix (0)
PARAMETERS = (
    1.0,
    0.9,
    0.5 + 1e-12,
    0.5,
    0.5 - 1e-12,
    0.3,
    1e-2,
    1e-4,
    1e-8,
    1e-16,
    1e-30,
    1e-100,
    0.0,
)
CHARACTERISTICS = (0.0, -0.3, -40.0, -2e12)  # n; -2e12 is the thin rod's (1 : 1e6)
# arguments as multiples of the quarter period K (the separatrix, K infinite, uses plain arguments)
QUARTER_PERIOD_MULTIPLES = (
    0.0,
    1e-9,
    0.3,
    0.5 - 1e-7,
    0.5,
    0.5 + 1e-7,
    0.9,
    1.0 - 1e-9,
    1.0,
    1.37,
    2.0,
    3.71,
    -0.2,
    -2.6,
    9.5,
    12345.6,
)
SEPARATRIX_ARGUMENTS = (0.0, 1e-9, 0.1, 1.0, 5.0, 20.0, 40.0, -3.0, -35.0)


def reference(u: float, mc: float, n: float) -> dict[str, tuple[float, float]]:
    """``name -> (value, derivative in u)`` at the float ``u``, in 60-digit arithmetic."""
    with mp.workdps(60 + max(0, int(-mp.log10(mc))) if mc > 0.0 else 60):
        u_mp, m = mp.mpf(u), 1 - mp.mpf(mc)
        sn, cn, dn = (mp.ellipfun(kind, u_mp, m=m) for kind in ('sn', 'cn', 'dn'))
        if mc == 0.0:
            am = mp.asin(mp.tanh(u_mp))  # the Gudermannian
        else:
            K = mp.ellipk(m)
            half_periods = mp.nint(u_mp / (2 * K))
            reduced = u_mp - 2 * K * half_periods  # in [-K, K], where cn >= 0
            am = (
                mp.atan2(mp.ellipfun('sn', reduced, m=m), mp.ellipfun('cn', reduced, m=m))
                + mp.pi * half_periods
            )
        if n == 0.0 and m == 0:
            S = (u_mp - mp.sin(u_mp) * mp.cos(u_mp)) / 2  # sn = sin
        elif n == 0.0:
            S = (u_mp - mp.ellipe(am, m)) / m
        else:
            S = (mp.ellippi(n, am, m) - u_mp) / n
        values = {
            'sn': (sn, cn * dn),
            'cn': (cn, -sn * dn),
            'dn': (dn, -m * sn * cn),
            'am': (am, dn),
            'sn2_integral': (S, sn**2 / (1 - n * sn**2)),
        }
        return {
            name: (float(value), float(derivative)) for name, (value, derivative) in values.items()
        }


def arguments(jacobi: JacobiElliptic) -> np.ndarray:
    if jacobi.mc == 0.0:
        return np.array(SEPARATRIX_ARGUMENTS)
    return np.array(QUARTER_PERIOD_MULTIPLES) * jacobi.quarter_period


@pytest.mark.parametrize('n', CHARACTERISTICS)
@pytest.mark.parametrize('mc', PARAMETERS)
def test_values_match_mpmath_to_their_condition(mc, n):
    jacobi = JacobiElliptic(mc, n)
    u = arguments(jacobi)
    values = jacobi(u)
    for i, ui in enumerate(u):
        for name, (expected, derivative) in reference(float(ui), mc, n).items():
            got = float(getattr(values, name)[i])
            tolerance = (
                TOLERANCE_FACTOR * EPS * (abs(expected) + abs(ui) * abs(derivative))
                + REFERENCE_ABSOLUTE_ERROR
            )
            assert abs(got - expected) <= tolerance, (
                f'{name}(u={ui!r} | mc={mc}, n={n}) = {got!r}, expected {expected!r} '
                f'(error {abs(got - expected):.2e} > {tolerance:.2e})'
            )


@pytest.mark.parametrize('mc', [value for value in PARAMETERS if value > 0.0])
def test_values_at_any_argument_do_not_depend_on_the_batch(mc):
    """Each sample is computed independently of the others requested with it (bit for bit)."""
    jacobi = JacobiElliptic(mc, -0.3)
    u = arguments(jacobi)
    together = jacobi(u)
    for i, ui in enumerate(u):
        alone = jacobi(np.array([ui]))
        for name in ('sn', 'cn', 'dn', 'am', 'sn2_integral'):
            assert getattr(alone, name)[0] == getattr(together, name)[i], (name, ui)


@pytest.mark.parametrize('mc', [value for value in PARAMETERS if value > 0.0])
def test_incomplete_first_kind_inverts_the_functions_on_a_half_period(mc):
    jacobi = JacobiElliptic(mc)
    u = (
        np.array([-1.0, -0.5, -1e-6, 0.0, 0.25, 0.5, 0.75, 1.0 - 1e-9, 1.0])
        * jacobi.quarter_period
    )
    expected = [reference(float(ui), mc, 0.0) for ui in u]
    sn, cn, dn = (
        np.array([values[name][0] for values in expected]) for name in ('sn', 'cn', 'dn')
    )
    np.testing.assert_allclose(
        jacobi.incomplete_first_kind(sn, cn, dn),
        u,
        rtol=TOLERANCE_FACTOR * EPS,
        atol=TOLERANCE_FACTOR * EPS,
    )


def test_bad_parameters_are_refused_by_name():
    with pytest.raises(ValueError, match='mc: '):
        JacobiElliptic(1.5)
    with pytest.raises(ValueError, match='n: '):
        JacobiElliptic(0.5, 0.1)
    with pytest.raises(ValueError, match='m: '):
        JacobiElliptic(0.5, -0.1, m=-0.5)


@pytest.mark.parametrize('n', CHARACTERISTICS)
@pytest.mark.parametrize('mc', PARAMETERS)
def test_theta_phase_gives_n_S_to_its_condition(mc, n):
    """
    The attitude's form of ``S``, ``n S(u) = n slope u + weight phase``, is good to its condition.

    It is good to the size of the linear term (``n S`` is added to it there), which is what the
    tolerance adds to the one above; ``phase`` alone is periodic (``2K``).
    """
    jacobi = JacobiElliptic(mc, n)
    u = arguments(jacobi)
    values = jacobi(u, integral=False, phase=True)
    assert values.sn2_integral is None
    got = n * jacobi.sn2_integral_slope * u + jacobi.phase_weight * values.theta_phase
    shifted = (
        jacobi(u + 2.0 * jacobi.quarter_period, integral=False, phase=True).theta_phase
        if mc > 0.0
        else None
    )
    for i, ui in enumerate(u):
        S, derivative = reference(float(ui), mc, n)['sn2_integral']
        linear = abs(n * jacobi.sn2_integral_slope * ui)
        tolerance = (
            TOLERANCE_FACTOR * EPS * (abs(n * S) + linear + abs(ui) * abs(n * derivative))
            + abs(n) * 1e-50
        )
        assert abs(got[i] - n * S) <= tolerance, (
            f'n S(u={ui!r} | mc={mc}, n={n}) = {got[i]!r}, expected {n * S!r} '
            f'(error {abs(got[i] - n * S):.2e} > {tolerance:.2e})'
        )
        if shifted is not None and n < 0.0 and abs(ui) <= 4.0 * jacobi.quarter_period:
            # periodic in 2K, to the rounding of u + 2K times the phase's slope n (S' - slope) /
            # weight
            slope = abs(n * (derivative - jacobi.sn2_integral_slope)) / jacobi.phase_weight
            allowed = (
                TOLERANCE_FACTOR * EPS * (1.0 + abs(ui + 2.0 * jacobi.quarter_period) * slope)
            )
            assert abs(shifted[i] - values.theta_phase[i]) <= allowed, (
                ui,
                shifted[i],
                values.theta_phase[i],
            )


@settings(max_examples=300, deadline=None)
@given(
    log_mc=st.floats(-40.0, 0.0),
    log_minus_n=st.floats(-6.0, 13.0),
    quarters=st.floats(-40.0, 40.0),
)
def test_theta_phase_agrees_with_carlsons_integral_anywhere(log_mc, log_minus_n, quarters):
    """
    The attitude's form of ``n S`` agrees with ``S`` from Carlson's ``R_J`` anywhere.

    Between the grid above, for any parameter, characteristic and argument (Carlson's ``R_J`` is
    the other path, to relative precision). A cross-check of the two formulas over the whole space
    (a wrong term or branch is off by far more); the mpmath grid pins the last bits. Tolerance: 32
    eps of the sizes of the terms both forms add, the phase's with its own condition for small
    ``|n|`` (``q e^(2 beta) = exp(-pi b'/K)`` multiplies the rounding of ``b'`` by its exponent,
    about ``ln(4/|n|)``).
    """
    mc, n = 10.0**log_mc, -(10.0**log_minus_n)
    jacobi = JacobiElliptic(mc, n)
    u = np.array([quarters * jacobi.quarter_period])
    carlson = jacobi(u)
    theta = jacobi(u, integral=False, phase=True)
    with np.errstate(under='ignore'):  # tiny arguments: powers of them below the normal range
        linear, phase = n * jacobi.sn2_integral_slope * u, jacobi.phase_weight * theta.theta_phase
        sn2 = carlson.sn**2
        derivative = n * sn2 / (1.0 - n * sn2)
        sizes = (
            abs(n * carlson.sn2_integral)
            + abs(linear)
            + (1.0 + max(0.0, np.log(4.0 / abs(n)))) * abs(phase)
            + abs(u * derivative)
        )
        error = abs((linear + phase) - n * carlson.sn2_integral)
        np.testing.assert_array_less(error, 4 * TOLERANCE_FACTOR * EPS * sizes + 1e-300)


@settings(max_examples=300, deadline=None)
@given(mc=st.floats(0.5, 1.0), quarters=st.floats(-4e5, 4e5))
def test_whole_half_period_agrees_with_the_two_halves(mc, quarters):
    """
    The whole half-period path agrees with the two halves' for any parameter and argument.

    For ``m <= 1/2`` and no ``S`` the functions come from the trigonometric series on the whole
    half-period (cubics in ``sin^2 z``, no selection between halves); with ``S`` from the two
    halves of the quarter period (the path the mpmath grid above pins, ``S`` included). The two
    agree, reduced values and half-period counts too, for any parameter and argument. Tolerance: 8
    eps of each value plus what moving ``u`` by 8 of its rounding units moves it (the two paths
    reduce ``u`` differently).
    """
    jacobi = JacobiElliptic(mc, -1.0)
    with np.errstate(under='ignore'):  # tiny arguments
        u = quarters * jacobi.quarter_period + np.array([0.0, 1e-3, 0.5, 1.0])
        nearby = [jacobi(u * (1.0 + sign * 8.0 * EPS)) for sign in (1.0, -1.0)]
    whole, halves = jacobi(u, integral=False), jacobi(u)
    for name in ('sn', 'cn', 'dn', 'reduced_sn', 'reduced_cn'):
        got, expected = getattr(whole, name), getattr(halves, name)
        moved = np.maximum(*(np.abs(getattr(values, name) - expected) for values in nearby))
        allowed = TOLERANCE_FACTOR * EPS * (1.0 + np.abs(expected)) + moved
        assert np.all(np.abs(got - expected) <= allowed), (name, u, got, expected, allowed)
    # the counts may differ only where r = ±K, i.e. where cn is 0 to the rounding of u
    differ = whole.half_periods != halves.half_periods
    assert np.all(np.abs(whole.half_periods - halves.half_periods) <= 1.0)
    assert np.all(np.abs(halves.reduced_cn[differ]) <= 64.0 * EPS * (1.0 + np.abs(u[differ]))), (
        u,
        whole.half_periods,
        halves.half_periods,
    )
