"""Jacobi elliptic functions and one elliptic integral of the third kind, parametrised by the
**complementary** parameter ``mc = 1 - m``.

Why not ``scipy.special.ellipj``: it takes ``m``, and next to the separatrix of the free rigid body
``m`` rounds to 1 and ``mc`` (what sets the period ``K ~ log(4/sqrt(mc))``) is lost. Near the turning
points ``cn`` and ``dn`` are tiny, and the attitude integral needs them to *relative* precision.

The method (periods and integrals from Carlson's symmetric forms in ``scipy.special``):

* reduce ``u`` to ``r`` in ``[0, K]`` with the half-period ``2K`` symmetries;
* on ``[0, K/2]`` evaluate ``sn, cn, dn`` as quotients of theta series in the nome of ``m`` (``m <= 1/2``)
  or, by Jacobi's imaginary transformation, of the complementary parameter (``m > 1/2``): each nome is
  at most ``exp(-pi)``, a few terms reach float64, and ``cn``, ``dn`` keep relative precision
  (:class:`_ThetaSeries`);
* on ``[K/2, K]`` use ``v = K - u``: ``sn = cd(v)``, ``cn = k' sd(v)``, ``dn = k' nd(v)`` (DLMF 22.4.3).

The attitude about the angular momentum needs ``Π(n; am u | m) = u + n S(u)`` (``n <= 0``) with
``S(u) = ∫_0^u sn^2/(1 - n sn^2) du' = (1/3) sn^3 R_J(cn^2, dn^2, 1, 1 - n sn^2)`` (DLMF 19.25.14).
``S`` itself is returned, not ``Π``: the attitude uses ``n S`` beside terms that would cancel against
``u``. On the second half of the quarter period ``S`` comes from the same identity in ``v = K - u``
(``sn(K - v) = cd(v)``), so nothing cancels. On the separatrix (``mc = 0``) everything is
hyperbolic and in closed form.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import elliprf, elliprj

from .ops import COLUMNS, FLOATS


@dataclass(frozen=True)
class JacobiValues:
    """``sn, cn, dn`` and ``S = ∫_0^u sn^2/(1 - n sn^2)`` at ``u``; ``u = r + 2K j`` with ``r`` in
    ``[-K, K]`` (where ``cn >= 0``) and ``j`` the ``half_periods``, kept for continuous angles."""

    sn: np.ndarray
    cn: np.ndarray
    dn: np.ndarray
    sn2_integral: np.ndarray
    reduced_sn: np.ndarray  # sn(r) = (-1)^j sn(u)
    reduced_cn: np.ndarray  # cn(r) >= 0
    half_periods: np.ndarray

    @property
    def am(self) -> np.ndarray:
        """The amplitude, continuous: ``am(r) + pi j``."""
        return self.angle(1.0, 1.0)

    def angle(self, a, b) -> np.ndarray:
        """The continuous angle of ``(a cn, b sn)`` (``a, b > 0``) from the angle 0 at ``u = 0``:
        ``atan2(b sn(r), a cn(r)) + pi j`` (``a = b = 1``: the amplitude)."""
        return np.arctan2(b * self.reduced_sn, a * self.reduced_cn) + np.pi * self.half_periods


class JacobiElliptic:
    """Jacobi functions for a fixed parameter given as ``mc = 1 - m`` (``0 <= mc <= 1``), and the
    integral ``S`` for a fixed characteristic ``n <= 0``."""

    #: from this ``mc`` up the functions are trigonometric theta series, below it hyperbolic ones
    TRIGONOMETRIC_MC = 0.5

    def __init__(self, mc: float, n: float = 0.0):
        if not 0.0 <= mc <= 1.0:
            raise ValueError(f"mc: the complementary parameter must lie in [0, 1], got {mc!r}")
        if not n <= 0.0:
            raise ValueError(f"n: the characteristic must be <= 0, got {n!r}")
        self.mc = float(mc)
        self.n = float(n)
        self.k_prime = math.sqrt(self.mc)
        if self.mc > 0.0:
            self.quarter_period, self.sn2_integral_quarter = (float(v) for v in _quarter_period_values(self.mc, self.n))
            self._theta = _ThetaSeries(self.quarter_period, float(elliprf(0.0, 1.0 - self.mc, 1.0)),
                                       self.mc >= self.TRIGONOMETRIC_MC, FLOATS)
        else:
            self.quarter_period = np.inf
            self.sn2_integral_quarter = np.inf

    # -- public ---------------------------------------------------------------------------------
    def __call__(self, u) -> JacobiValues:
        u = np.asarray(u, dtype=float)
        if u.ndim == 0:  # one argument: the values as scalars
            values = self(u.reshape(1))
            return JacobiValues(*(np.asarray(getattr(values, name))[..., 0] for name in JacobiValues.__dataclass_fields__))
        if self.mc == 0.0:
            return self._separatrix(u)
        return self._periodic(u)

    @staticmethod
    def columns(mc: np.ndarray, n: np.ndarray) -> "JacobiElliptic":
        """Many parameters at once (``0 < mc <= 1``, ``n <= 0``, arrays over bodies): every constant a
        column ``(N, 1)``, so that ``u`` of shape ``(N, M)`` gives row ``i`` exactly as
        ``JacobiElliptic(mc[i], n[i])(u[i])`` would (the same elementwise operations)."""
        mc, n = (np.asarray(v, dtype=float)[:, None] for v in (mc, n))
        if not (np.all(mc > 0.0) and np.all(mc <= 1.0) and np.all(n <= 0.0)):
            raise ValueError("columns: only parameters off the separatrix (0 < mc <= 1) and n <= 0")
        trigonometric = bool(mc[0, 0] >= JacobiElliptic.TRIGONOMETRIC_MC) if mc.size else True
        if np.any((mc >= JacobiElliptic.TRIGONOMETRIC_MC) != trigonometric):
            raise ValueError("columns: parameters of one kind only (all mc >= 1/2, or all below)")
        stacked = object.__new__(_Stacked)
        stacked.mc, stacked.n, stacked.k_prime = mc, n, np.sqrt(mc)
        stacked.quarter_period, stacked.sn2_integral_quarter = _quarter_period_values(mc, n)
        stacked._theta = _ThetaSeries(stacked.quarter_period, elliprf(0.0, 1.0 - mc, 1.0), trigonometric, COLUMNS)
        return stacked

    def _periodic(self, u: np.ndarray) -> JacobiValues:
        half_periods = np.round(u / (2.0 * self.quarter_period))
        r = u - (2.0 * self.quarter_period) * half_periods  # in [-K, K]
        s, c, d, integral = self._quarter(np.abs(r))
        s = np.copysign(s, r)
        parity = 1.0 - 2.0 * np.mod(half_periods, 2.0)  # (-1)^j
        return JacobiValues(
            sn=parity * s,
            cn=parity * c,
            dn=d,
            sn2_integral=np.copysign(integral, r) + (2.0 * self.sn2_integral_quarter) * half_periods,
            reduced_sn=s,
            reduced_cn=c,
            half_periods=half_periods,
        )

    def values_at(self, sn: float, cn: float, dn: float) -> JacobiValues:
        """The values at the ``u`` in ``[-K, K]`` where the functions are ``sn``, ``cn >= 0``, ``dn``
        (scalars): ``am`` and ``S`` from them directly, without finding ``u``."""
        return JacobiValues(sn=sn, cn=cn, dn=dn, sn2_integral=float(sn2_integral_from_values(sn, cn, dn, self.n)),
                            reduced_sn=sn, reduced_cn=cn, half_periods=0.0)

    def incomplete_first_kind(self, sn, cn, dn) -> np.ndarray:
        """``u = F(am|m)`` in ``[-K, K]`` from ``sn``, ``cn >= 0``, ``dn`` (inverse of ``__call__``)."""
        sn, cn, dn = (np.asarray(v, dtype=float) for v in (sn, cn, dn))
        return first_kind_from_values(sn, cn, dn)

    # -- internals ------------------------------------------------------------------------------
    def _first_half(self, u: np.ndarray):
        """``sn, cn, dn`` for ``0 <= u <= K/2`` as quotients of theta series (see :class:`_ThetaSeries`)."""
        return self._theta(u)

    def _quarter(self, r: np.ndarray):
        """``sn, cn, dn, S`` for ``0 <= r <= K``."""
        K, mc, n, kp = self.quarter_period, self.mc, self.n, self.k_prime
        first = r <= 0.5 * K
        # First half directly; second half through v = K - r (both evaluated on [0, K/2]).
        w = np.where(first, r, K - r)
        s1, c1, d1 = self._first_half(w)
        s1s, c1s, d1s = s1 * s1, c1 * c1, d1 * d1
        inverse_d1 = 1.0 / d1
        s = np.where(first, s1, c1 * inverse_d1)
        c = np.where(first, c1, (kp * s1) * inverse_d1)
        d = np.where(first, d1, kp * inverse_d1)
        # S on the first half: (1/3) sn^3 R_J(cn^2, dn^2, 1, 1 - n sn^2).
        # On the second half, with v = K - r: sn^2(K - v) / (1 - n sn^2(K - v)) equals
        # (1 - sn^2 v) / ((1 - n)(1 - n' sn^2 v)) for n' = (m - n)/(1 - n), so
        # S(r) = S(K) - [v - (1 - n') S_n'(v)] / (1 - n) with 1 - n' = mc/(1 - n) and
        # 1 - n' sn^2 = cn^2 + mc/(1 - n) sn^2 (no cancellation near sn = 1).
        shifted = mc / (1.0 - n)
        p = np.where(first, 1.0 - n * s1s, c1s + shifted * s1s)
        rj = elliprj(c1s, d1s, 1.0, p) * (s1 * s1s) * (1.0 / 3.0)
        integral_second = (self.sn2_integral_quarter - w / (1.0 - n)) + (shifted / (1.0 - n)) * rj
        return s, c, d, np.where(first, rj, integral_second)

    def _separatrix(self, u: np.ndarray) -> JacobiValues:
        """``m = 1``: ``sn = tanh``, ``cn = dn = sech``, ``am = gd``, and in closed form
        ``S(u) = ∫ tanh^2/(1 - n tanh^2) = [u - atan(sqrt(-n) tanh u) / sqrt(-n)] / (1 - n)``.
        That difference cancels for small ``u`` (``S ~ u^3/3``), so there ``S`` comes from the
        Carlson form used off the separatrix, ``(1/3) tanh^3 R_J(sech^2, sech^2, 1, 1 - n tanh^2)``."""
        a = np.abs(u)
        with np.errstate(under="ignore"):  # sech underflows to its true value 0 far out
            e = np.exp(-a)
            sech = 2.0 * e / (1.0 + e * e)
        tanh = np.tanh(u)
        root = np.sqrt(-self.n)
        bounded = np.arctan(root * tanh) / root if root > 0.0 else tanh
        c2 = sech * sech
        with np.errstate(under="ignore"):
            carlson = tanh**3 * elliprj(c2, c2, 1.0, 1.0 - self.n * tanh * tanh) / 3.0  # inf once sech^2 underflows
        s = np.where(a < 1.0, carlson, (u - bounded) / (1.0 - self.n))
        return JacobiValues(sn=tanh, cn=sech, dn=sech.copy(), sn2_integral=s, reduced_sn=tanh, reduced_cn=sech,
                            half_periods=np.zeros_like(u))


def _quarter_period_values(mc, n):
    """``K`` and ``S(K)`` (floats or arrays, ``mc > 0``)."""
    return elliprf(0.0, mc, 1.0), elliprj(0.0, mc, 1.0, 1.0 - n) / 3.0


def first_kind_from_values(sn, cn, dn, rf=elliprf):
    """``u = F(am|m)`` in ``[-K, K]`` from ``sn``, ``cn >= 0``, ``dn`` (floats or arrays). Taking ``cn^2``
    and ``dn^2`` directly keeps ``u`` accurate next to ``±K``, where ``am`` is ``±pi/2`` to rounding."""
    return sn * rf(cn * cn, dn * dn, 1.0)


def sn2_integral_from_values(sn, cn, dn, n, rj=elliprj):
    """``S(u) = (1/3) sn^3 R_J(cn^2, dn^2, 1, 1 - n sn^2)`` at the ``u`` in ``[-K, K]`` where the
    functions are ``sn``, ``cn >= 0``, ``dn`` (floats or arrays; DLMF 19.25.14)."""
    s2 = sn * sn
    return sn * s2 * rj(cn * cn, dn * dn, 1.0, 1.0 - n * s2) / 3.0


class _Stacked(JacobiElliptic):
    """:meth:`JacobiElliptic.columns`' result: the periodic case only."""

    def __call__(self, u) -> JacobiValues:
        return self._periodic(np.asarray(u, dtype=float))


