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
The free gyrostat's rates in closed form for any ``h``, oblique to the principal axes (issue 43).

The Zhukovsky-Volterra gyrostat ``I w' + w x (I w + h) = 0`` (Volterra 1899; Basak, "On the
motion of a free gyrostat", 2009, for the general ``h``), in the principal frame, ``A = I^-1``:
the total momentum ``m = I w + h`` moves as ``m' = m x w`` on the curve ``|m| = H``,
``(m - h) . A (m - h) = 2T``, the intersection of two quadrics, an elliptic curve. Its
uniformising variable is the time itself, and the construction below treats every regime alike (a
motion about a centre, circulating, next to a separatrix), since it never asks which one it is.

**The curve from the initial point.** A point ``m`` of the sphere other than ``m0`` is
``m = m0 - 2 (m0 . v) v / (v . v)``, ``v`` its direction from ``m0`` (the second intersection of
a line through ``m0``). It lies on the energy quadric exactly when the homogeneous cubic
``C(v) = (m0 . v)(v . A v) - (w0 . v)(v . v)`` vanishes (``w0 = A (m0 - h)``; both quadrics'
equations less ``m0``'s, divided by the line's parameter). ``C`` vanishes at ``v = d``, the
tangent ``d = m0' = m0 x w0`` (``m0 . d = w0 . d = 0``). Lines of directions through ``d`` are the
planes through the tangent line: ``v = alpha d + p``, ``p = p0 + s p1`` with ``p0, p1`` an
orthonormal pair across ``d``, and

    ``C = a2(s) alpha^2 + a1(s) alpha + a0(s)``,
    ``a2 = (m0 . p)(d . A d) - (w0 . p)``, ``a1 = 2 (m0 . p)(d . A p)``,
    ``a0 = (m0 . p)(p . A p) - (w0 . p)(p . p)``  (``|d| = 1``):

each plane holds two more points of the curve, ``alpha = (y - a1) / (2 a2)`` with
``y^2 = Delta(s) = a1^2 - 4 a2 a0``, a quartic. ``s`` is a function of degree two on the curve,
``(s, y)`` its birational model, and ``ds / y`` its holomorphic differential: ``s' = kappa y``,
``kappa`` constant, so ``s'^2 = f(s) = kappa^2 Delta(s)`` (Whittaker & Watson, *Modern Analysis*,
§20.6). ``p0`` is along ``m0''`` across ``d`` (the osculating plane: ``s(0) = 0``, ``a2(0) = 0``,
the double point ``alpha = inf`` being ``m0`` itself, on the branch ``y(0) = -a1(0)``), and
``s'(0) = (p1 . m0''') / (3 p0 . m0'')`` from ``s = p1 . (m - m0) / p0 . (m - m0)`` expanded in
``t``; ``kappa = s'(0) / y(0)``.

**The plane in closed form.** ``f`` has two real roots ``s_A``, ``s_B`` (the turning points of
``s``) around ``s(0) = 0``; with ``s_A`` one of them, reached at ``t_c``, Weierstrass's solution
from a root (Whittaker & Watson §20.6, example 1) is

    ``s(t) = s_A + f'(s_A) / (4 (P(t - t_c) - c))``,  ``c = f''(s_A) / 24``,

``P`` Weierstrass's function of the quartic's invariants ``g2, g3``, and
``y = s' / kappa = -f'(s_A) P' / (4 kappa (P - c)^2)``. ``P`` and ``P'`` in Jacobi functions of
``u = r (t - t_c)`` (DLMF 23.6.16-23.6.17; Abramowitz & Stegun 18.9.11 with the half argument of
DLMF 22.6.19), the cubic ``4x^3 - g2 x - g3`` having

* three real roots ``e1 > e2 > e3``: ``P = e3 + r^2 / sn^2``, ``r^2 = e1 - e3``,
  ``m = (e2 - e3) / r^2``, ``mc = (e1 - e2) / r^2``; ``P - c = (E X + R Y) / X`` with
  ``X = sn^2``, ``Y = cn^2``, ``E = e1 - c``, ``R = r^2``;
