"""Jacobi elliptic functions and one elliptic integral of the third kind, parametrised by the
**complementary** parameter ``mc = 1 - m``.

Why not ``scipy.special.ellipj``: it takes ``m``, and next to the separatrix of the free rigid body
``m`` rounds to 1 and ``mc`` (what sets the period ``K ~ log(4/sqrt(mc))``) is lost. Near the turning
points ``cn`` and ``dn`` are tiny, and the attitude integral needs them to *relative* precision.

The method (after Fukushima's use of the complementary parameter, built on Carlson's symmetric
integrals from ``scipy.special``):

* reduce ``u`` to ``r`` in ``[0, K]`` with the half-period ``2K`` symmetries;
* on ``[0, K/2]`` solve ``F(am(u)|m) = u`` by Newton's method in the hyperbolic variable ``x`` with
  ``sn = tanh x``, ``cn = sech x``, so ``cn`` and ``dn = sqrt(cn^2 + mc sn^2)`` keep relative precision
  (``F(phi|m) = sin(phi) R_F(cos^2 phi, 1 - m sin^2 phi, 1)``, DLMF 19.25.5);
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
from scipy.special import ellipj, elliprf, elliprj

# Newton steps from scipy's (m-parametrised) guess. Against mpmath the guess is within 2e-10 (relative,
# in x) at worst, where m rounds to 1; one step reaches rounding level and the second is margin.
# A fixed count keeps every sample independent of the others in its batch (bit-identical results).
_NEWTON_STEPS = 2


@dataclass(frozen=True)
class JacobiValues:
    """``sn, cn, dn``, the amplitude ``am`` and ``S = ∫_0^u sn^2/(1 - n sn^2)`` (both continuous)."""

    sn: np.ndarray
    cn: np.ndarray
    dn: np.ndarray
    am: np.ndarray
    sn2_integral: np.ndarray


class JacobiElliptic:
    """Jacobi functions for a fixed parameter given as ``mc = 1 - m`` (``0 <= mc <= 1``), and the
    integral ``S`` for a fixed characteristic ``n <= 0``."""

    def __init__(self, mc: float, n: float = 0.0):
        if not 0.0 <= mc <= 1.0:
            raise ValueError(f"mc: the complementary parameter must lie in [0, 1], got {mc!r}")
        if not n <= 0.0:
            raise ValueError(f"n: the characteristic must be <= 0, got {n!r}")
        self.mc = float(mc)
        self.m = 1.0 - self.mc  # only for scipy's initial guess; never used where mc matters
        self.n = float(n)
        self.k_prime = float(np.sqrt(self.mc))
        if self.mc > 0.0:
            self.quarter_period = float(elliprf(0.0, self.mc, 1.0))
            self.sn2_integral_quarter = float(elliprj(0.0, self.mc, 1.0, 1.0 - self.n)) / 3.0  # S(K)
        else:
            self.quarter_period = np.inf
            self.sn2_integral_quarter = np.inf

    # -- public ---------------------------------------------------------------------------------
    def __call__(self, u) -> JacobiValues:
        u = np.asarray(u, dtype=float)
        if self.mc == 0.0:
            return self._separatrix(u)
        return self._periodic(u)

    @staticmethod
    def stack(jacobis) -> "JacobiElliptic":
        """Many parameters at once (``mc > 0`` each): every constant a column ``(N, 1)``, so that
        ``u`` of shape ``(N, M)`` gives row ``i`` exactly as ``jacobis[i](u[i])`` would (the same
        elementwise operations)."""
        stacked = object.__new__(_Stacked)
        for name in ("mc", "m", "n", "k_prime", "quarter_period", "sn2_integral_quarter"):
            setattr(stacked, name, np.array([[getattr(j, name)] for j in jacobis], dtype=float))
        if not np.all(stacked.mc > 0.0):
            raise ValueError("stack: only parameters off the separatrix (mc > 0)")
        return stacked

    def _periodic(self, u: np.ndarray) -> JacobiValues:
        half_periods = np.round(u / (2.0 * self.quarter_period))
        r = u - (2.0 * self.quarter_period) * half_periods  # in [-K, K]
        s, c, d, am, integral = self._quarter(np.abs(r))
        parity = 1.0 - 2.0 * np.mod(half_periods, 2.0)  # (-1)^j
        return JacobiValues(
            sn=parity * np.copysign(s, r),
            cn=parity * c,
            dn=d,
            am=np.copysign(am, r) + np.pi * half_periods,
            sn2_integral=np.copysign(integral, r) + (2.0 * self.sn2_integral_quarter) * half_periods,
        )

    def values_at(self, sn: float, cn: float, dn: float) -> JacobiValues:
        """The values at the ``u`` in ``[-K, K]`` where the functions are ``sn``, ``cn >= 0``, ``dn``
        (scalars): ``am`` and ``S`` from them directly, without finding ``u``."""
        s2 = sn * sn
        integral = sn * s2 * float(elliprj(cn * cn, dn * dn, 1.0, 1.0 - self.n * s2)) / 3.0
        return JacobiValues(sn=sn, cn=cn, dn=dn, am=math.atan2(sn, cn), sn2_integral=integral)

    def incomplete_first_kind(self, sn, cn, dn) -> np.ndarray:
        """``u = F(am|m)`` in ``[-K, K]`` from ``sn``, ``cn >= 0``, ``dn`` (inverse of ``__call__``).

        Taking ``cn^2`` and ``dn^2`` directly keeps ``u`` accurate next to ``±K`` where ``am`` is
        ``±pi/2`` to within rounding.
        """
        sn, cn, dn = (np.asarray(v, dtype=float) for v in (sn, cn, dn))
        return sn * elliprf(cn * cn, dn * dn, 1.0)

    # -- internals ------------------------------------------------------------------------------
    def _first_half(self, u: np.ndarray):
        """``sn, cn`` and their squares and ``dn^2`` for ``0 <= u <= K/2``, by Newton's method on
        ``F(am) = u`` in ``x = asinh(tan(am))``, where ``sn = tanh x`` and ``cn = sech x``."""
        _, _, _, phi = ellipj(u, self.m)
        x = np.arcsinh(np.tan(phi))
        mc = self.mc
        for _ in range(_NEWTON_STEPS):
            ch = np.cosh(x)
            t = np.tanh(x)
            c2 = 1.0 / (ch * ch)
            d2 = c2 + mc * (t * t)
            # dF/dx = sech(x) / dn, so the Newton step is (F - u) * dn * cosh(x)
            x -= (t * elliprf(c2, d2, 1.0) - u) * (np.sqrt(d2) * ch)
        s = np.tanh(x)
        c = 1.0 / np.cosh(x)
        s2, c2 = s * s, c * c
        return s, c, s2, c2, c2 + mc * s2

    def _quarter(self, r: np.ndarray):
        """``sn, cn, dn, am, S`` for ``0 <= r <= K``."""
        K, mc, n, kp = self.quarter_period, self.mc, self.n, self.k_prime
        first = r <= 0.5 * K
        # First half directly; second half through v = K - r (both evaluated on [0, K/2]).
        w = np.where(first, r, K - r)
        s1, c1, s1s, c1s, d1s = self._first_half(w)
        d1 = np.sqrt(d1s)
        inverse_d1 = 1.0 / d1
        s = np.where(first, s1, c1 * inverse_d1)
        c = np.where(first, c1, (kp * s1) * inverse_d1)
        d = np.where(first, d1, kp * inverse_d1)
        am = np.arctan2(s, c)
        # S on the first half: (1/3) sn^3 R_J(cn^2, dn^2, 1, 1 - n sn^2).
        # On the second half, with v = K - r: sn^2(K - v) / (1 - n sn^2(K - v)) equals
        # (1 - sn^2 v) / ((1 - n)(1 - n' sn^2 v)) for n' = (m - n)/(1 - n), so
        # S(r) = S(K) - [v - (1 - n') S_n'(v)] / (1 - n) with 1 - n' = mc/(1 - n) and
        # 1 - n' sn^2 = cn^2 + mc/(1 - n) sn^2 (no cancellation near sn = 1).
        shifted = mc / (1.0 - n)
        p = np.where(first, 1.0 - n * s1s, c1s + shifted * s1s)
        rj = elliprj(c1s, d1s, 1.0, p) * (s1 * s1s) * (1.0 / 3.0)
        integral_second = (self.sn2_integral_quarter - w / (1.0 - n)) + (shifted / (1.0 - n)) * rj
        return s, c, d, am, np.where(first, rj, integral_second)

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
        return JacobiValues(sn=tanh, cn=sech, dn=sech.copy(), am=np.arctan2(tanh, sech), sn2_integral=s)


class _Stacked(JacobiElliptic):
    """:meth:`JacobiElliptic.stack`'s result: the periodic case only."""

    def __call__(self, u) -> JacobiValues:
        return self._periodic(np.asarray(u, dtype=float))
