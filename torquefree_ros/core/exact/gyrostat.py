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
The exact free gyrostat with its rotor along a principal axis (issue 43).

Rates by Jacobi elliptic functions, attitude by the rotation about the constant angular momentum.

The Zhukovsky-Volterra gyrostat ``I w' + w x (I w + h) = 0`` with ``h = h e3`` constant along a
principal axis (Volterra 1899; Cochran, Shu & Rew, "Attitude motion of asymmetric dual-spin
spacecraft", J. Guidance 5 (1982); Elipe & Lanchares, "Exact solution of a triaxial gyrostat with
one rotor", Celest. Mech. Dyn. Astr. 101 (2008); Wittenburg, *Dynamics of Multibody Systems*,
2nd ed., the gyrostat with an axial rotor). In a *solver frame* S, a proper signed permutation of
the principal axes whose axis 3 is the rotor's (moments ``J1, J2, J3``, ``a, b, c = 1/J1, 1/J2,
1/J3``), the total momentum ``m = J w + h e3`` keeps ``|m| = H`` and ``2T = w . J w``, and
``m' = m x w``. With ``z = m3``:

* ``(a - b) m1^2 = Q1(z) = (b - c) z^2 + 2 c h z + (2T - c h^2 - b H^2)`` and
  ``(b - a) m2^2 = Q2(z)``, the same with ``a``; ``z'^2 = -Q1(z) Q2(z) = F(z)``, a quartic whose
  roots are the two quadratics' (one at infinity where a ``Q`` is linear, ``J3 = J1`` or ``J2``);
* ``z`` oscillates between two adjacent real roots ``z_A``, ``z_B`` (the turning points, zeros of
  ``m1`` or ``m2``) bounding the interval where ``F > 0``; the other two roots set the modulus
  (Byrd & Friedman, *Handbook of Elliptic Integrals*, 252-259):

  - both real, ``e_m`` and ``e_inf`` following ``z_B`` around the projective line: with
    ``s = sn^2 u``, ``z = (z_A W0 cn^2 + z_B W1 sn^2) / (W0 cn^2 + W1 sn^2)``,
    ``W0 = z_B - e_inf``, ``W1 = z_A - e_inf`` (both 1 for a root at infinity), and
    ``mc = (e_m - z_B)(z_A - e_inf) / ((e_m - z_A)(z_B - e_inf))`` (one formula for the three
    orders of the roots);
  - complex, ``b1 ± i a1``: ``A^2 = (z_B - b1)^2 + a1^2``, ``B^2 = (z_A - b1)^2 + a1^2``,
    ``z = (z_A A (1 + cn) + z_B B (1 - cn)) / (A (1 + cn) + B (1 - cn))``,
    ``mc = ((A + B)^2 - (z_B - z_A)^2) / (4AB)``;

  ``u = lambda t + u0``. Each factor ``z - root`` is a constant times ``sn^2``, ``cn^2``, ``dn^2``
  or 1 over the same denominator, so ``m1`` and ``m2`` are a constant times a product of ``sn``,
  ``cn``, ``dn`` over it; every weighted form above sums terms of one sign.

The regimes: the equilibria on the sphere ``|m| = H`` are ``± H e3`` always and, while
``|h J_k / (J_k - J3)| < H``, two in the plane of ``e3`` and ``e_k`` at
``m3 = h J_k / (J_k - J3)``: they move with ``h`` and merge into ``± e3`` as ``h / H`` grows
(Elipe & Lanchares' bifurcations). A motion circles a transverse axis (both turning points zeros of
one transverse component: the other keeps its sign) or the rotor axis (one turning point of each).
Next to a separatrix two roots of ``F`` meet and ``mc -> 0``. The roots come from the quadratics in
80-digit decimal arithmetic on the exact binary inputs, so every difference of roots, hence ``mc``,
keeps its relative precision down to the separatrix without case-by-case rearrangement; the Jacobi
functions take ``mc`` (:mod:`.elliptic`). The regime is chosen once, here; evaluation is a pure
function of time.

Attitude: ``R_NA = P Rz(psi) Q(m_A)`` in a frame A fixed in the body whose axis 3 is a reference
axis ``e_ref``, ``Q(m)`` the shortest arc from ``m/|m|`` to ``e_z``, and
``psi' = (H w_ref + w . m) / (H + m_ref)`` (the Euler angle about H plus the turn of
``(m_1, m_2)``: their singularities cancel but at ``m = -H e_ref``). ``e_ref`` is the transverse
axis a motion circles, signed so that ``m_ref > 0`` (``H + m_ref >= H``), or ``± e3`` for a motion
about the rotor axis, the pole farther from the motion. With ``w . m = 2T + h w3``:

* ``e_ref = σ e3``: ``psi' = (2T + (h + σ H) w3) / (H + σ z)``;
* ``e_ref = σ e_r``: ``psi' = (2T + h w3 + (H/J_r) |m_r|) / (H + |m_r|)``;

evaluated as written: a constant split off, ``(H + σ h)/J3 + ν / (H + σ z)``, would cancel to
digits where ``h`` dominates (the two parts then near ``± 2h/J3``, their sum ``~ w3``).