class _ThetaSeries:
    """``sn, cn, dn`` for ``0 <= u <= K/2`` as quotients of Jacobi theta functions (DLMF 22.2.4),
    ``sn = θ3 θ1(z) / (θ2 θ4(z))``, ``cn = θ4 θ2(z) / (θ2 θ4(z))``, ``dn = θ4 θ3(z) / (θ3 θ4(z))``
    (constants at 0), each series cut after the terms that matter in float64.

    For ``m <= 1/2`` the nome ``q = exp(-pi K'/K)`` is at most ``exp(-pi) = 0.043`` and the theta
    functions of ``z = pi u / (2K)`` are trigonometric series. For ``m > 1/2`` Jacobi's imaginary
    transformation (DLMF 22.6(iv)) writes the same functions with the complementary nome
    ``q' = exp(-pi K/K') <= 0.043`` at the imaginary argument ``i y``, ``y = pi u / (2K')``: hyperbolic
    series, divided through by ``cosh y`` (or ``sinh y``) so that nothing overflows as ``m -> 1``.

    Every series keeps ``q^(j^2+j)`` (odd) and ``q^(j^2)`` (even) for ``j <= 3``; on ``[0, K/2]`` the
    first term left out is below ``1e-19`` of the sum. With ``c = cos 2z`` (or ``cosh 2y``) each
    series divided by its first harmonic is a cubic in ``c``, the same cubic for both kinds:

    * ``A(c) = 1 - q^2 (2c+1) + q^6 (4c^2+2c-1) - q^12 (8c^3+4c^2-4c-1)`` (``θ1`` over ``sin z``, ``sinh y``)
    * ``B(c) = 1 + q^2 (2c-1) + q^6 (4c^2-2c-1) + q^12 (8c^3-4c^2-4c+1)`` (``θ2`` over ``cos z``, ``cosh y``)
    * ``C(c), D(c) = 1 ± 2q c + 2q^4 (2c^2-1) ± 2q^9 (4c^3-3c)`` (``θ3``, ``θ4``)

    so ``sn = (θ3/θ2) sin z A/D``, ``cn = (θ4/θ2) cos z B/D``, ``dn = (θ4/θ3) C/D`` and, hyperbolic,
    ``sn = (θ3/θ4) tanh y A/B``, ``cn = (θ2/θ4) D/(B cosh y)``, ``dn = (θ2/θ3) C/(B cosh y)``. Their
    coefficients (constant factors folded in) are set once; a sample is ``sin`` and ``cos`` (or
    ``sinh``, ``cosh``, ``tanh``) and four Horner cubics, whose terms fall off fast enough that none
    cancels: ``sn`` is a sine or ``tanh`` times a positive quotient and ``cn``, ``dn`` are quotients of
    sums without cancellation, so all three keep relative precision next to ``u = 0`` and next to the
    separatrix. A fixed count, and powers of ``q`` by products, keep each value the same whatever
    else is evaluated with it.

    Works on one parameter (floats) or on columns of parameters of one kind (``trigonometric`` the
    same for every column)."""

    def __init__(self, K, K_complementary, trigonometric: bool, ops):
        self.trigonometric = trigonometric
        ratio = K_complementary / K if trigonometric else K / K_complementary
        self.scale = (0.5 * math.pi) / (K if trigonometric else K_complementary)  # u -> z or y
        q = ops.exp(-math.pi * ratio)  # the same value for one parameter and for columns
        q2 = q * q
        q4 = q2 * q2
        q6, q9, q12 = q4 * q2, q4 * q4 * q, q4 * q4 * q4
        t2 = ((1.0 + q2) + q6) + q12  # theta_2(0) / (2 q^(1/4))
        t3 = 1.0 + 2.0 * ((q + q4) + q9)
        t4 = 1.0 + 2.0 * ((q4 - q) - q9)
        a = (((1.0 - q2) - q6) + q12, (2.0 * q6 - 2.0 * q2) + 4.0 * q12, 4.0 * q6 - 4.0 * q12, -8.0 * q12)
        b = (((1.0 - q2) - q6) + q12, (2.0 * q2 - 2.0 * q6) - 4.0 * q12, 4.0 * q6 - 4.0 * q12, 8.0 * q12)
        c = (1.0 - 2.0 * q4, 2.0 * q - 6.0 * q9, 4.0 * q4, 8.0 * q9)
        d = (1.0 - 2.0 * q4, 6.0 * q9 - 2.0 * q, 4.0 * q4, -8.0 * q9)
        if trigonometric:  # sn = s A/D, cn = cos B/D, dn = C/D with the constants in A, B, C
            factors = (t3 / t2, t4 / t2, t4 / t3, 1.0)
        else:  # sn = tanh A/B, cn = D/(B cosh), dn = C/(B cosh)
            factors = (t3 / t4, 1.0, t2 / t3, t2 / t4)
        # coefficient k of the four cubics stacked, (4, 1) or (4, N, 1): one Horner pass for all four
        coefficients = np.array([[factor * cubic[k] for factor, cubic in zip(factors, (a, b, c, d))] for k in range(4)])
        self.cubics = tuple(coefficients[:, :, None] if coefficients.ndim == 2 else coefficients)

    def __call__(self, u):
        with np.errstate(under="ignore"):  # far terms of a tiny nome: their true value is below rounding
            return self._series(self.scale * u)

    def _series(self, x):
        if self.trigonometric:
            first_sin, first_cos = np.sin(x), np.cos(x)
            c = 1.0 - 2.0 * (first_sin * first_sin)  # cos 2z
        else:
            first_cos = np.cosh(x)
            first_sin = np.tanh(x)
            c = 2.0 * (first_cos * first_cos) - 1.0  # cosh 2y (>= 1: no cancellation)
        k0, k1, k2, k3 = self.cubics
        A, B, C, D = ((k3 * c + k2) * c + k1) * c + k0
        if self.trigonometric:
            inverse = 1.0 / D
            return first_sin * A * inverse, first_cos * B * inverse, C * inverse
        inverse = 1.0 / B
        over_cosh = inverse / first_cos
        return first_sin * A * inverse, D * over_cosh, C * over_cosh