* one real root ``e2``: ``P = e2 + H2 cn^2 / (sn^2 dn^2)``, ``r^2 = H2 = sqrt(3 e2^2 - g2 / 4)``,
  ``m = 1/2 - 3 e2 / (4 H2)``, ``mc = 1/2 + 3 e2 / (4 H2)``; ``X = sn^2 dn^2``,
  ``Y = cn^2 - sn^2 dn^2 = cn^4 - mc sn^4`` (small with relative precision where the motion
  lingers by a saddle, ``P`` by the cubic's near-double root), ``E = e2 - c + H2``.

The plane, homogeneous, is then ``p = Y (4 R p_A) + X (4 E p0 + (4 E s_A + f'(s_A)) p1)`` (with
three real roots the two terms are the two turning points' planes, ``p_A = p0 + s_A p1``):
weights of one sign at the turning points, each vector formed once in the decimal digits, never
``s`` itself, so no cancellation and no division where ``s`` passes through infinity. ``y``
comes with its sign as ``y = (8 f'(s_A) r^3 / kappa) sn cn dn`` (times ``dn^4 + m mc sn^4``, a
sum of positive terms, for one real root), not as a square root, which would lose half the
digits at the turning points. The root is taken in whichever of ``(y - a1) / (2 a2)`` and
``2 a0 / (-a1 - y)`` adds terms of one sign, as a direction ``v = num d + den p``.

``t_c`` comes from ``P(t_c) = c - f'(s_A) / (4 s_A)`` (``s(0) = 0``), inverted by the incomplete
integral of the first kind (:func:`.elliptic.first_kind_from_values`, Carlson's ``R_F``) from
``sn, cn, dn`` formed in the decimal digits, on the half period that the sign of ``P'(t_c)``,
``s'(0) f'(s_A)``'s, picks. Of the real roots of ``f`` reached at a real time (``P(t_c)`` on the
real line's range, at least ``e1`` or ``e2``) ``s_A`` is the most isolated one, away from the
pair that meets next to a separatrix.

**Next to the pencil's base point** ``m0`` (``t`` next to a multiple of the period)
``m - m0 ~ a2 / y`` with ``a2`` cancelling in the form above; there (``v`` within
:data:`BASE_POINT_MARGIN` of the tangent) the solution from the initial point itself serves
(Whittaker & Watson §20.6, example 2: ``s = (a P'(t) + b x + e) / (2 x^2 - g)``,
``x = P(t) - c``, with ``a = -s'(0)`` and ``b, c, e, g`` from ``f``'s derivatives at 0), in which
``a2`` is one term (:class:`InitialForm`). That form alone does not serve everywhere: its
numerator and denominator share a zero (two of the four points where ``2 x^2 = g`` are not poles
of ``s``), at real times for some motions.

The real period of ``P`` is the motion's: ``2K / r``. Next to a separatrix two roots of the cubic
meet and ``mc -> 0``; the cubic's roots come from the quartic's coefficients in 80-digit decimal
arithmetic on the exact binary inputs (one simple root by Newton's method, the other two by the
deflated quadratic), so ``mc`` keeps its relative precision there, and the Jacobi functions take
``mc`` (:mod:`.elliptic`). Where the plane passes by a saddle the cubic ``C``'s coefficients
nearly cancel: ``a2, a1, a0`` (and ``m0 . p``, ``w0 . p``) are polynomials in ``X, Y`` whose
coefficients are formed in the decimal digits (the float plane's own rounding would move the
point by ``eps / sqrt(mc)``). A uniform precession is refused with its reason.

**Exactly on a separatrix** the cubic has a double root (the decimal roots split by the square
root of the digits' rounding, :data:`SEPARATRIX_MC`): ``mc = 0``, ``m = 1``, ``sn = tanh``,
``cn = dn = sech``, ``K = inf`` and no period; the motion leaves its saddle and returns to it
(``t -> -inf, +inf``) as ``e^{-2r|t|}``. ``P`` is even about ``u = 0``, so a turning point reached
while ``P`` increases is at ``-u_c``; with one real root ``P - e2 = H2 coth^2 u`` reaches only
``[e2 + H2, inf)`` (the turning points below lie on the other loop), and ``X, Y, y`` of that form
carry a common factor ``dn^2`` (``dn^4`` for ``y``) that vanishes at the saddle, so the real roots'
``X = sn^2``, ``Y = cn^2``, ``y = slope_scale sn cn dn`` serve (the forms are homogeneous).

**The attitude** (:class:`ObliqueAttitude`) is the principal-axis gyrostat's: the rotation about
the constant inertial momentum by an angle whose rate is exact, ``psi' = (H w . e + 2T + h . w) /
(H + m . e)``, integrated over a period by Chebyshev series on panels halved where they have not
converged (:class:`PeriodicIntegral`: no symmetry of the motion is assumed, the origin being any
state); coasting wheels' angles come from the rates' integrals the same way
(:class:`ObliqueRateIntegrals`). On a separatrix both integrate over the whole time axis
(:class:`WholeLineIntegral`: panels in ``s = tanh(r (t - t_c))`` on ``(g - g_saddle) dt/ds``, plus
``g_saddle t`` exactly).

**The evaluation** is compiled by :mod:`.gyrostat_oblique_kernels` (numba) when the kernels are
on where an object is built (:mod:`..numerics.kernels`), sample by sample with the operations
below in their order; the numpy code here is the reference it repeats. The constants (the
decimal arithmetic, the series) are built here either way.
"""

from __future__ import annotations

import decimal
import math
from typing import NamedTuple

import numpy as np

from . import gyrostat_oblique_kernels
from .elliptic import first_kind_from_values, JacobiElliptic
from ..frames import quaternion
from ..numerics import kernels

#: significant digits of the constants' decimal arithmetic (as :mod:`.gyrostat`'s)
DIGITS = 80
#: Newton's iterations on the cubic's simple root at most (quadratic convergence: 80 digits from
#: a float64 start take four)
NEWTON_STEPS = 40

_CONTEXT = decimal.Context(prec=DIGITS, traps=[decimal.InvalidOperation, decimal.DivisionByZero])

#: Taylor terms of the step to another base point, and such steps at most
TAYLOR_ORDER = 60
BASE_SHIFTS = 3
#: a decimal quantity this small relative to its terms' scale counts as zero (the inputs' products
#: are exact to ~48 digits, their rounding to float64 is 1e-16)
_NEGLIGIBLE = decimal.Decimal(10) ** -40
#: ``mc`` this small is a double root of the cubic, a state on a separatrix: the decimal roots of
#: a double root split by the square root of the 80 digits' rounding (``mc`` ~ 1e-39 measured),
#: a motion 1e-10 from a separatrix has ``mc`` ~ 1e-10
SEPARATRIX_MC = decimal.Decimal(10) ** -30

#: the turning point's form hands a sample to the initial point's where the direction ``v`` from
#: the pencil's base point ``m0`` is within this sine of the tangent ``d`` (``m`` next to ``m0``,
#: where ``m - m0 ~ a2 / y`` and ``a2`` cancels in the turning point's form)
BASE_POINT_MARGIN = 0.05

REAL_ROOTS, ONE_REAL_ROOT = 'real_roots', 'one_real_root'


class InitialForm(NamedTuple):
    """
    Weierstrass's solution from the initial point itself (module docstring), floats.

    Exact where the pencil's base point makes the other form lose digits, next to the base time
    (mod the period): there ``a2 = A2[1] s1`` keeps its relative precision. ``u = r (t - t_b)``.
    """

    slope_weight: float  # a = -s'(0): N = a Z + numerator(X, Y)
    numerator: tuple  # degree 2 in X, Y
    denominator: tuple  # D, degree 2
    turn_quartic: tuple  # y = turn_quartic(X, Y) + Z turn_slope(X, Y)
    turn_slope: tuple  # degree 2
    a2: tuple  # in (s0, s1) = (D, N), the coefficient of s^k with s0^(deg - k) s1^k
    a1: tuple
    a0: tuple
    plane_axes: tuple  # p0, p1


class ObliqueMotion(NamedTuple):
    """One non-stationary oblique gyrostat motion: every constant its evaluation uses (floats)."""

    form: str  # REAL_ROOTS | ONE_REAL_ROOT
    mc: float
    m: float
    rate: float  # r, 1/s: u = r t
    period: float  # of the rates, s; inf on a separatrix (mc = 0)
    turning_time: float  # t_c, s: u = r (t - t_c)
    slope_scale: float  # y = slope_scale sn cn dn (times dn^4 + m mc sn^4: one real root)
    # the plane p = Y planes[0] + X planes[1], X = sn^2, Y = cn^2 (real roots: each a turning
    # point's) or X = sn^2 dn^2, Y = cn^4 - mc sn^4 (one real root)
    planes: tuple
    # (m0 . p, w0 . p, a2, a1, a0) as polynomials in X, Y (coefficients of X^j Y^(deg - j))
    pencil: tuple
    tangent: tuple  # d / |d|
    initial: InitialForm
    momentum0: tuple  # m0 = I w0 + h at the base point
    rate0: tuple  # w0 there
    inverse_moments: tuple  # A
    base_time: float = 0.0  # s: the pencil's base point is the state at this time
    momentum: float = 0.0  # H = |m|
    energy: float = 0.0  # 2T = w . I w


def _dec(value) -> decimal.Decimal:
    return decimal.Decimal(float(value))


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _scale(k, a):
    return tuple(k * x for x in a)


def _add(*vectors):
    return tuple(sum(parts) for parts in zip(*vectors))


def _poly_mul(a, b):
    """Multiply polynomials given as coefficient lists, lowest power first."""
    out = [decimal.Decimal(0)] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] += x * y
    return out


def _poly_add(*polys):
    size = max(len(p) for p in polys)
    return [sum((p[k] for p in polys if k < len(p)), decimal.Decimal(0)) for k in range(size)]


class _Degenerate(Exception):
    """The pencil at this base point is degenerate: another base point serves."""


def solve_oblique(moments, omega, h) -> ObliqueMotion | None:
    """
    Return the motion's constants from ``w0 = omega`` (principal frame); ``None`` if stationary.

    ``moments``: the principal moments ``I1, I2, I3``; ``h``: the constant relative momentum in the
    principal frame (any direction). Stationary: ``m0 x w0 = 0`` exactly (a relative equilibrium,
    whose rate is constant). The pencil is based at the initial state, or, where that state
    makes it degenerate (an inflection of the rate curve, or ``a1(0) = 0``: a state of symmetry,
    such as a transverse rate at zero with ``h`` on a principal axis), at the state a short time
    ``tau`` later, from the Taylor series of ``m' = m x A (m - h)`` in the decimal digits
    (:data:`TAYLOR_ORDER` terms, each step a twentieth of the motion's time scale: truncation
    below 1e-70). A uniform precession (a symmetric body with ``h`` on its axis, the curve a
    circle) is refused: :class:`.gyrostat.UniformPrecession` is its closed form.
    """
    with decimal.localcontext(_CONTEXT):
        J = tuple(_dec(v) for v in moments)
        w0 = tuple(_dec(v) for v in omega)
        hd = tuple(_dec(v) for v in h)
        A = tuple(1 / x for x in J)
        m0 = tuple(J[k] * w0[k] + hd[k] for k in range(3))
        if all(x == 0 for x in _cross(m0, w0)):
            return None
        invariants = (_dot(m0, m0).sqrt(), _dot(w0, _add(m0, _scale(-1, hd))))
        speed = _dot(w0, w0).sqrt() + max(A) * invariants[0]
        tau = decimal.Decimal(1) / (20 * speed)
        for step in range(BASE_SHIFTS + 1):
            base = m0 if step == 0 else _advance(m0, A, hd, step * tau)
            try:
                motion = _motion_at(A, hd, base)
            except (_Degenerate, decimal.InvalidOperation, decimal.DivisionByZero):
                continue
            shift = float(step * tau)
            return motion._replace(
                base_time=shift,
                turning_time=motion.turning_time + shift,
                momentum=float(invariants[0]),
                energy=float(invariants[1]),
            )
        raise ValueError(
            'the oblique gyrostat degenerates here (a uniform precession: a symmetric body with '
            'h on its symmetry axis)'
        )


def _advance(m, A, h, tau):
    """Return ``m(tau)`` from ``m(0) = m`` by the Taylor series of ``m' = m x A (m - h)``."""
    terms = [m]
    rates = [tuple(A[k] * (m[k] - h[k]) for k in range(3))]
    for k in range(TAYLOR_ORDER):
        total = (decimal.Decimal(0),) * 3
        for i in range(k + 1):
            total = _add(total, _cross(terms[i], rates[k - i]))
        term = _scale(1 / decimal.Decimal(k + 1), total)
        terms.append(term)
        rates.append(tuple(A[j] * term[j] for j in range(3)))
    value = terms[-1]
    for term in reversed(terms[:-1]):
        value = _add(term, _scale(tau, value))
    return value


def _motion_at(A, h, m0) -> ObliqueMotion:
    """Return the constants with the pencil based at ``m0`` (time 0 there; decimal context)."""
    w0 = tuple(A[k] * (m0[k] - h[k]) for k in range(3))
    d = _cross(m0, w0)
    # m' = m x w, w' = A m' (w = A (m - h)): the derivatives at the base point
    dw = tuple(A[k] * d[k] for k in range(3))
    m2 = _add(_cross(d, w0), _cross(m0, dw))
    dw2 = tuple(A[k] * m2[k] for k in range(3))
    m3 = _add(_cross(m2, w0), _scale(2, _cross(d, dw)), _cross(m0, dw2))
    tangent = _scale(1 / _dot(d, d).sqrt(), d)
    across = _add(m2, _scale(-_dot(m2, tangent), tangent))
    size = _dot(across, across).sqrt()
    if size <= _dot(m2, m2).sqrt() * _NEGLIGIBLE:  # an inflection: no osculating plane
        raise _Degenerate
    p0 = _scale(1 / size, across)
    p1 = _cross(tangent, p0)
    slope = _dot(p1, m3) / (3 * _dot(p0, m2))  # s'(0)
    return _Solver(A, w0, m0, tangent, p0, p1, slope).motion()


class _Solver:
    """The decimal arithmetic of :func:`solve_oblique` (within its context)."""

    def __init__(self, A, w0, m0, tangent, p0, p1, slope):
        self.A, self.w0, self.m0 = A, w0, m0
        self.tangent, self.p0, self.p1, self.slope = tangent, p0, p1, slope

        def Ap(a, b):
            return sum(A[k] * a[k] * b[k] for k in range(3))

        d = tangent
        mp = [_dot(m0, p0), _dot(m0, p1)]  # m0 . p(s), lowest power of s first
        wp = [_dot(w0, p0), _dot(w0, p1)]
        dAp = [Ap(d, p0), Ap(d, p1)]
        pAp = [Ap(p0, p0), 2 * Ap(p0, p1), Ap(p1, p1)]
        pp = [decimal.Decimal(1), decimal.Decimal(0), decimal.Decimal(1)]
        self.a2 = _poly_add([x * Ap(d, d) for x in mp], [-x for x in wp])
        self.a1 = [2 * x for x in _poly_mul(mp, dAp)]
        self.a0 = _poly_add(_poly_mul(mp, pAp), [-x for x in _poly_mul(wp, pp)])
        delta = _poly_add(
            _poly_mul(self.a1, self.a1), [-4 * x for x in _poly_mul(self.a2, self.a0)]
        )
        scale = abs(mp[0]) * max(A) + abs(mp[1]) * max(A)
        if abs(self.a1[0]) <= scale * _NEGLIGIBLE or slope == 0:
            raise _Degenerate  # the base point is a branch point of s: kappa is 0 / 0
        self.kappa = slope / -self.a1[0]
        self.f = [self.kappa * self.kappa * x for x in delta] + [decimal.Decimal(0)] * 5
        self.f = self.f[:5]  # c0 .. c4

    def roots(self, g2, g3):
        """Return ``('real', (e1, e2, e3))`` or ``('one', e2)`` of ``4x^3 - g2 x - g3``."""
        discriminant = g2 ** 3 - 27 * g3 * g3
        guesses = np.roots([4.0, 0.0, -float(g2), -float(g3)])
        if discriminant < 0:
            start = guesses[np.argmin(np.abs(guesses.imag))].real
        else:
            real = np.sort(guesses.real)
            gaps = np.diff(real)
            start = real[0] if gaps[0] > gaps[1] else real[2]  # the most isolated
        e = _dec(start)
        for _ in range(NEWTON_STEPS):
            step = (4 * e ** 3 - g2 * e - g3) / (12 * e * e - g2)
            e -= step
            if abs(step) <= abs(e) * decimal.Decimal(10) ** -(DIGITS - 4):
                break
        rest = g2 - 3 * e * e  # 4x^3 - g2 x - g3 = (x - e)(4x^2 + 4ex + 4e^2 - g2)
        if discriminant < 0 or rest < 0:
            return 'one', e
        root = rest.sqrt()
        return 'real', tuple(sorted((e, (-e + root) / 2, (-e - root) / 2), reverse=True))

    def motion(self) -> ObliqueMotion:
        c0, c1, c2, c3, c4 = self.f
        # the quartic as a0 s^4 + 4 a1 s^3 + 6 a2 s^2 + 4 a3 s + a4 (Whittaker & Watson §20.6)
        b0, b1, b2, b3, b4 = c4, c3 / 4, c2 / 6, c1 / 4, c0
        g2 = b0 * b4 - 4 * b1 * b3 + 3 * b2 * b2
        g3 = b0 * b2 * b4 + 2 * b1 * b2 * b3 - b2 ** 3 - b0 * b3 * b3 - b1 * b1 * b4
        kind, roots = self.roots(g2, g3)
        if kind == 'real':
            e1, e2, e3 = roots
            r2 = e1 - e3
            m, mc = (e2 - e3) / r2, (e1 - e2) / r2
            form, top = REAL_ROOTS, e1
        else:
            e2 = roots
            r2 = (3 * e2 * e2 - g2 / 4).sqrt()  # H2
            # 1/2 -+ 3 e2 / (4 H2), each as a quotient without cancellation:
            # (2 H2 - 3 e2)(2 H2 + 3 e2) = 4 H2^2 - 9 e2^2 = 3 e2^2 - g2
            product = 3 * e2 * e2 - g2
            m = (2 * r2 - 3 * e2) / (4 * r2)
            mc = (2 * r2 + 3 * e2) / (4 * r2)
            if e2 > 0:
                m = product / (4 * r2 * (2 * r2 + 3 * e2))
            elif e2 < 0:
                mc = product / (4 * r2 * (2 * r2 - 3 * e2))
            form, top = ONE_REAL_ROOT, e2
        r = r2.sqrt()
        if mc <= SEPARATRIX_MC:  # a double root: on a separatrix, sn = tanh, cn = dn = sech
            m, mc = decimal.Decimal(1), decimal.Decimal(0)
        fm, fmc = float(m), float(mc)
        K = float(JacobiElliptic(fmc, m=fm).quarter_period)
        # on a separatrix P reaches the double root only as t -> inf (one real root: P - e2 =
        # H2 coth^2 u >= H2): the turning points with P below it lie on the other loop
        reach = top + r2 if form == ONE_REAL_ROOT and fmc == 0.0 else top
        turning, slope, P_c = self.turning_point(reach)
        # the time of the turning point from P(t_c) = P_c and the sign of P'(t_c), that of
        # s'(0) f'(s_c): P decreases on u in (0, K), increases on (K, 2K)
        if form == REAL_ROOTS:  # P = e3 + r^2 / sn^2
            values = (r2 / (P_c - e3), (P_c - e1) / (P_c - e3), (P_c - e2) / (P_c - e3))
            sn, cn, dn = (float(v.sqrt()) for v in values)
            u_c = float(first_kind_from_values(sn, cn, dn))
        else:  # (1 + cn 2u) / (1 - cn 2u) = (P - e2) / H2
            p = P_c - e2
            cos2 = (p - r2) / (p + r2)
            sin2 = 2 * (p * r2).sqrt() / (p + r2)
            dn2 = (mc + m * cos2 * cos2).sqrt()
            half = float(first_kind_from_values(float(sin2), abs(float(cos2)), float(dn2)))
            u_c = 0.5 * (half if cos2 >= 0 else 2.0 * K - half)
        if (self.slope > 0) == (slope > 0):  # P'(t_c) > 0
            u_c = 2.0 * K - u_c if fmc > 0.0 else -u_c  # (P even about 0 on a separatrix)
        period = 2.0 * K / float(r)

        def floats(values):
            return tuple(float(x) for x in values)

        # s = s_c + f'(s_c) / (4 (P - c)), P - c = (E X + R Y) / X: the plane
        # p = p0 + s p1 ~ 4 R Y p_A + X (4 E p0 + (4 E s_c + f'(s_c)) p1), p_A = p0 + s_c p1,
        # the second term the other turning point's plane (Y = 0: P = top)
        shift = self.derivative(turning, 2) / 24  # c = f''(s_c) / 24
        E = top - shift
        start = _scale(4 * r2, _add(self.p0, _scale(turning, self.p1)))
        end = _add(_scale(4 * E, self.p0), _scale(4 * E * turning + slope, self.p1))
        if form == ONE_REAL_ROOT:  # in Y = cn^2 - sn^2 dn^2 = cn^4 - mc sn^4, small by a saddle
            end = _add(end, start)
        return ObliqueMotion(
            form=form,
            mc=fmc,
            m=fm,
            rate=float(r),
            period=period,
            turning_time=u_c / float(r),
            slope_scale=float(8 * slope * r2 * r / self.kappa),
            planes=(floats(start), floats(end)),
            pencil=tuple(floats(c) for c in self.pencil(start, end)),
            tangent=floats(self.tangent),
            initial=self.initial_form(form, g2, g3, top, r2),
            momentum0=floats(self.m0),
            rate0=floats(self.w0),
            inverse_moments=floats(self.A),
        )

    def pencil(self, start, end):
        """
        Return ``(m0 . p, w0 . p, a2, a1, a0)`` at ``p = Y start + X end`` as polynomials in X, Y.

        Coefficients of ``X^j Y^(deg - j)``, formed in the decimal digits: where the plane passes
        by a saddle these nearly cancel, and their differences, formed here, keep their relative
        precision (the float plane's own rounding would move the point by ``eps / sqrt(mc)``).
        """
        A, d = self.A, self.tangent

        def Ap(a, b):
            return sum(A[k] * a[k] * b[k] for k in range(3))

        mp = [_dot(self.m0, start), _dot(self.m0, end)]
        wp = [_dot(self.w0, start), _dot(self.w0, end)]
        dAp = [Ap(d, start), Ap(d, end)]
        pAp = [Ap(start, start), 2 * Ap(start, end), Ap(end, end)]
        pp = [_dot(start, start), 2 * _dot(start, end), _dot(end, end)]
        a2 = _poly_add([x * Ap(d, d) for x in mp], [-x for x in wp])
        a1 = [2 * x for x in _poly_mul(mp, dAp)]
        a0 = _poly_add(_poly_mul(mp, pAp), [-x for x in _poly_mul(wp, pp)])
        return mp, wp, a2, a1, a0

    def initial_form(self, form, g2, g3, top, r2) -> InitialForm:
        """
        Return Weierstrass's solution from ``s(0) = 0`` as polynomials in ``X, Y`` (``Z`` apart).

        ``s = (a P' + b x + e) / (2 x^2 - g)``, ``x = P - c``, and ``(2 x^2 - g)^2 s' = a R4(x) +
        P' (-2 b x^2 - 4 e x - b g)``, ``R4 = (6 (x + c)^2 - g2 / 2)(2 x^2 - g) - 4 x P'^2``,
        ``P'^2 = 4 (x + c)^3 - g2 (x + c) - g3``; times ``X^2``, with ``x = (E X + R Y) / X``
        (one real root: ``Y = cn^4 - mc sn^4 = cn^2 - sn^2 dn^2``, ``E = e2 - c + H2``, so that
        the terms keep their sign where the motion lingers by a saddle).
        """
        c0, c1, c2, c3, c4 = self.f
        zero, one = decimal.Decimal(0), decimal.Decimal(1)
        a, b, e, g = -self.slope, c1 / 2, c0 * c3 / 4, c0 * c4 / 2
        shift = c2 / 12
        xc = [shift, one]  # x + c, lowest power first
        xc2 = _poly_mul(xc, xc)
        second = _poly_add([6 * v for v in xc2], [-g2 / 2])  # P''
        cube = _poly_add([4 * v for v in _poly_mul(xc2, xc)], [-g2 * v for v in xc], [-g3])
        R4 = _poly_add(
            _poly_mul(second, [-g, zero, 2 * one]), [-4 * v for v in _poly_mul([zero, one], cube)]
        )
        E = top - shift + (r2 if form == ONE_REAL_ROOT else 0)
        Q, F = [r2, E], [zero, one]  # in (Y, X): lowest power of X first

        def homogeneous(coefficients, degree):
            """Return ``sum c_k Q^k F^(degree - k)`` as coefficients of ``X^j Y^(degree - j)``."""
            total = [zero] * (degree + 1)
            for k, c in enumerate(coefficients):
                term = [c]
                for _ in range(k):
                    term = _poly_mul(term, Q)
                for _ in range(degree - k):
                    term = _poly_mul(term, F)
                total = _poly_add(total, term)
            return total

        def floats(values):
            return tuple(float(x) for x in values)

        gain = 1 / self.kappa
        return InitialForm(
            slope_weight=float(a),
            numerator=floats(homogeneous([e, b], 2)),
            denominator=floats(homogeneous([-g, zero, 2 * one], 2)),
            turn_quartic=floats(gain * a * v for v in homogeneous(R4 + [zero] * (5 - len(R4)), 4)),
            turn_slope=floats(gain * v for v in homogeneous([-b * g, -4 * e, -2 * b], 2)),
            a2=floats(self.a2),
            a1=floats(self.a1),
            a0=floats(self.a0),
            plane_axes=(floats(self.p0), floats(self.p1)),
        )

    def derivative(self, s, order):
        """Return the ``order``-th derivative of ``f`` at ``s``."""
        coefficients = list(self.f)
        for _ in range(order):
            coefficients = [k * c for k, c in enumerate(coefficients)][1:]
        return sum(c * s ** k for k, c in enumerate(coefficients))

    def turning_point(self, top):
        """
        Return ``(s_c, f'(s_c), P(t_c))``: a turning point of ``s`` on this motion.

        The real roots of ``f`` (float64 estimates polished by Newton's method in the decimal
        digits), those reached at a real time (``P(t_c) = c - f'(s_c) / (4 s_c) >= top``, the
        real line's least ``P``), and of them the farthest from every other root: a simple root,
        away from the pair that meets next to a separatrix.
        """
        estimates = np.roots([float(c) for c in reversed(self.f)])
        scale = max(abs(estimates))
        real = [float(x.real) for x in estimates if abs(x.imag) <= 1e-6 * scale]
        best, best_gap = None, -1.0
        for start in real:
            s = _dec(start)
            for _ in range(NEWTON_STEPS):
                slope = self.derivative(s, 1)
                if slope == 0:
                    break
                step = self.derivative(s, 0) / slope
                s -= step
                if abs(step) <= (abs(s) + 1) * decimal.Decimal(10) ** -(DIGITS - 4):
                    break
            if s == 0:
                continue
            slope = self.derivative(s, 1)
            P_c = self.derivative(s, 2) / 24 - slope / (4 * s)
            if P_c < top:
                continue
            gap = min((abs(start - x) for x in estimates if x != start), default=math.inf)
            if gap > best_gap:
                best, best_gap = (s, slope, P_c), gap
        if best is None:
            raise _Degenerate
        return best


def _direction(d, p, y, a2, a1, a0):
    """
    Return ``v = alpha d + p`` as ``num d + den p``, ``alpha`` the root of ``y = 2 a2 alpha + a1``.

    In whichever of ``(y - a1) / (2 a2)`` and ``2 a0 / (-a1 - y)`` adds terms of one sign.
    """
    same = a1 * y <= 0.0
    num = np.where(same, y - a1, 2.0 * a0)
    den = np.where(same, 2.0 * a2, -a1 - y)
    return num[:, None] * d + den[:, None] * p


def _homogeneous(coefficients, X, Y):
    """
    Evaluate ``sum c_j X^j Y^(deg - j)`` (Horner in ``X`` over ``Y``'s powers).

    ``Y``'s powers by products, as the compiled path forms them (numpy's ``**`` is its own
    vectorised ``pow``, in the last bit of some samples).
    """
    degree = len(coefficients) - 1
    total = coefficients[degree] * np.ones_like(X)
    power = Y
    for j in range(degree - 1, -1, -1):
        total = total * X + coefficients[j] * power
        power = power * Y
    return total


class ObliqueRates:
    """
    The rates ``w(t)`` of one oblique motion, principal frame.

    Compiled (:mod:`.gyrostat_oblique_kernels`) when the kernels are on where it is built, the
    numpy path below otherwise (the reference the kernels repeat).
    """

    def __init__(self, motion: ObliqueMotion):
        self.motion = motion
        self.jacobi = JacobiElliptic(motion.mc, m=motion.m)
        # one real root's X = sn^2 dn^2, Y = cn^4 - mc sn^4 (and y, Z times dn^4 + m mc sn^4);
        # on a separatrix (cn = dn) these are sn^2, cn^2 (y, Z) times dn^2 (dn^4), which the
        # homogeneous forms drop: the real roots' X, Y, nonzero as t -> inf
        self.one_root = motion.form == ONE_REAL_ROOT and motion.mc > 0.0
        self._kernels = None
        if kernels.ENABLED:
            self._row = gyrostat_oblique_kernels.rates_row(motion, self.jacobi, self.one_root)
            self._kernels = gyrostat_oblique_kernels.kernels()

    @property
    def compiled(self) -> bool:
        """Tell whether the evaluation runs through the kernels (on where it was built)."""
        return self._kernels is not None

    def momentum_direction(self, t: np.ndarray):
        """
        Return ``v`` per sample, ``(N, 3)``: ``m = m0 - 2 (m0 . v) v / (v . v)``.

        From the turning point's form, but where ``v`` lies within :data:`BASE_POINT_MARGIN` of
        the tangent ``d`` (``m`` next to ``m0``, the pencil's base point, where ``a2`` cancels in
        that form): there from the initial point's form.
        """
        mo = self.motion
        t = np.asarray(t, dtype=float)
        if self._kernels is not None:
            v = np.empty((t.shape[0], 3))
            self._kernels['direction_kernel'](np.ascontiguousarray(t), self._row, v)
            return v
        # on a separatrix cn = dn = sech underflow as t -> inf: their limit, 0
        with np.errstate(under='ignore'):
            values = self._jacobi(mo.rate * (t - mo.turning_time))
            sn, cn, dn = values
            X, Y = sn * sn, cn * cn
            y = mo.slope_scale * sn * cn * dn
            if self.one_root:
                dn2, sn4 = dn * dn, X * X
                y = y * (dn2 * dn2 + (mo.m * mo.mc) * sn4)
                X = X * dn2
                Y = Y * Y - mo.mc * sn4
            start, end = (np.asarray(plane) for plane in mo.planes)
            p = Y[:, None] * start + X[:, None] * end
            d = np.asarray(mo.tangent)
            m0_p, w0_p, a2, a1, a0 = (_homogeneous(c, X, Y) for c in mo.pencil)
            v = _direction(d, p, y, a2, a1, a0)
            # v = num d + den p mostly along d: m next to m0
            along = np.abs(_along(v, d))
            near = along * along > (1.0 - BASE_POINT_MARGIN**2) * np.einsum('ij,ij->i', v, v)
            if np.any(near):
                v[near] = self._initial_direction(t[near])
        return v

    def _jacobi(self, u):
        with np.errstate(under='ignore'):
            values = self.jacobi(u, integral=False)
        return values.sn, values.cn, values.dn

    def _initial_direction(self, t):
        """Return ``v`` from the initial point's form (:class:`InitialForm`)."""
        mo, form = self.motion, self.motion.initial
        with np.errstate(under='ignore'):
            sn, cn, dn = self._jacobi(mo.rate * (t - mo.base_time))
            X, Y = sn * sn, cn * cn
            Z = -2.0 * mo.rate ** 3 * sn * cn * dn
            if self.one_root:
                dn2, sn4 = dn * dn, X * X
                X = X * dn2
                Y = Y * Y - mo.mc * sn4
                Z = Z * (dn2 * dn2 + (mo.m * mo.mc) * sn4)
            N = form.slope_weight * Z + _homogeneous(form.numerator, X, Y)
            D = _homogeneous(form.denominator, X, Y)
            y = _homogeneous(form.turn_quartic, X, Y) + Z * _homogeneous(form.turn_slope, X, Y)
            a2 = form.a2[0] * D + form.a2[1] * N
            a1 = form.a1[0] * D * D + form.a1[1] * D * N + form.a1[2] * N * N
            a0 = ((form.a0[0] * D + form.a0[1] * N) * D + form.a0[2] * N * N) * D + (
                form.a0[3] * N * N * N
            )
            p0, p1 = (np.asarray(p) for p in form.plane_axes)
            p = D[:, None] * p0 + N[:, None] * p1
            return _direction(np.asarray(mo.tangent), p, y, a2, a1, a0)

    def state(self, t: np.ndarray) -> tuple:
        """
        Return ``(w, m)`` at ``t``, each ``(N, 3)``, principal frame.

        ``m = m0 + k v`` and ``w = w0 + k A v``, ``k = -2 (m0 . v) / (v . v)``: the change from
        the initial state as one term (no difference of nearly equal momenta).
        """
        mo = self.motion
        if self._kernels is not None:
            t = np.ascontiguousarray(t, dtype=float)
            w, m = np.empty((t.shape[0], 3)), np.empty((t.shape[0], 3))
            self._kernels['state_kernel'](t, self._row, w, m)
            return w, m
        v = self.momentum_direction(t)
        m0 = np.asarray(mo.momentum0)
        gain = (-2.0 * _along(v, m0) / np.einsum('ij,ij->i', v, v))[:, None] * v
        return np.asarray(mo.rate0) + gain * np.asarray(mo.inverse_moments), m0 + gain

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Return ``w(t)``, ``(N, 3)``, principal frame."""
        return self.state(t)[0]

    def momentum(self, t: np.ndarray) -> np.ndarray:
        """Return ``m(t) = I w + h``, ``(N, 3)``, principal frame."""
        return self.state(t)[1]


# -- the attitude -------------------------------------------------------------------------------
#: the degree of the angle's Chebyshev series on each panel (as :mod:`.gyrostat`'s)
CHEBYSHEV_DEGREE = 16
#: a panel's series is converged when its last coefficients are below this many rounding units of
#: the largest value
CHEBYSHEV_TAIL_ULPS = 32.0
#: the panels a period starts with, each then halved until its series converges
INITIAL_PANELS = 8
#: ... or until it is this fraction of the period (a bound on the work; never reached in the cases)
MIN_PANEL_FRACTION = 2.0**-20
#: ... of the whole line's ``[-1, 1]`` in ``s = tanh``: next to ``s = ±1`` the integrand
#: ``(g - limit) dt/ds`` carries ``g``'s rounding times ``dt/ds``, noise no panel resolves
WHOLE_LINE_LEAST_PANEL = 2.0**-12
#: samples of the momentum over a period from which the reference axis is chosen
REFERENCE_SAMPLES = 512

_EPS = float(np.finfo(float).eps)


class PeriodicIntegral:
    """
    ``∫_0^t g dt = mean t + P(t)`` of a smooth periodic ``g`` (whole period, no symmetry).

    Chebyshev series of degree :data:`CHEBYSHEV_DEGREE` of ``g`` on panels of the period
    (Clenshaw-Curtis: values at the first-kind Chebyshev points, the antiderivative's series term
    by term, as :class:`.gyrostat.RateIntegrals`); a panel whose last coefficients are not yet at
    the values' rounding is halved, so the panels crowd where ``g`` turns fast (the passage by a
    saddle next to a separatrix) and stay wide elsewhere. ``mean`` is the exact mean over the
    period (the panels' integrals summed by ``fsum``), ``P`` periodic with ``P(0) = 0``.
    """

    def __init__(self, g, period: float, least_panel: float = MIN_PANEL_FRACTION):
        n = CHEBYSHEV_DEGREE
        nodes = np.cos(np.pi * (np.arange(n + 1) + 0.5) / (n + 1))
        transform = (2.0 / (n + 1)) * np.cos(
            np.pi * np.outer(np.arange(n + 1) + 0.5, np.arange(n + 1)) / (n + 1)
        )
        pending = [
            (k * period / INITIAL_PANELS, period / INITIAL_PANELS) for k in range(INITIAL_PANELS)
        ]
        panels, scale, self._vector = [], 0.0, None
        while pending:
            starts = np.array([a for a, _ in pending])
            widths = np.array([w for _, w in pending])
            points = (starts + 0.5 * widths)[:, None] + (0.5 * widths)[:, None] * nodes
            values = np.asarray(g(points.ravel()))
            self._vector = values.ndim == 2
            values = values.reshape(len(pending), n + 1, -1)  # (panels, nodes, functions)
            # one scale for every function: a function that stays near 0 is not refined to noise
            scale = max(scale, float(np.abs(values).max()))
            coefficients = np.einsum('pnf,nj->pjf', values, transform)
            coefficients[:, 0] *= 0.5
            tails = np.abs(coefficients[:, -3:]).max(axis=(1, 2))
            split = []
            for (a, w), rows, tail in zip(pending, coefficients, tails):
                if tail <= CHEBYSHEV_TAIL_ULPS * _EPS * scale or w <= period * least_panel:
                    panels.append((a, w, rows))
                else:
                    split += [(a, 0.5 * w), (a + 0.5 * w, 0.5 * w)]
            pending = split
        panels.sort(key=lambda panel: panel[0])
        self.starts = np.array([a for a, _, _ in panels])
        self.widths = np.array([w for _, w, _ in panels])
        #: each panel's middle and the scale to its Chebyshev variable ``x``
        self.middles, self.scales = self.starts + 0.5 * self.widths, 2.0 / self.widths
        coefficients = np.array([rows for _, _, rows in panels])  # (count, n + 1, functions)
        count = len(panels)
        c = np.concatenate([coefficients, np.zeros((count, 2, coefficients.shape[2]))], axis=1)
        c[:, 0] *= 2.0
        integral = np.zeros((count, n + 2, coefficients.shape[2]))
        for k in range(1, n + 2):
            integral[:, k] = (c[:, k - 1] - c[:, k + 1]) / (2 * k)
        integral *= 0.5 * self.widths[:, None, None]
        at_start = np.einsum('pjf,j->pf', integral, (-1.0) ** np.arange(n + 2))
        pieces = integral.sum(axis=1) - at_start  # (count, functions)
        #: the mean of ``g`` over the period (per function)
        self.mean = np.array([math.fsum(column) for column in pieces.T.tolist()]) / period
        before = np.concatenate([np.zeros((1, pieces.shape[1])), np.cumsum(pieces, axis=0)[:-1]])
        integral[:, 0] += before - at_start - self.middles[:, None] * self.mean
        integral[:, 1] -= (0.5 * self.widths)[:, None] * self.mean
        self.coefficients = integral
        self.count, self.period = count, period
        if not self._vector:
            self.mean = float(self.mean[0])
        # by degree, then panel: each step of Clenshaw's recurrence gathers one contiguous row
        table = np.moveaxis(integral, 1, 0)
        self._table = np.ascontiguousarray(table if self._vector else table[:, :, 0])
        #: (degree, panel, function) for the compiled recurrence, whatever ``g``'s shape
        self.compiled_table = np.ascontiguousarray(table)
        self._kernel = None
        if kernels.ENABLED:
            self._kernel = gyrostat_oblique_kernels.kernels()['periodic_kernel']

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Return ``P(t)``: ``(N,)``, or ``(N, functions)`` for a vector ``g``."""
        if self._kernel is not None:
            t = np.ascontiguousarray(t, dtype=float)
            out = np.empty((t.shape[0], self.compiled_table.shape[2]))
            self._kernel(
                t, self.period, self.starts, self.middles, self.scales, self.compiled_table, out
            )
            return out if self._vector else out[:, 0]
        r = t - self.period * np.floor(t / self.period)
        index = np.clip(np.searchsorted(self.starts, r, side='right') - 1, 0, self.count - 1)
        x = (r - self.middles[index]) * self.scales[index]
        if self._vector:
            x = x[:, None]
        table = self._table
        two_x = x + x
        b1 = table[-1][index]
        b2 = np.zeros_like(b1)
        for k in range(table.shape[0] - 2, 0, -1):
            b1, b2 = two_x * b1 - b2 + table[k][index], b1
        return x * b1 - b2 + table[0][index]


class WholeLineIntegral:
    """
    ``∫_0^t g dt = limit t + P(t)`` of a ``g`` that tends to ``limit`` like ``sech^2`` both ways.

    A motion on a separatrix (no period): ``g - limit`` is smooth in ``s = tanh(rate (t -
    centre))`` over ``(-1, 1)`` and decays like ``1 - s^2 = rate dt/ds``, so ``(g - limit) dt/ds``
    is a smooth function of ``s`` on ``[-1, 1]``, integrated by :class:`PeriodicIntegral`'s panels
    in ``sigma = 1 + s`` over ``[0, 2]`` (its mean added back: nothing there is periodic).
    """

    def __init__(self, g, limit, rate: float, centre: float):
        self.mean, self.rate, self.centre = limit, rate, centre

        def integrand(sigma):
            s = sigma - 1.0
            values = np.asarray(g(centre + np.arctanh(s) / rate)) - limit
            weight = 1.0 / (rate * (1.0 - s * s))
            return values * (weight[:, None] if values.ndim == 2 else weight)

        self.series = PeriodicIntegral(integrand, 2.0, WHOLE_LINE_LEAST_PANEL)
        #: the integral from sigma = 0, less its value at t = 0 (P(0) = 0)
        self.offset = 0.0
        self.offset = self(np.zeros(1))[0]

    def sigma(self, t: np.ndarray) -> np.ndarray:
        """Return ``1 + tanh(rate (t - centre))``: the series' variable."""
        return 1.0 + np.tanh(self.rate * (np.asarray(t, dtype=float) - self.centre))

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Return ``P(t)``: ``(N,)``, or ``(N, functions)`` for a vector ``g``."""
        sigma = self.sigma(t)
        series = self.series
        slope = series.mean * (sigma[:, None] if series._vector else sigma)
        return (series(sigma) + slope) - self.offset


def _saddle_times(motion: ObliqueMotion) -> np.ndarray:
    """Return the times ``t -> -inf, +inf`` of a separatrix, as far as ``sech`` is 0 in float64."""
    return motion.turning_time + np.array([-1e3, 1e3]) / motion.rate


def _integral(g, motion: ObliqueMotion, limit):
    """Return ``g``'s integral: over a period, or over the whole line on a separatrix."""
    if math.isfinite(motion.period):
        return PeriodicIntegral(g, motion.period)
    return WholeLineIntegral(g, limit, motion.rate, motion.turning_time)


class ObliqueRateIntegrals:
    """
    ``∫_0^t w dt = mean t + P(t)``, principal frame: what a coasting wheel's angle needs.

    The three rates at once by :class:`PeriodicIntegral` over the motion's period (as
    :class:`.gyrostat.RateIntegrals` does for ``h`` on a principal axis).
    """

    def __init__(self, rates: ObliqueRates):
        self.series = _integral(rates, rates.motion, rates(_saddle_times(rates.motion))[1])
        #: the mean rates over a period, principal frame, rad/s
        self.mean = self.series.mean

    def wheel_angles(self, t: np.ndarray, axes_P: np.ndarray, spins: np.ndarray) -> np.ndarray:
        """
        Return coasting wheels' angles ``theta_i = (h_i / Js_i) t - g_i . ∫_0^t w dt``, ``(N, n)``.

        ``axes_P``: the wheels' axes in the principal frame ``(n, 3)``; ``spins``: ``h_i / Js_i``.
        As ``(h_i / Js_i - g_i . mean) t - g_i . P(t)``: the linear parts joined in one constant.
        """
        t = np.asarray(t, dtype=float)
        return np.outer(t, spins - axes_P @ self.mean) - _rows(self.series(t), axes_P)


def _combine(columns, rows) -> np.ndarray:
    """Return ``np.stack(columns, -1) @ matrix`` from the matrix's ``rows``, element by element."""
    total = columns[0][..., None] * rows[0]
    for column, row in zip(columns[1:], rows[1:]):
        total += column[..., None] * row
    return total


def _along(vectors: np.ndarray, v) -> np.ndarray:
    """
    Return ``vectors @ v`` for ``(N, 3)`` vectors, element by element.

    A BLAS product's rounding can depend on ``N`` (its kernels differ by size): a sample must not
    depend on the block it is asked in.
    """
    return vectors[:, 0] * v[0] + vectors[:, 1] * v[1] + vectors[:, 2] * v[2]


def _rows(vectors: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """Return ``vectors @ matrix.T`` for ``(N, 3)`` vectors (einsum: no BLAS call per block)."""
    return np.einsum('ij,kj->ik', vectors, matrix)


def _frame_with_axis(axis) -> np.ndarray:
    """Return a proper rotation's rows ``E`` whose third row is the unit ``axis``."""
    e3 = np.asarray(axis, dtype=float)
    k = int(np.argmin(np.abs(e3)))
    helper = np.zeros(3)
    helper[k] = 1.0
    e1 = helper - (helper @ e3) * e3
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(e3, e1), e3])


class ObliqueAttitude:
    """
    Exact ``(omega_B, q_NB)`` of one oblique motion: rates in closed form, the angle by series.

    As :class:`.gyrostat.GyrostatAttitude`: ``q_NB = L ⊗ Rz(psi) ⊗ Q(m_A) ⊗ q_AB`` in a body
    frame A whose axis 3 is a reference axis ``e``, ``Q(m)`` the shortest arc from ``m / H`` to
    ``e_z`` and ``L`` constant, so that ``R_NB m = H L e_z``, the constant inertial momentum. The
    kinematics ``q' = q ⊗ (w, 0) / 2`` with ``m' = m x w`` leave one angle about ``H``, whose rate
    is (the Euler angle about ``H`` plus the turn of ``(m_A1, m_A2)``)

        ``psi' = (H w . e + w . m) / (H + m . e)``,  ``w . m = 2T + h . w``,

    evaluated as written. ``e`` is chosen once among the principal axes (both signs) and the
    momentum's mean direction over a period, the one farthest from ``-m`` along the motion (``H +
    m . e`` stays at least ``H`` times the largest such margin), and ``psi = mean psi' t + P(t)``
    (:class:`PeriodicIntegral`). ``principal_axes``: the columns of the principal axes in the body
    frame (``v_B = axes v_P``).
    """

    def __init__(self, motion: ObliqueMotion, h, principal_axes, q0_NB):
        self.motion = motion
        self.rates = ObliqueRates(motion)
        self.h = np.asarray(h, dtype=float)
        self.H, self.energy = motion.momentum, motion.energy  # |m|, 2T = w . I w
        # the momentum at t = 0 (the pencil's base point, or the closed form's value there)
        m0 = np.asarray(motion.momentum0)
        if motion.base_time != 0.0:
            m0 = self.rates.momentum(np.zeros(1))[0]
        if math.isfinite(motion.period):
            samples = np.arange(REFERENCE_SAMPLES) * (motion.period / REFERENCE_SAMPLES)
        else:  # the whole separatrix, by s = tanh(r (t - t_c)), and the saddle
            nodes = np.cos(np.pi * (np.arange(REFERENCE_SAMPLES) + 0.5) / REFERENCE_SAMPLES)
            samples = np.concatenate(
                [motion.turning_time + np.arctanh(nodes) / motion.rate, _saddle_times(motion)]
            )
        orbit = self.rates.momentum(samples)
        mean = orbit.mean(axis=0)
        candidates = [np.eye(3)[k] * sign for k in range(3) for sign in (1.0, -1.0)]
        if np.linalg.norm(mean) > 0.0:
            candidates.append(mean / np.linalg.norm(mean))
        margins = [float((orbit @ e).min()) for e in candidates]
        self.reference = candidates[int(np.argmax(margins))]
        E = _frame_with_axis(self.reference)
        self._E = E
        self.angle = _integral(
            self._angle_rate, motion, self._angle_rate(_saddle_times(motion))[1]
        )
        self.psi_rate = self.angle.mean
        axes = np.asarray(principal_axes, dtype=float)
        self._axes = axes
        # q_AB: v_A = E v_P = E axes^T v_B
        q_AB = np.asarray(quaternion.matrix_quaternion((E @ axes.T).tolist()))
        m_A0 = E @ m0
        Q0 = self._arc(m_A0[None, :], np.array([self.H + m_A0[2]]))[0]
        q0 = np.asarray(q0_NB, dtype=float)
        left = quaternion.multiply(q0, quaternion.conjugate(quaternion.multiply(Q0, q_AB)))
        # q = left ⊗ x ⊗ q_AB as one matrix: rows of ``columns @ matrix`` (as the principal-axis
        # gyrostat's)
        self._frame_change_rows = tuple(
            np.array(row)
            for row in zip(*quaternion.product_matrix_values(left.tolist(), q_AB.tolist()))
        )
        self._two_momentum = 2.0 * self.H
        # the compiled evaluation, with these very constants (gyrostat_oblique_kernels)
        if self.rates.compiled:
            self._row = gyrostat_oblique_kernels.attitude_row(
                self.H, self.psi_rate, motion.period, E, axes, self._frame_change_rows,
                None if isinstance(self.angle, PeriodicIntegral) else self.angle,
            )

    @property
    def compiled(self) -> bool:
        """Tell whether the evaluation runs through the kernels, as its rates' does."""
        return self.rates.compiled

    def _angle_rate(self, t: np.ndarray) -> np.ndarray:
        w, m = self.rates.state(t)
        e = self.reference
        numerator = self.H * _along(w, e) + self.energy + _along(w, self.h)
        return numerator / (self.H + _along(m, e))

    def _arc(self, m_A: np.ndarray, arc: np.ndarray) -> np.ndarray:
        """Return ``Q(m_A)``, ``(N, 4)``: the shortest arc from ``m / H`` to ``e_z``."""
        scale = 1.0 / np.sqrt(2.0 * self.H * arc)
        return np.column_stack(
            [m_A[:, 1] * scale, -m_A[:, 0] * scale, np.zeros_like(arc), arc * scale]
        )

    def __call__(self, t: np.ndarray):
        """Return ``(omega_B, q_NB)`` at ``t``: ``(N, 3)`` and ``(N, 4)``."""
        t = np.asarray(t, dtype=float)
        if self.rates.compiled:
            t = np.ascontiguousarray(t)
            omega, q = np.empty((t.shape[0], 3)), np.empty((t.shape[0], 4))
            angle = self.angle if isinstance(self.angle, PeriodicIntegral) else self.angle.series
            self.rates._kernels['attitude_kernel'](
                t, self.rates._row, self._row, angle.starts, angle.middles, angle.scales,
                angle.compiled_table, omega, q,
            )
            return omega, q
        w, m = self.rates.state(t)
        m_A = _rows(m, self._E)
        arc = self.H + m_A[:, 2]
        half = 0.5 * (self.psi_rate * t + self.angle(t))
        # Rz(psi) ⊗ Q(m_A), Q's scale 1 / sqrt(2 H arc) folded into the half angle's cosine and
        # sine (Q's third component is 0)
        scale = 1.0 / np.sqrt(self._two_momentum * arc)
        cos_half, sin_half = np.cos(half) * scale, np.sin(half) * scale
        inner = (
            cos_half * m_A[:, 1] + sin_half * m_A[:, 0],
            sin_half * m_A[:, 1] - cos_half * m_A[:, 0],
            sin_half * arc,
            cos_half * arc,
        )
        return _rows(w, self._axes), _combine(inner, self._frame_change_rows)