``psi`` is a constant rate (the mean of ``psi'`` over a period, exact) times ``t`` plus a bounded
periodic part, the integral in ``u`` of the periodic part of ``psi'``. Odd and periodic, it is kept
as Chebyshev series on equal panels of its half period (Clenshaw-Curtis: the series of ``psi'`` at
Chebyshev points, integrated term by term; panels halved until every series reaches the values'
rounding) and evaluated by Clenshaw's recurrence: the float64 floor for a few dozen operations a
sample. On the separatrix (``mc = 0``) the motion never repeats and ``psi'`` tends to its value at
the saddle: that is the rate, and the periodic part is kept on ``[0, SEPARATRIX_RANGE]``, beyond
which it is constant to rounding.

With ``J1 = J2`` (a rotor on the symmetry axis) ``m3`` is constant and the motion is a uniform
precession, ``w = m / J1 + κ e3``: ``R(t) = exp(t [H_N]x / J1) R0 exp(t κ [e3]x)``.

Coasting reaction wheels make the same gyrostat (``J`` the body's inertia less the wheels' spin,
``h = sum h_i g_i``); a wheel's angle relative to the body, ``(h_i / J_si) t - g_i . ∫ w dt``,
needs the rates' integral: a mean rate times ``t`` plus a periodic part, kept as Chebyshev series
over the rates' period the way the attitude's angle is (:class:`RateIntegrals`); for a uniform
precession it is elementary.
"""

from __future__ import annotations

from dataclasses import dataclass
import decimal
import math
from typing import NamedTuple

import numpy as np
from scipy.special import elliprf

from . import gyrostat_kernels
from .elliptic import first_kind_from_values, JacobiElliptic
from ..frames import quaternion
from ..numerics import kernels

#: significant digits of the constants' decimal arithmetic: products of three float64 inputs are
#: exact (~48 digits), differences of roots keep ~40 digits next to a separatrix
DIGITS = 80
#: the degree of the angle's Chebyshev series on each panel
CHEBYSHEV_DEGREE = 16
#: a panel's series is converged when its last coefficients are below this many rounding units of
#: the largest value (the values' own rounding, a few units, is the floor the series reach)
CHEBYSHEV_TAIL_ULPS = 32.0
#: panels at most: their count doubles until the series converge or it reaches this
MAX_PANELS = 4096
#: on the separatrix, ``psi'`` equals its value at the saddle to rounding beyond this ``u``
#: (``sech^2 u < 4 e^-2u ~ 1e-20``)
SEPARATRIX_RANGE = 24.0
#: the same for the rates themselves, whose transverse components fall as ``sech u`` (``2 e^-u``:
#: below 1e-20 here), the range :class:`RateIntegrals` keeps on the separatrix
RATE_SEPARATRIX_RANGE = 48.0

_CONTEXT = decimal.Context(prec=DIGITS, traps=[decimal.InvalidOperation, decimal.DivisionByZero])
_EPS = float(np.finfo(float).eps)

SN2, CN = 'sn2', 'cn'  # the two forms of z(u)


class GyrostatMotion(NamedTuple):
    """
    One non-stationary gyrostat motion: the regime and every constant its evaluation uses.

    Floats (rounded once from the decimal constants) in the solver frame S; see the module
    docstring for the equations.
    """

    regime: str  # rotor_axis_polhode | transverse_axis_polhode | separatrix
    form: str  # SN2 | CN
    mc: float  # the complementary parameter
    m: float  # the parameter, as itself (1 - mc loses it for a nearly symmetric body)
    rate: float  # lambda, 1/s
    initial_phase: float  # u0
    weights: tuple  # (k0, k1): the denominator D = k0 p + k1 q
    z_weights: tuple  # z = (z_weights . (p, q)) / D
    w3_weights: tuple  # w3 = (w3_weights . (p, q)) / D
    momenta: tuple  # (A1, A2): m_i = A_i f_i / D, f_i a product of sn, cn, dn
    powers: tuple  # per transverse component, the powers (0 or 1) of sn, cn, dn in f_i
    inverse_moments: tuple  # (1/J1, 1/J2)
    momentum: float  # H
    reference: int  # the axis of S the motion circles (0, 1; 2: the rotor's), A's axis 3
    reference_sign: float  # σ
    arc_weights: tuple  # reference 3: H + σ z = (arc_weights . (p, q)) / D
    # psi' = (2T + w3_gain w3 + m_gain |m_ref|) / (H + m_ref): see the module docstring
    energy: float  # 2T
    w3_gain: float  # h + σ H for the rotor axis, h for a transverse one
    m_gain: float  # H / J_r for a transverse axis, 0 for the rotor axis
    rotor_momentum: float  # h
    period: float  # of psi' in u (2K or 4K; inf on the separatrix)


def _dec(value) -> decimal.Decimal:
    return decimal.Decimal(float(value))


def solve_gyrostat(moments, omega, h) -> GyrostatMotion | None:
    """
    Choose the regime and every constant once, in the solver frame; ``None`` when stationary.

    ``moments``: ``J1, J2, J3`` (the rotor along axis 3, ``J1 != J2``), ``omega``: the initial rate
    in S, ``h``: the rotor's momentum along ``+e3`` (nonzero). Stationary: a relative equilibrium,
    ``m x w = 0`` exactly (``w2 ((J2 - J3) w3 - h)``, ``w1 ((J3 - J1) w3 + h)``,
    ``(J1 - J2) w1 w2``: all zero), whose rate is constant.
    """
    with decimal.localcontext(_CONTEXT):
        J1, J2, J3 = (_dec(v) for v in moments)
        w1, w2, w3 = (_dec(v) for v in omega)
        hd = _dec(h)
        if (
            w2 * ((J2 - J3) * w3 - hd) == 0
            and w1 * ((J3 - J1) * w3 + hd) == 0
            and (J1 - J2) * w1 * w2 == 0
        ):
            return None
        return _Solver(J1, J2, J3, w1, w2, w3, hd).motion()


class _Root(NamedTuple):
    value: decimal.Decimal | None  # z - z0; None: at infinity (a linear Q)
    quadratic: int  # 0: Q1 (m1 = 0 there), 1: Q2 (m2 = 0 there)


class _Solver:
    """
    The decimal arithmetic of :func:`solve_gyrostat` (within its context).

    Every ``z`` is an offset ``d = z - z0`` from the initial one: ``Q_i(z0 + d) = k d^2 + B d + C``
    with ``C = Q_i(z0) = norm_i m_i(0)^2`` exact from the inputs, so roots a hair from ``z0`` (a
    state next to an equilibrium oscillates by ``~|w_i|^2`` of ``H``) keep their relative precision
    however close they are, and no difference of roots cancels.
    """

    def __init__(self, J1, J2, J3, w1, w2, w3, h):
        self.J = (J1, J2, J3)
        self.w = (w1, w2, w3)
        self.h = h
        self.m0 = (J1 * w1, J2 * w2, J3 * w3 + h)
        self.H2 = sum(v * v for v in self.m0)
        self.H = self.H2.sqrt()
        self.T2 = J1 * w1 * w1 + J2 * w2 * w2 + J3 * w3 * w3
        a, b, c = 1 / J1, 1 / J2, 1 / J3
        self.norms = (a - b, b - a)  # Q1 = (a - b) m1^2, Q2 = (b - a) m2^2
        z0 = self.m0[2]
        # Q_i(z) = k z^2 + 2 c h z + ..., expanded about z0: (k, B, C)
        self.quadratics = tuple(
            (k, 2 * k * z0 + 2 * c * h, norm * m * m)
            for k, norm, m in zip((b - c, a - c), self.norms, self.m0)
        )

    def q(self, i, d):
        """Return ``Q_i(z0 + d)``."""
        k, B, C = self.quadratics[i]
        return (k * d + B) * d + C

    def F(self, d):
        """Return ``z'^2`` at ``z0 + d``."""
        return -self.q(0, d) * self.q(1, d)

    def roots(self):
        """Return the real roots, as offsets, and the complex pair ``(quadratic, re, im)``."""
        real, pair = [], None
        for i, (k, B, C) in enumerate(self.quadratics):
            if k == 0:  # (B = 2 c h != 0)
                real += [_Root(-C / B, i), _Root(None, i)]
                continue
            discriminant = B * B - 4 * k * C
            if discriminant < 0:
                pair = (i, -B / (2 * k), (-discriminant).sqrt() / (2 * abs(k)))
                continue
            # the root nearer 0 as C / s: no cancellation (Numerical Recipes' quadratic)
            s = -(B + discriminant.sqrt().copy_sign(B)) / 2
            if s == 0:  # (B = C = 0: z0 a double root, only at an equilibrium)
                real += [_Root(s, i), _Root(s, i)]
                continue
            real += [_Root(s / k, i), _Root(C / s, i)]
        return real, pair

    def bracket(self, real):
        """Return the turning points: the adjacent real roots around ``z0``, ``F > 0`` between."""
        finite = sorted((r for r in real if r.value is not None), key=lambda r: r.value)
        zero = decimal.Decimal(0)
        best, distance = None, None
        for low, high in zip(finite, finite[1:]):
            if not self.F((low.value + high.value) / 2) > 0:
                continue
            # z0 lies inside but for the rounding of a root it starts on
            outside = max(low.value, -high.value, zero)
            if distance is None or outside < distance:
                best, distance = (low, high), outside
        return best

    def motion(self) -> GyrostatMotion:
        real, pair = self.roots()
        low, high = self.bracket(real)
        others = [r for r in real if r is not low and r is not high]
        if pair is not None:
            constants = self._cn_form(low, high, pair)
        else:
            constants = self._sn2_form(low, high, others)
        return self._finish(**constants)

    # -- the two forms ---------------------------------------------------------------------------
    def _cn_form(self, low, high, pair):
        """Map ``cn`` to ``z`` (the other two roots complex; Byrd & Friedman 259)."""
        other, b1, a1 = pair
        zA, zB = low.value, high.value
        A = ((zB - b1) ** 2 + a1 * a1).sqrt()
        B = ((zA - b1) ** 2 + a1 * a1).sqrt()
        gap = zB - zA
        m = (gap * gap - (A - B) ** 2) / (4 * A * B)
        # (A + B)^2 - gap^2 = (A + B - gap)(A + B + gap): no cancellation in the decimal digits
        mc = (A + B - gap) * (A + B + gap) / (4 * A * B)
        k1, k2 = self.quadratics[0][0], self.quadratics[1][0]
        rate2 = abs(k1 * k2) * A * B
        # cn(u0) from z0 (d = 0), and (1 - c0)(1 + c0) = sn0^2 without cancellation
        up, down = B * zB, A * -zA
        c0 = (up - down) / (up + down)
        sn0_squared = 4 * up * down / ((up + down) ** 2)
        dn0 = (mc + m * c0 * c0).sqrt()
        sn0 = sn0_squared.sqrt().copy_sign(self._zdot())  # dz/du = |dz/dc| sn dn
        powers = [None, None]
        powers[1 - other], powers[other] = (1, 0, 0), (0, 0, 1)
        probe = decimal.Decimal(1) / 2  # c = 1/2: sn^2 = 3/4, dn^2 = mc + m/4
        p, q = 1 + probe, 1 - probe
        return {
            'form': CN,
            'm': m,
            'mc': mc,
            'rate2': rate2,
            'weights': (A, B),
            'ends': (zA, zB),
            'phase': (sn0, c0, dn0),
            'powers': tuple(powers),
            'probe': (p, q, {0: 1 - probe * probe, 1: probe * probe, 2: mc + m * probe * probe}),
            'circled': other,
        }

    def _sn2_form(self, low, high, others):
        """
        Map ``sn^2`` to ``z`` (the four roots real; Byrd & Friedman 252-257).

        The orientation (``z_A`` the low or the high turning point) puts the nearer pair of roots,
        the one that meets on the separatrix, at ``z_B, e_m``: on the separatrix itself (a double
        root) the motion then tends to ``z_B`` as ``u -> inf``. A root at infinity always goes to
        ``e_inf`` (the denominator is then 1).
        """
        # (a root equal to a turning point, a double root on the separatrix, is next to it)
        above = sorted(
            (r for r in others if r.value is not None and r.value >= high.value),
            key=lambda r: r.value,
        )
        below = sorted(
            (r for r in others if r.value is not None and r.value <= low.value),
            key=lambda r: r.value,
        )
        infinite = [r for r in others if r.value is None]
        orders = {
            'up': (low, high, *(above + infinite + below)),
            'down': (high, low, *(below[::-1] + infinite + above[::-1])),
        }

        def pieces(order):
            zA, zB, em, einf = (r.value for r in order)
            return _ratio(em, zB, em, zA), _ratio(zA, einf, zB, einf)

        if infinite:
            orientation = 'up' if orders['up'][3].value is None else 'down'
        else:
            orientation = 'up' if pieces(orders['up'])[0] <= pieces(orders['down'])[0] else 'down'
        order = orders[orientation]
        near, far = pieces(order)
        mc = near * far
        m = 1 - mc
        zA, zB, em, einf = order
        if einf.value is None:
            W0 = W1 = decimal.Decimal(1)
        else:
            W0, W1 = zB.value - einf.value, zA.value - einf.value
        # lambda^2 = F / ((dz/ds)^2 (ds/du)^2) at s = 1/2: dz/ds = W0 W1 (zB - zA) / D^2,
        # (ds/du)^2 = 4 s (1 - s)(1 - m s)
        half_D = (W0 + W1) / 2
        z_half = (zA.value * W0 + zB.value * W1) / (2 * half_D)
        slope = W0 * W1 * (zB.value - zA.value) / (half_D * half_D)
        rate2 = self.F(z_half) / (slope * slope * (1 - m / 2))
        zero = decimal.Decimal(0)
        # (z0, d = 0, starts on a turning point but for the rounding of a root: clipped onto it)
        first, second = -zA.value * W0, zB.value * W1
        if (first < 0) != (second < 0) and first != 0 and second != 0:
            first, second = (zero, second) if abs(first) < abs(second) else (first, zero)
        s0 = first / (first + second)
        direction = self._zdot() * (1 if zB.value > zA.value else -1)
        sn0 = s0.sqrt().copy_sign(direction if direction != 0 else decimal.Decimal(1))
        cn0 = (second / (first + second)).sqrt()
        dn0 = (1 - m * s0).sqrt()
        kinds = {id(zA): 0, id(zB): 1, id(em): 2}  # sn, cn, dn; e_inf: the constant 1
        powers = []
        for i in (0, 1):
            factors = [kinds[id(r)] for r in order if r.quadratic == i and id(r) in kinds]
            powers.append(tuple(int(k in factors) for k in range(3)))
        # the transverse component free of sn and cn never vanishes: the axis the motion circles
        circled = next((i for i in (0, 1) if powers[i][:2] == (0, 0)), 2)
        half = decimal.Decimal(1) / 2
        return {
            'form': SN2,
            'm': m,
            'mc': mc,
            'rate2': rate2,
            'weights': (W0, W1),
            'ends': (zA.value, zB.value),
            'phase': (sn0, cn0, dn0),
            'powers': tuple(powers),
            'probe': (half, half, {0: half, 1: half, 2: 1 - m * half}),
            'circled': circled,
        }

    def _zdot(self):
        """Return ``z'(0) = (m x w)_3 = (J1 - J2) w1 w2`` (its sign)."""
        J1, J2, _ = self.J
        return (J1 - J2) * self.w[0] * self.w[1]

    # -- constants common to both forms ---------------------------------------------------------
    def _finish(self, form, m, mc, rate2, weights, ends, phase, powers, probe, circled):
        k0, k1 = weights
        zA, zB = ends  # offsets from z0
        sn0, cn0, dn0 = phase
        J1, J2, J3 = self.J
        h, H = self.h, self.H
        z0, w3 = self.m0[2], self.w[2]
        # amplitudes at the probe: m_i^2 = Q_i(z) / norm_i = A_i^2 f_i^2 / D^2
        p, q, squares = probe
        D = k0 * p + k1 * q
        d = (zA * k0 * p + zB * k1 * q) / D
        # the signs: D keeps one sign; f_i at u0, or its derivative where f_i(u0) = 0 (a turning
        # point: then m_i(0) = 0 and m_i'(0) = (m x w)_i != 0)
        values = (sn0, cn0, dn0)
        derivatives = (cn0 * dn0, -sn0 * dn0, -m * sn0 * cn0)
        m_dot = (
            self.m0[1] * self.w[2] - self.m0[2] * self.w[1],
            self.m0[2] * self.w[0] - self.m0[0] * self.w[2],
        )
        amplitudes = []
        for i in (0, 1):
            chosen = [k for k in range(3) if powers[i][k]]
            f2 = decimal.Decimal(1)
            for k in chosen:
                f2 *= squares[k]
            amplitude = (self.q(i, d) / self.norms[i] * D * D / f2).sqrt()
            f0 = decimal.Decimal(1)
            for k in chosen:
                f0 *= values[k]
            df0 = sum(
                (
                    derivatives[k] * _product(values[j] for j in chosen if j != k)
                    for k in chosen
                ),
                decimal.Decimal(0),
            )
            same = (self.m0[i] > 0) == (f0 > 0) if self.m0[i] != 0 else (m_dot[i] > 0) == (
                df0 > 0
            )
            if (k0 > 0) != same:
                amplitude = -amplitude
            amplitudes.append(amplitude)
        # the reference axis of the attitude, and psi' = (H w_ref + w . m) / (H + m_ref) with
        # w . m = 2T + h w3, as written (see the module docstring)
        if circled == 2:
            sigma = 1 if 2 * z0 + zA + zB >= 0 else -1
            w3_gain, m_gain = h + sigma * H, decimal.Decimal(0)
            arc = ((H + sigma * (z0 + zA)) * k0, (H + sigma * (z0 + zB)) * k1)
        else:
            sigma = 1 if amplitudes[circled] * k0 > 0 else -1  # f_r > 0 (dn or 1)
            w3_gain, m_gain = h, H / self.J[circled]
            arc = (decimal.Decimal(0), decimal.Decimal(0))
        rate = rate2.sqrt()
        # u0 from the values at it
        s0f, c0f, d0f = float(sn0), float(cn0), float(dn0)
        mc_f = float(mc)
        if form == SN2 or c0f >= 0.0:
            u0 = float(first_kind_from_values(s0f, abs(c0f), d0f))
        else:  # cn(u0) < 0: u0 = ±(2K - v), cn(v) = |cn(u0)|
            v = abs(s0f) * float(elliprf(c0f * c0f, d0f * d0f, 1.0))
            u0 = math.copysign(2.0 * float(elliprf(0.0, mc_f, 1.0)) - v, s0f)
        quarter = float(elliprf(0.0, mc_f, 1.0)) if mc_f > 0.0 else math.inf
        if mc_f == 0.0:
            regime = 'separatrix'
        else:
            regime = 'rotor_axis_polhode' if circled == 2 else 'transverse_axis_polhode'
        return GyrostatMotion(
            regime=regime,
            form=form,
            mc=min(max(mc_f, 0.0), 1.0),
            m=min(max(float(m), 0.0), 1.0),
            rate=float(rate),
            initial_phase=u0,
            weights=(float(k0), float(k1)),
            z_weights=(float((z0 + zA) * k0), float((z0 + zB) * k1)),
            # w3 = (z - h) / J3 = w3(0) + d / J3: relative precision wherever w3 keeps its sign
            w3_weights=(float((w3 + zA / J3) * k0), float((w3 + zB / J3) * k1)),
            momenta=tuple(float(v) for v in amplitudes),
            powers=powers,
            inverse_moments=(float(1 / J1), float(1 / J2)),
            momentum=float(H),
            reference=circled,
            reference_sign=float(sigma),
            arc_weights=tuple(float(v) for v in arc),
            energy=float(self.T2),
            w3_gain=float(w3_gain),
            m_gain=float(m_gain),
            rotor_momentum=float(h),
            period=(2.0 if form == SN2 else 4.0) * quarter,
        )


def _ratio(a, b, c, d):
    """Return ``(a - b) / (c - d)``, 1 where both differences hold the same root at infinity."""
    if (a is None and c is None) or (b is None and d is None):
        return decimal.Decimal(1)
    return (a - b) / (c - d)


def _product(values):
    total = decimal.Decimal(1)
    for v in values:
        total *= v
    return total


# -- evaluation ---------------------------------------------------------------------------------
class _Values(NamedTuple):
    """The solver-frame quantities at ``u``, arrays."""

    m1: np.ndarray
    m2: np.ndarray
    z: np.ndarray
    w3: np.ndarray
    arc: np.ndarray  # H + m_ref (> 0)


class GyrostatRates:
    """
    The closed form of one motion: the solver-frame momentum and rate at any ``u`` (numpy).

    ``p, q`` are ``cn^2, sn^2`` (form SN2) or ``1 + cn, 1 - cn`` (form CN, each from the other
    by ``sn^2 / (1 ∓ cn)`` where it is small), ``D = k0 p + k1 q``.
    """

    def __init__(self, motion: GyrostatMotion):
        self.motion = motion
        self.jacobi = JacobiElliptic(motion.mc, 0.0, motion.m)
        values = np.array(
            (
                *motion.weights,
                *motion.z_weights,
                *motion.w3_weights,
                *motion.momenta,
                *motion.arc_weights,
                motion.momentum,
                motion.reference_sign,
            )
        )
        (
            self._k0,
            self._k1,
            self._z0,
            self._z1,
            self._w0,
            self._w1,
            self._A1,
            self._A2,
            self._arc0,
            self._arc1,
            self._H,
            self._sigma,
        ) = (values[i, ...] for i in range(values.size))

    def __call__(self, u: np.ndarray) -> _Values:
        mo = self.motion
        v = self.jacobi(u, integral=False)
        sn, cn, dn = v.sn, v.cn, v.dn
        if mo.form == SN2:
            p, q = cn * cn, sn * sn
        else:
            sn2 = sn * sn
            p = np.where(cn > 0.0, 1.0 + cn, sn2 / (1.0 - cn))
            q = np.where(cn > 0.0, sn2 / (1.0 + cn), 1.0 - cn)
        inverse = np.reciprocal(self._k0 * p + self._k1 * q)
        functions = (sn, cn, dn)
        m = []
        for amplitude, powers in zip((self._A1, self._A2), mo.powers):
            factor = amplitude * inverse
            for function, power in zip(functions, powers):
                if power:
                    factor = factor * function
            m.append(factor)
        z = (self._z0 * p + self._z1 * q) * inverse
        w3 = (self._w0 * p + self._w1 * q) * inverse
        if mo.reference == 2:
            arc = (self._arc0 * p + self._arc1 * q) * inverse
        else:
            arc = self._H + self._sigma * m[mo.reference]
        return _Values(m[0], m[1], z, w3, arc)

    def angle_rate(self, values: _Values) -> np.ndarray:
        """Return ``G = psi' / lambda``, the angle's rate per unit ``u``."""
        mo = self.motion
        numerator = mo.energy + mo.w3_gain * values.w3
        if mo.reference != 2:
            m_ref = (values.m1, values.m2)[mo.reference]
            numerator = numerator + mo.m_gain * (mo.reference_sign * m_ref)
        return numerator / (values.arc * mo.rate)


class AnglePanels:
    """
    The periodic part ``P(u) = ∫_0^u (G - mean)`` of the angle about H, as Chebyshev series.

    ``G`` is even and periodic (``period``), so ``P`` is odd and periodic, and zero at half the
    period: it is kept on ``[0, X]`` (``X`` the half period, or :data:`SEPARATRIX_RANGE` on the
    separatrix) as ``panels`` series of degree :data:`CHEBYSHEV_DEGREE` on equal panels, halved
    until every series' last coefficients are at the values' rounding. ``mean`` is the exact mean
    of ``G`` (on the separatrix: its limit at the saddle).
    """

    def __init__(self, G, period: float, limit: float | None = None):
        periodic = math.isfinite(period)
        X = 0.5 * period if periodic else SEPARATRIX_RANGE
        n = CHEBYSHEV_DEGREE
        nodes = np.cos(np.pi * (np.arange(n + 1) + 0.5) / (n + 1))  # first kind, on [-1, 1]
        transform = (2.0 / (n + 1)) * np.cos(
            np.pi * np.outer(np.arange(n + 1) + 0.5, np.arange(n + 1)) / (n + 1)
        )
        count = max(1, math.ceil(X))
        while True:
            width = X / count
            middles = (np.arange(count) + 0.5) * width
            values = G((middles[:, None] + (0.5 * width) * nodes).ravel()).reshape(count, n + 1)
            if limit is not None:
                values = values - limit
            coefficients = values @ transform
            coefficients[:, 0] *= 0.5
            tail = np.abs(coefficients[:, -3:]).max()
            scale = np.abs(values).max() + (abs(limit) if limit is not None else 0.0)
            if tail <= CHEBYSHEV_TAIL_ULPS * _EPS * scale or count >= MAX_PANELS:
                break
            count *= 2
        # the series of the antiderivative (degree n + 1): C_k = (c_{k-1} - c_{k+1}) / 2k
        c = np.concatenate([coefficients, np.zeros((count, 2))], axis=1)
        c[:, 0] *= 2.0
        integral = np.zeros((count, n + 2))
        for k in range(1, n + 2):
            integral[:, k] = (c[:, k - 1] - c[:, k + 1]) / (2 * k)
        integral *= 0.5 * width
        at_start = integral @ ((-1.0) ** np.arange(n + 2))
        pieces = integral.sum(axis=1) - at_start
        total = math.fsum(pieces.tolist())
        if limit is None:
            self.mean = total / X
        else:
            self.mean = limit
        starts = np.concatenate([[0.0], np.cumsum(pieces)[:-1]])
        integral[:, 0] += starts - at_start
        if limit is None:  # less the mean: P = I - mean u
            integral[:, 0] -= self.mean * middles
            integral[:, 1] -= self.mean * (0.5 * width)
        self.coefficients = integral
        self.width, self.count, self.range = width, count, X
        self.period = period
        self._inverse_width = 2.0 / width
        self._periodic = periodic

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """Return ``P(u)``."""
        if self._periodic:
            r = u - self.period * np.rint(u / self.period)
        else:
            r = u
        a = np.minimum(np.abs(r), self.range)
        index = np.minimum((a / self.width).astype(np.int64), self.count - 1)
        x = (a - (index + 0.5) * self.width) * self._inverse_width
        rows = self.coefficients[index]
        two_x = x + x
        b1 = rows[:, -1].copy()
        b2 = np.zeros_like(x)
        for k in range(self.coefficients.shape[1] - 2, 0, -1):
            b1, b2 = two_x * b1 - b2 + rows[:, k], b1
        value = x * b1 - b2 + rows[:, 0]
        return np.where(r < 0.0, -value, value)


class RateIntegrals:
    """
    ``∫_0^t w_S dt``, the solver-frame rates' integrals: what a coasting wheel's angle needs.

    In ``u = lambda t + u0``, ``∫_0^t w dt = mean t + (P(u) - P(u0)) / lambda`` with ``mean``
    the mean rate over the full period ``4K`` (every ``sn``, ``cn``, ``dn`` product repeats
    there) and ``P(u) = ∫_0^u (w - mean) du``, periodic. Unlike the angle's ``G``, a transverse
    rate holding ``sn`` or ``cn`` alone is not even, so ``P`` is kept on the whole period
    ``[0, 4K)``: Chebyshev series of degree :data:`CHEBYSHEV_DEGREE` of the three rates at once on
    equal panels (Clenshaw-Curtis, as :class:`AnglePanels`), halved until every series' last
    coefficients are at the rates' rounding; the antiderivative's series term by term. On the
    separatrix (``mc = 0``) the rates tend to their saddle values ``L±`` as ``u -> ±inf``:
    ``mean = 0`` and ``P`` is the whole integral, kept on ``[-R, R]`` (``R =``
    :data:`RATE_SEPARATRIX_RANGE`, where ``w`` equals ``L±`` to rounding) and continued beyond
    with slope ``L±``.
    """

    def __init__(self, rates: GyrostatRates):
        motion = rates.motion
        J1inv, J2inv = motion.inverse_moments

        def w(u):
            v = rates(u)
            return np.stack((v.m1 * J1inv, v.m2 * J2inv, v.w3))

        periodic = math.isfinite(motion.period)
        if periodic:
            full = motion.period * (2.0 if motion.form == SN2 else 1.0)  # 4K
            start, X = 0.0, full
        else:
            full, start, X = math.inf, -RATE_SEPARATRIX_RANGE, 2.0 * RATE_SEPARATRIX_RANGE
        n = CHEBYSHEV_DEGREE
        nodes = np.cos(np.pi * (np.arange(n + 1) + 0.5) / (n + 1))
        transform = (2.0 / (n + 1)) * np.cos(
            np.pi * np.outer(np.arange(n + 1) + 0.5, np.arange(n + 1)) / (n + 1)
        )
        count = max(1, math.ceil(X))
        with np.errstate(under='ignore'):
            while True:
                width = X / count
                middles = start + (np.arange(count) + 0.5) * width
                values = w((middles[:, None] + (0.5 * width) * nodes).ravel())
                values = values.reshape(3, count, n + 1)
                coefficients = values @ transform  # (3, count, n + 1)
                coefficients[:, :, 0] *= 0.5
                tail = np.abs(coefficients[:, :, -3:]).max()
                scale = np.abs(values).max()
                if tail <= CHEBYSHEV_TAIL_ULPS * _EPS * scale or count >= MAX_PANELS:
                    break
                count *= 2
            ends = w(np.array([start, start + X])) if not periodic else None
        c = np.concatenate([coefficients, np.zeros((3, count, 2))], axis=2)
        c[:, :, 0] *= 2.0
        integral = np.zeros((3, count, n + 2))
        for k in range(1, n + 2):
            integral[:, :, k] = (c[:, :, k - 1] - c[:, :, k + 1]) / (2 * k)
        integral *= 0.5 * width
        at_start = integral @ ((-1.0) ** np.arange(n + 2))  # (3, count)
        pieces = integral.sum(axis=2) - at_start
        starts = np.concatenate([np.zeros((3, 1)), np.cumsum(pieces, axis=1)[:, :-1]], axis=1)
        integral[:, :, 0] += starts - at_start
        if periodic:
            #: the mean rates over a period, solver frame, rad/s
            self.mean = np.array([math.fsum(row) / X for row in pieces.tolist()])
            integral[:, :, 0] -= self.mean[:, None] * middles
            integral[:, :, 1] -= self.mean[:, None] * (0.5 * width)
            self._slopes = None
        else:
            self.mean = np.zeros(3)
            self._slopes = ends  # (3, 2): L- at -R, L+ at R (P's constant cancels in P(u) - P(u0))
        self.coefficients = integral  # (3, count, n + 2)
        self.width, self.count, self.start, self.range, self.period = (
            width,
            count,
            start,
            X,
            full,
        )
        self.rate, self.initial_phase = motion.rate, motion.initial_phase
        self._at_start = self.periodic_part(np.array([self.initial_phase]))[:, 0]
        self._kernel = None
        if kernels.ENABLED:
            self._row = gyrostat_kernels.integral_row(self)
            self._kernel = gyrostat_kernels.angle_kernel()

    def periodic_part(self, u: np.ndarray) -> np.ndarray:
        """Return ``P(u)``, ``(3, N)`` (up to a constant on the separatrix)."""
        if self._slopes is None:
            r = u - self.period * np.floor(u / self.period)
            r = np.minimum(r, np.nextafter(self.period, 0.0))  # (u just below a multiple)
            return _clenshaw(self.coefficients, r, self.start, self.width)
        low, high = self.start, self.start + self.range
        inside = np.clip(u, low, high)
        value = _clenshaw(self.coefficients, inside, self.start, self.width)
        value += self._slopes[:, 0:1] * np.minimum(u - low, 0.0)
        value += self._slopes[:, 1:2] * np.maximum(u - high, 0.0)
        return value

    def rest(self, t: np.ndarray) -> np.ndarray:
        """Return ``(P(u) - P(u0)) / lambda`` at ``t``, ``(3, N)``: ``∫_0^t w_S dt - mean t``."""
        u = self.rate * t + self.initial_phase
        return (self.periodic_part(u) - self._at_start[:, None]) / self.rate

    def wheel_angles(self, t: np.ndarray, axes_S: np.ndarray, spins: np.ndarray) -> np.ndarray:
        """
        Return coasting wheels' angles ``theta_i = (h_i / Js_i) t - g_i . ∫_0^t w dt``, ``(N, n)``.

        ``axes_S``: the wheels' axes ``g_i`` in the solver frame ``(n, 3)``; ``spins``:
        ``h_i / Js_i``. As ``(h_i / Js_i - g_i . mean) t - g_i . rest``: the two linear parts
        join in one constant, so the angle keeps its precision when the wheel barely turns
        relative to the body. Compiled with the rates (:mod:`.gyrostat_kernels`) when numba is.
        """
        linear = spins - axes_S @ self.mean
        if self._kernel is not None:
            out = np.empty((t.shape[0], linear.shape[0]))
            wheels = np.ascontiguousarray(np.column_stack([linear, axes_S]))
            self._kernel(np.ascontiguousarray(t, dtype=float), self._row, self.coefficients,
                         wheels, out)
            return out
        rest = self.rest(t)
        return np.outer(t, linear) - (axes_S @ rest).T


def _clenshaw(coefficients, a, start, width):
    """Evaluate the panels' series ``(functions, count, degree)`` at ``a`` in the table's range."""
    count = coefficients.shape[1]
    index = np.minimum(((a - start) / width).astype(np.int64), count - 1)
    index = np.maximum(index, 0)
    x = (a - (start + (index + 0.5) * width)) * (2.0 / width)
    rows = coefficients[:, index]  # (functions, N, degree)
    two_x = x + x
    b1 = rows[:, :, -1].copy()
    b2 = np.zeros_like(b1)
    for k in range(coefficients.shape[2] - 2, 0, -1):
        b1, b2 = two_x * b1 - b2 + rows[:, :, k], b1
    return x * b1 - b2 + rows[:, :, 0]


def attitude_frame(reference: int, sign: float) -> tuple:
    """
    Return the rows of ``E`` (``v_A = E v_S``), a proper signed permutation with row 3 ``σ e_ref``.

    Exact.
    """
    s = sign
    if reference == 2:
        return ((1.0, 0.0, 0.0), (0.0, s, 0.0), (0.0, 0.0, s))
    if reference == 0:
        return ((0.0, s, 0.0), (0.0, 0.0, 1.0), (s, 0.0, 0.0))
    return ((0.0, 0.0, s), (1.0, 0.0, 0.0), (0.0, s, 0.0))


@dataclass(frozen=True)
class SolverFrame:
    """The solver frame S of a rotor along principal axis ``rotor``: ``v_S = C v_B``."""

    rows: tuple  # C, rows of floats
    moments: tuple  # J1, J2, J3
    rotor_momentum: float  # h along +e3 of S


def solver_frame(moments_P, principal_axes, rotor: int, h: float) -> SolverFrame:
    """
    Return the solver frame: principal axes ``(i, j, rotor)``, ``i < j`` the others, row 1 signed.

    A proper rotation; ``h``, the rotor's momentum along principal axis ``rotor``, keeps its sign.
    """
    i, j = (k for k in range(3) if k != rotor)
    order = (i, j, rotor)
    inversions = (order[0] > order[1]) + (order[0] > order[2]) + (order[1] > order[2])
    signs = (-1.0 if inversions % 2 else 1.0, 1.0, 1.0)
    axes = np.asarray(principal_axes, dtype=float)
    rows = tuple(
        tuple(signs[k] * float(axes[col, order[k]]) for col in range(3)) for k in range(3)
    )
    moments = tuple(float(moments_P[k]) for k in order)
    return SolverFrame(rows, moments, float(h))


class GyrostatAttitude:
    """
    Exact ``(omega_B, q_NB)`` at any times for one gyrostat motion (numpy).

    Per sample: the Jacobi functions at ``u = lambda t + u0``; ``m_S``, ``w_S`` from
    :class:`GyrostatRates`; ``omega_B = C^T w_S``; ``q_NB = L ⊗ Rz(psi) ⊗ Q(m_A) ⊗ q_AB``, the
    constant factors one 4x4 matrix (as :class:`.polhode.PolhodeAttitude`), ``m_A = E m_S``,
    ``psi = psi_rate t + P(u) - P(u0)``.
    """

    #: elements evaluated in one pass (as PolhodeAttitude's): temporaries stay in cache
    ELEMENTS_PER_PASS = 2560

    def __init__(self, motion: GyrostatMotion, frame: SolverFrame, q0_NB):
        self.motion = motion
        self.rates = GyrostatRates(motion)
        limit = None
        if not math.isfinite(motion.period):  # the saddle: sn = 1, cn = dn = 0
            limit = float(self.rates.angle_rate(self.rates(np.array([np.inf])))[0])
        with np.errstate(under='ignore'):
            self.panels = AnglePanels(
                lambda u: self.rates.angle_rate(self.rates(u)), motion.period, limit
            )
        self.psi_rate = self.panels.mean * motion.rate
        u0 = motion.initial_phase
        self._psi_offset = -float(self.panels(np.array([u0]))[0])
        E = attitude_frame(motion.reference, motion.reference_sign)
        self._permutation = tuple(
            next((k, row[k]) for k in range(3) if row[k] != 0.0) for row in E
        )
        C = frame.rows
        J1inv, J2inv = motion.inverse_moments
        # omega_B = w_S @ C: rows of C scaled
        self._rate_rows = (np.array(C[0]), np.array(C[1]), np.array(C[2]))
        self._inverse_moments = (J1inv, J2inv)
        # q_AB of E C, and L from the initial attitude: q_NB0 = L ⊗ Q(m_A0) ⊗ q_AB (psi(0) = 0)
        EC = [[sum(E[r][k] * C[k][col] for k in range(3)) for col in range(3)] for r in range(3)]
        q_AB = quaternion.matrix_quaternion(EC)
        m_A0 = self._attitude_vector(self.rates(np.array([u0])))
        arc0 = float(m_A0[3][0])
        x0, y0 = float(m_A0[0][0]), float(m_A0[1][0])
        norm0 = math.sqrt(2.0 * motion.momentum * arc0)
        Q0 = (y0 / norm0, -x0 / norm0, 0.0, arc0 / norm0)
        q0 = np.asarray(q0_NB, dtype=float).tolist()
        left = quaternion.multiply_values(
            q0, quaternion.conjugate_values(quaternion.multiply_values(Q0, q_AB))
        )
        self._frame_change_rows = tuple(
            np.array(row) for row in zip(*quaternion.product_matrix_values(left, q_AB))
        )
        self._two_momentum = 2.0 * motion.momentum
        # the compiled evaluation, with these very constants (gyrostat_kernels)
        self._kernel = None
        if kernels.ENABLED:
            self._row, self._panel_table = gyrostat_kernels.table(self)
            self._kernel = gyrostat_kernels.kernel()

    @property
    def compiled(self) -> bool:
        return self._kernel is not None

    def _attitude_vector(self, v: _Values):
        """Return ``(m_A1, m_A2, m_A3, H + m_A3)``."""
        m_S = (v.m1, v.m2, v.z)
        (i1, s1), (i2, s2), (i3, s3) = self._permutation
        return s1 * m_S[i1], s2 * m_S[i2], s3 * m_S[i3], v.arc

    def __call__(self, t: np.ndarray):
        count = t.shape[0]
        if self._kernel is not None:
            omega, q = np.empty((count, 3)), np.empty((count, 4))
            self._kernel(
                np.ascontiguousarray(t, dtype=float), self._row, self._panel_table, omega, q
            )
            return omega, q
        step = self.ELEMENTS_PER_PASS
        if count <= step:
            return self._pass(t)
        omega, q = np.empty((count, 3)), np.empty((count, 4))
        for start in range(0, count, step):
            omega[start: start + step], q[start: start + step] = self._pass(t[start: start + step])
        return omega, q

    def _pass(self, t: np.ndarray):
        # (on and next to a separatrix sech^2 and the transverse momenta underflow to their true
        # value's rounding, 0, far from the turning point)
        with np.errstate(under='ignore'):
            return self._evaluate(t)

    def _evaluate(self, t: np.ndarray):
        mo = self.motion
        u = mo.rate * t + mo.initial_phase
        v = self.rates(u)
        J1inv, J2inv = self._inverse_moments
        w_S = (v.m1 * J1inv, v.m2 * J2inv, v.w3)
        omega = _combine(w_S, self._rate_rows)
        mA1, mA2, _, arc = self._attitude_vector(v)
        half = 0.5 * ((self.psi_rate * t + self.panels(u)) + self._psi_offset)
        scale = np.reciprocal(np.sqrt(self._two_momentum * arc))
        cos_half, sin_half = np.cos(half) * scale, np.sin(half) * scale
        about_H_arc = (
            cos_half * mA2 + sin_half * mA1,
            sin_half * mA2 - cos_half * mA1,
            sin_half * arc,
            cos_half * arc,
        )
        return omega, _combine(about_H_arc, self._frame_change_rows)


class UniformPrecession:
    """
    A rotor on the symmetry axis (``J1 = J2``): ``w = m / J1 + κ e``, constant ``κ``.

    ``q_NB(t) = exp(t H_N / (2 J1)) ⊗ q0 ⊗ exp(t κ e / 2)`` and ``w(t)`` is ``w0`` turned by
    ``-κ t`` about ``e`` (the rotor axis in B), exact: ``R' = R [w]x`` with
    ``R^T H_N = m(t)``.
    """

    def __init__(self, J1: float, J3: float, h: float, axis_B, omega0_B, q0_NB):
        e = np.asarray(axis_B, dtype=float)
        w0 = np.asarray(omega0_B, dtype=float)
        w3 = float(e @ w0)
        z = J3 * w3 + h
        self.kappa = w3 - z / J1  # = -((J3 - J1) w3 + h) / J1
        self.e, self.w0, self.q0 = e, w0, np.asarray(q0_NB, dtype=float)
        m_B = J1 * w0 + ((J3 - J1) * w3 + h) * e
        H_N = quaternion.rotate(self.q0, m_B)
        self.spin = float(np.linalg.norm(H_N)) / J1
        self.H_axis = H_N / np.linalg.norm(H_N)

    def __call__(self, t: np.ndarray):
        turn = -self.kappa * t  # of w about e
        c, s = np.cos(turn), np.sin(turn)
        e, w0 = self.e, self.w0
        along = (e @ w0) * e
        across = w0 - along
        omega = (
            along + c[:, None] * across + s[:, None] * np.cross(e, w0)[None, :]
        )
        half_spin = 0.5 * self.spin * t
        left = np.column_stack([np.sin(half_spin)[:, None] * self.H_axis, np.cos(half_spin)])
        half_k = 0.5 * self.kappa * t
        right = np.column_stack([np.sin(half_k)[:, None] * e, np.cos(half_k)])
        return omega, quaternion.multiply(quaternion.multiply(left, self.q0), right)

    def rate_integral(self, t: np.ndarray):
        """
        Return ``(mean (3,), rest (N, 3))``: ``∫_0^t w dt = mean t + rest``, body frame.

        ``mean`` is ``w``'s part along ``e``; the turning part integrates to
        ``across sin(κt) / κ - (e x w0) 2 sin^2(κt / 2) / κ`` (no cancellation as ``κ -> 0``).
        """
        e, w0, kappa = self.e, self.w0, self.kappa
        if kappa == 0.0:
            return w0, np.zeros((t.size, 3))
        along = (e @ w0) * e
        across = w0 - along
        half = np.sin(0.5 * kappa * t)
        rest = (np.sin(kappa * t) / kappa)[:, None] * across - (
            2.0 * half * half / kappa
        )[:, None] * np.cross(e, w0)[None, :]
        return along, rest


def _combine(columns, rows) -> np.ndarray:
    """
    Compute ``np.stack(columns, -1) @ matrix`` from the matrix's ``rows``, element by element.

    As :func:`.polhode._combine`: a sample does not depend on how many were requested with it.
    """
    total = columns[0][..., None] * rows[0]
    for column, row in zip(columns[1:], rows[1:]):
        total += column[..., None] * row
    return total
