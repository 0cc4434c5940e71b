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
Jacobi elliptic functions and one elliptic integral of the third kind, in ``mc = 1 - m``.

Both are parametrised by the **complementary** parameter ``mc = 1 - m``.

Why not ``scipy.special.ellipj``: it takes ``m``, and next to the separatrix of the free rigid body
``m`` rounds to 1 and ``mc`` (what sets the period ``K ~ log(4/sqrt(mc))``) is lost. Near the
turning points ``cn`` and ``dn`` are tiny, and the attitude integral needs them to *relative*
precision.

The method (periods and integrals from Carlson's symmetric forms in ``scipy.special``):

* reduce ``u`` to ``r`` in ``[0, K]`` with the half-period ``2K`` symmetries;
* on ``[0, K/2]`` evaluate ``sn, cn, dn`` as quotients of theta series in the nome of ``m``
  (``m <= 1/2``) or, by Jacobi's imaginary transformation, of the complementary parameter
  (``m > 1/2``): each nome is at most ``exp(-pi)``, a few terms reach float64, and ``cn``, ``dn``
  keep relative precision (:class:`_ThetaSeries`);
* on ``[K/2, K]`` use ``v = K - u``: ``sn = cd(v)``, ``cn = k' sd(v)``, ``dn = k' nd(v)`` (DLMF
  22.4.3);
* except when ``S`` is not asked for and ``m <= 1/2``: the trigonometric series hold for every real
  argument, so they are evaluated on the whole half-period ``[-K, K]`` at once, without the two
  halves' selections (a call's fixed cost is its count of array operations).

The attitude about the angular momentum needs ``Π(n; am u | m) = u + n S(u)`` (``n <= 0``) with
``S(u) = ∫_0^u sn^2/(1 - n sn^2) du' = (1/3) sn^3 R_J(cn^2, dn^2, 1, 1 - n sn^2)`` (DLMF 19.25.14).
``S`` itself is returned, not ``Π``: the attitude uses ``n S`` beside terms that would cancel
against ``u``. On the second half of the quarter period ``S`` comes from the same identity in
``v = K - u`` (``sn(K - v) = cd(v)``), so nothing cancels. On the separatrix (``mc = 0``)
everything is hyperbolic and in closed form.

The attitude only needs ``n S`` to absolute precision, beside a linear term, and there a cheaper
form serves (Jacobi's form of the third kind, Whittaker & Watson §22.74, taken to an imaginary
shift): with ``n = -m sc^2(b|mc)``, ``z = pi u/(2K)`` and ``beta = pi b/(2K)``,
``n S(u) = n (S(K)/K) u + w arg θ4(z + i beta)``, ``w = sqrt(-n/((m - n)(1 - n)))``. The *theta
phase* ``arg θ4(z + i beta)`` is periodic and takes a few more terms of the same series as
``sn, cn, dn`` and one ``atan2`` a sample, where ``R_J`` costs more than everything else together
(:class:`_ThetaPhase`).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
from scipy.special import elliprf, elliprj

from ..numerics.ops import COLUMNS, FLOATS


class JacobiValues(NamedTuple):
    """
    ``sn, cn, dn`` at ``u``, with ``S`` and the theta phase when asked for.

    ``S = ∫_0^u sn^2/(1 - n sn^2)`` and the theta phase are ``None`` when not asked for;
    ``u = r + 2K j`` with ``r`` in ``[-K, K]`` (where ``cn >= 0``) and ``j`` the ``half_periods``,
    kept for continuous angles.
    """

    sn: np.ndarray
    cn: np.ndarray
    dn: np.ndarray
    sn2_integral: np.ndarray | None
    reduced_sn: np.ndarray  # sn(r) = (-1)^j sn(u)
    reduced_cn: np.ndarray  # cn(r) >= 0
    half_periods: np.ndarray
    #: the theta phase (n S(u) = n slope u + weight * phase, see JacobiElliptic) as ``(re, im,
    #: linear)``: ``atan2(im, re) + linear`` with ``re > 0`` (``linear`` None: 0)
    phase_parts: tuple | None = None

    @property
    def theta_phase(self) -> np.ndarray:
        re, im, linear = self.phase_parts
        phase = np.arctan2(im, re)
        return phase if linear is None else phase + linear

    def phase_minus_angle(self, a, b) -> np.ndarray:
        """
        Return ``theta_phase - angle(a, b)`` by one ``atan2``.

        Both ``atan2`` terms lie within ``pi/2`` of 0 (``re > 0``, ``cn(r) >= 0``), so their
        difference is the argument of one product, unwrapped.
        """
        re, im, linear = self.phase_parts
        x, y = a * self.reduced_cn, b * self.reduced_sn
        difference = np.arctan2(im * x - re * y, re * x + im * y) - _PI * self.half_periods
        return difference if linear is None else difference + linear

    @property
    def am(self) -> np.ndarray:
        """
        Return the amplitude, continuous over half periods.

        ``am(r) + pi j``.
        """
        return self.angle(1.0, 1.0)

    def angle(self, a, b) -> np.ndarray:
        """
        Return the continuous angle of ``(a cn, b sn)`` (``a, b > 0``), 0 at ``u = 0``.

        ``atan2(b sn(r), a cn(r)) + pi j`` (``a = b = 1``: the amplitude).
        """
        return np.arctan2(b * self.reduced_sn, a * self.reduced_cn) + np.pi * self.half_periods


class JacobiElliptic:
    """
    Jacobi functions for a fixed parameter, ``S`` for a fixed characteristic, and the theta phase.

    The parameter is given as ``mc = 1 - m`` (``0 <= mc <= 1``; pass ``m`` too when it is known to
    more relative precision than ``1 - mc``), the characteristic is ``n <= 0``, and the theta phase
    gives ``n S(u) = n * sn2_integral_slope * u + phase_weight * phase``.
    """

    #: from this ``mc`` up the functions are trigonometric theta series, below it hyperbolic ones
    TRIGONOMETRIC_MC = 0.5

    def __init__(self, mc: float, n: float = 0.0, m: float | None = None):
        if not 0.0 <= mc <= 1.0:
            raise ValueError(f'mc: the complementary parameter must lie in [0, 1], got {mc!r}')
        if not n <= 0.0:
            raise ValueError(f'n: the characteristic must be <= 0, got {n!r}')
        if m is not None and not 0.0 <= m <= 1.0:
            raise ValueError(f'm: the parameter must lie in [0, 1], got {m!r}')
        mc, n = float(mc), float(n)
        m = 1.0 - mc if m is None else float(m)
        if mc > 0.0:
            self._set_constants(FLOATS, mc, n, m, mc >= self.TRIGONOMETRIC_MC)
        else:
            self.mc, self.n, self.m, self.k_prime = mc, n, m, 0.0
            self._theta = None  # closed forms on the separatrix
            self.phase_weight = _phase_weight(FLOATS, m, n)
            self.quarter_period = np.inf
            self.sn2_integral_quarter = np.inf
            # S(u) ~ u / (1 - n) far out on the separatrix
            self.sn2_integral_slope = 1.0 / (1.0 - self.n)

    # -- public ---------------------------------------------------------------------------------
    def __call__(self, u, *, integral: bool = True, phase: bool = False) -> JacobiValues:
        """
        Return the values at ``u``.

        ``S`` (to relative precision) unless ``integral`` is false, the theta phase if ``phase``.
        """
        u = np.asarray(u, dtype=float)
        if u.ndim == 0:  # one argument: the values as scalars
            values = self(u.reshape(1), integral=integral, phase=phase)
            return JacobiValues(
                *(_first_element(getattr(values, name)) for name in JacobiValues._fields)
            )
        if self.mc == 0.0:
            return self._separatrix(u, integral, phase)
        return self._periodic(u, integral, phase)

    @staticmethod
    def columns(mc: np.ndarray, n: np.ndarray, m: np.ndarray | None = None) -> 'JacobiElliptic':
        """
        Build the functions of many parameters at once (arrays ``(N,)`` over bodies).

        Parameters ``0 < mc <= 1`` and ``n <= 0``; every constant is an array over bodies, so that
        ``u`` of shape ``(M, N)`` gives column ``i`` exactly as
        ``JacobiElliptic(mc[i], n[i], m[i])(u[:, i])`` would (the same elementwise operations;
        bodies along the contiguous axis, so that numpy's loops run over them whatever ``M`` is).
        """
        mc, n = (np.asarray(v, dtype=float) for v in (mc, n))
        m = 1.0 - mc if m is None else np.asarray(m, dtype=float)
        if not (
            np.all(mc > 0.0)
            and np.all(mc <= 1.0)
            and np.all(n <= 0.0)
            and np.all((m >= 0.0) & (m <= 1.0))
        ):
            raise ValueError(
                'columns: only parameters off the separatrix (0 < mc <= 1, 0 <= m <= 1) and n <= 0'
            )
        trigonometric = bool(mc[0] >= JacobiElliptic.TRIGONOMETRIC_MC) if mc.size else True
        if np.any((mc >= JacobiElliptic.TRIGONOMETRIC_MC) != trigonometric):
            raise ValueError('columns: parameters of one kind only (all mc >= 1/2, or all below)')
        stacked = object.__new__(_Stacked)
        stacked._set_constants(COLUMNS, mc, n, m, trigonometric)
        return stacked

    def _set_constants(self, ops, mc, n, m, trigonometric: bool) -> None:
        """
        Set every constant off the separatrix (``mc > 0``).

        By the same operations for one parameter (floats) and for arrays over bodies.
        """
        self.mc, self.n, self.m, self.k_prime = mc, n, m, ops.sqrt(mc)
        self.phase_weight = _phase_weight(ops, m, n)
        self.quarter_period = ops.elliprf(0.0, mc, 1.0)
        self.sn2_integral_quarter = ops.elliprj(0.0, mc, 1.0, 1.0 - n) / 3.0  # S(K)
        self.sn2_integral_slope = self.sn2_integral_quarter / self.quarter_period
        K_complementary = ops.elliprf(0.0, m, 1.0)
        phase = _ThetaPhase(ops, self.quarter_period, K_complementary, m, n, trigonometric)
        self._theta = _ThetaSeries(self.quarter_period, K_complementary, trigonometric, ops, phase)
        # what a call computes with, as numpy values (0-d for one parameter): numpy converts a
        # Python float operand again on every operation, a third of a small operation's cost
        K = self.quarter_period
        self._K, self._k_prime = np.asarray(K), np.asarray(self.k_prime)
        self._half_K, self._period, self._per_period = (
            np.asarray(0.5 * K),
            np.asarray(2.0 * K),
            np.asarray(0.5 / K),
        )

    def _periodic(self, u: np.ndarray, integral: bool, phase: bool) -> JacobiValues:
        # far terms of a tiny nome, and powers of tiny arguments, underflow: their true values are
        # below rounding
        with np.errstate(under='ignore'):
            functions = self._whole_half_period if self._theta.trigonometric else self._two_halves
            if not integral:
                return functions(u, phase)
            # S's R_J form, on the two halves of the quarter period
            values = self._with_integral(u)
            return values._replace(phase_parts=functions(u, True).phase_parts) if phase else values

    def _whole_half_period(self, u: np.ndarray, phase: bool) -> JacobiValues:
        """
        Evaluate for ``m <= 1/2``, without ``S``, on the whole half-period at once.

        The trigonometric series hold for every real ``z`` (see :class:`_ThetaSeries`), so ``u`` is
        reduced by ``2K`` to ``r = u - 2K j``, ``z_r = pi r/(2K)`` in ``[-pi/2, pi/2]``, and the
        functions come from it directly: ``sn(r) = sin z_r A/D``, ``cn(r) = cos z_r B/D >= 0``,
        ``dn = C/D``, cubics in ``s = sin^2 z_r``; no selection between two halves, which makes a
        call fewer array operations. The theta phase is
        ``θ4(i beta) + s P(s) + i sin z_r cos z_r Q(s)`` (:class:`_ThetaPhase`).
        """
        series = self._theta
        half_periods, r = self._reduce(u)
        # (z = pi u/(2K) scaled first would add a rounding of its size to every sample)
        reduced = series.scale * r
        sine, cosine = np.sin(reduced), np.cos(reduced)
        s = sine * sine
        k0, k1, k2, k3 = series.phased_cubics if phase else series.cubics
        values = ((k3 * s + k2) * s + k1) * s + k0
        quotients = values[:3] * np.reciprocal(values[3])
        reduced_sn, reduced_cn = quotients[0] * sine, quotients[1] * cosine
        parity = _parity(half_periods)
        return JacobiValues(
            sn=parity * reduced_sn,
            cn=parity * reduced_cn,
            dn=quotients[2],
            sn2_integral=None,
            reduced_sn=reduced_sn,
            reduced_cn=reduced_cn,
            half_periods=half_periods,
            phase_parts=(series.phase.base + s * values[4], (sine * cosine) * values[5], None)
            if phase
            else None,
        )

    def _two_halves(self, u: np.ndarray, phase: bool) -> JacobiValues:
        """
        Evaluate for ``m > 1/2``, without ``S``: the hyperbolic series on ``[0, K/2]``.

        The series are evaluated at ``w = |r|`` on the first half of the quarter period and at
        ``w = K - |r|`` on the second, each half's three functions one numerator over one
        denominator (``sh = sinh y``, ``ch = cosh y``): ``(sh A, D, C) / (ch B)`` on the first
        (``sn = tanh A/B``, ``cn = D/(ch B)``, ``dn = C/(ch B)``), ``(D, k' sh A, k' ch B) / C`` on
        the second (``sn = cd(w)``, ``cn = k' sd(w)``, ``dn = k' nd(w)``). The theta phase from the
        same variables (:class:`_ThetaPhase`: ``arg θ2(gamma - i y) - kappa w`` on the first half,
        ``kappa w - arg θ3(gamma - i y)`` on the second), odd in ``r``.
        """
        series = self._theta
        half_periods, r = self._reduce(u)
        first, w = self._fold(np.abs(r))
        y = series.scale * w
        ch, th = np.cosh(y), np.tanh(y)
        ch2 = ch * ch
        c = _TWO * ch2 - _ONE  # cosh 2y
        k0, k1, k2, k3 = series.phased_cubics if phase else series.cubics
        values = ((k3 * c + k2) * c + k1) * c + k0
        A, B, C, D = values[:4]
        sh_A, ch_B = (th * ch) * A, ch * B
        inverse = np.reciprocal(np.where(first, ch_B, C))
        reduced_sn = np.copysign(np.where(first, sh_A, D) * inverse, r)
        reduced_cn = np.where(first, D, self._k_prime * sh_A) * inverse
        parity = _parity(half_periods)
        phase_parts = None
        if phase:
            re_first, im_first, re_second, im_second = values[4:]
            phase_parts = (
                np.where(first, re_first, re_second),
                np.copysign(th, r) * np.where(first, im_first, ch2 * im_second),
                np.where(first, series.phase.first_half_kappa, series.phase.kappa)
                * np.copysign(w, r),
            )
        return JacobiValues(
            sn=parity * reduced_sn,
            cn=parity * reduced_cn,
            dn=np.where(first, C, self._k_prime * ch_B) * inverse,
            sn2_integral=None,
            reduced_sn=reduced_sn,
            reduced_cn=reduced_cn,
            half_periods=half_periods,
            phase_parts=phase_parts,
        )

    def _with_integral(self, u: np.ndarray) -> JacobiValues:
        half_periods, r = self._reduce(u)
        s, c, d, quarter_integral = self._quarter(np.abs(r))
        s = np.copysign(s, r)
        parity = _parity(half_periods)
        return JacobiValues(
            sn=parity * s,
            cn=parity * c,
            dn=d,
            sn2_integral=np.copysign(quarter_integral, r)
            + (2.0 * self.sn2_integral_quarter) * half_periods,
            reduced_sn=s,
            reduced_cn=c,
            half_periods=half_periods,
        )

    def values_at(self, sn: float, cn: float, dn: float) -> JacobiValues:
        """
        Return the values at the ``u`` in ``[-K, K]`` where the functions have the given values.

        The functions are ``sn``, ``cn >= 0``, ``dn`` (scalars): ``am`` and ``S`` from them
        directly, without finding ``u``.
        """
        return JacobiValues(
            sn=sn,
            cn=cn,
            dn=dn,
            sn2_integral=float(sn2_integral_from_values(sn, cn, dn, self.n)),
            reduced_sn=sn,
            reduced_cn=cn,
            half_periods=0.0,
        )

    def incomplete_first_kind(self, sn, cn, dn) -> np.ndarray:
        """
        Return ``u = F(am|m)`` in ``[-K, K]`` from ``sn``, ``cn >= 0``, ``dn``.

        The inverse of ``__call__``.
        """
        sn, cn, dn = (np.asarray(v, dtype=float) for v in (sn, cn, dn))
        return first_kind_from_values(sn, cn, dn)

    # -- internals ------------------------------------------------------------------------------
    def _reduce(self, u: np.ndarray):
        """
        Return ``(j, r)`` with ``u = r + 2K j``, ``r`` in ``[-K, K]``.

        Exact next to a multiple of ``2K``.
        """
        half_periods = np.rint(u * self._per_period)
        return half_periods, u - self._period * half_periods

    def _fold(self, r: np.ndarray):
        """
        Fold ``0 <= r <= K`` onto ``[0, K/2]``, where the series are evaluated.

        Return ``(first, w)``: ``w = r`` on the first half of the quarter period, ``K - r`` on the
        second.
        """
        first = r <= self._half_K
        return first, np.where(first, r, self._K - r)

    def _quarter(self, r: np.ndarray):
        """``sn, cn, dn`` and ``S`` for ``0 <= r <= K``."""
        mc, n, kp = self.mc, self.n, self.k_prime
        # second half through v = K - r: sn = cd(v), cn = k' sd(v), dn = k' nd(v)
        first, w = self._fold(r)
        s1, c1, d1 = self._theta(w)
        inverse_d1 = 1.0 / d1
        s = np.where(first, s1, c1 * inverse_d1)
        c = np.where(first, c1, (kp * s1) * inverse_d1)
        d = np.where(first, d1, kp * inverse_d1)
        # S on the first half: (1/3) sn^3 R_J(cn^2, dn^2, 1, 1 - n sn^2).
        # On the second half, with v = K - r: sn^2(K - v) / (1 - n sn^2(K - v)) equals
        # (1 - sn^2 v) / ((1 - n)(1 - n' sn^2 v)) for n' = (m - n)/(1 - n), so
        # S(r) = S(K) - [v - (1 - n') S_n'(v)] / (1 - n) with 1 - n' = mc/(1 - n) and
        # 1 - n' sn^2 = cn^2 + mc/(1 - n) sn^2 (no cancellation near sn = 1).
        s1s, c1s, d1s = s1 * s1, c1 * c1, d1 * d1
        shifted = mc / (1.0 - n)
        p = np.where(first, 1.0 - n * s1s, c1s + shifted * s1s)
        rj = elliprj(c1s, d1s, 1.0, p) * (s1 * s1s) * (1.0 / 3.0)
        integral_second = (self.sn2_integral_quarter - w / (1.0 - n)) + (shifted / (1.0 - n)) * rj
        return s, c, d, np.where(first, rj, integral_second)

    def _separatrix(self, u: np.ndarray, integral: bool, phase: bool) -> JacobiValues:
        """
        Evaluate on the separatrix, ``m = 1``.

        ``sn = tanh``, ``cn = dn = sech``, ``am = gd``, and in closed form
        ``S(u) = ∫ tanh^2/(1 - n tanh^2) = [u - atan(sqrt(-n) tanh u) / sqrt(-n)] / (1 - n)`` (the
        theta phase is that arctangent). The difference cancels for small ``u`` (``S ~ u^3/3``), so
        there ``S`` comes from the Carlson form used off the separatrix,
        ``(1/3) tanh^3 R_J(sech^2, sech^2, 1, 1 - n tanh^2)``.
        """
        a = np.abs(u)
        with np.errstate(under='ignore'):  # sech underflows to its true value 0 far out
            e = np.exp(-a)
            sech = 2.0 * e / (1.0 + e * e)
        tanh = np.tanh(u)
        root = np.sqrt(-self.n)
        s = None
        if integral:
            bounded = np.arctan(root * tanh) / root if root > 0.0 else tanh
            c2 = sech * sech
            with np.errstate(under='ignore'):
                # inf once sech^2 underflows
                carlson = tanh**3 * elliprj(c2, c2, 1.0, 1.0 - self.n * tanh * tanh) / 3.0
            s = np.where(a < 1.0, carlson, (u - bounded) / (1.0 - self.n))
        return JacobiValues(
            sn=tanh,
            cn=sech,
            dn=sech.copy(),
            sn2_integral=s,
            reduced_sn=tanh,
            reduced_cn=sech,
            half_periods=np.zeros_like(u),
            phase_parts=(1.0, root * tanh, None) if phase else None,
        )


# (numpy values: see _set_constants)
_ONE, _TWO, _PI = np.array(1.0), np.array(2.0), np.array(math.pi)


def _parity(half_periods: np.ndarray) -> np.ndarray:
    """``(-1)^j``."""
    return _ONE - _TWO * np.mod(half_periods, _TWO)


def _first_element(value):
    """
    Return one argument's value from a batch of one.

    Tuples element by element, constants as they are.
    """
    if value is None or isinstance(value, float):
        return value
    if isinstance(value, tuple):
        return tuple(_first_element(v) for v in value)
    return np.asarray(value)[..., 0]


def first_kind_from_values(sn, cn, dn, rf=elliprf):
    """
    Return ``u = F(am|m)`` in ``[-K, K]`` from ``sn``, ``cn >= 0``, ``dn``.

    Floats or arrays. Taking ``cn^2`` and ``dn^2`` directly keeps ``u`` accurate next to ``±K``,
    where ``am`` is ``±pi/2`` to rounding.
    """
    return sn * rf(cn * cn, dn * dn, 1.0)


def sn2_integral_from_values(sn, cn, dn, n, rj=elliprj):
    """
    Return ``S(u) = (1/3) sn^3 R_J(cn^2, dn^2, 1, 1 - n sn^2)`` from the functions' values.

    At the ``u`` in ``[-K, K]`` where the functions are ``sn``, ``cn >= 0``, ``dn`` (floats or
    arrays; DLMF 19.25.14).
    """
    s2 = sn * sn
    return sn * s2 * rj(cn * cn, dn * dn, 1.0, 1.0 - n * s2) / 3.0


class _Stacked(JacobiElliptic):
    """:meth:`JacobiElliptic.columns`' result: the periodic case only."""

    def __call__(self, u, *, integral: bool = True, phase: bool = False) -> JacobiValues:
        return self._periodic(np.asarray(u, dtype=float), integral, phase)


class _ThetaSeries:
    """
    ``sn, cn, dn`` for ``0 <= u <= K/2`` as quotients of Jacobi theta functions (DLMF 22.2.4).

    ``sn = θ3 θ1(z) / (θ2 θ4(z))``, ``cn = θ4 θ2(z) / (θ2 θ4(z))``, ``dn = θ4 θ3(z) / (θ3 θ4(z))``
    (constants at 0), each series cut after the terms that matter in float64.

    For ``m <= 1/2`` the nome ``q = exp(-pi K'/K)`` is at most ``exp(-pi) = 0.043`` and the theta
    functions of ``z = pi u / (2K)`` are trigonometric series. For ``m > 1/2`` Jacobi's imaginary
    transformation (DLMF 22.6(iv)) writes the same functions with the complementary nome
    ``q' = exp(-pi K/K') <= 0.043`` at the imaginary argument ``i y``, ``y = pi u / (2K')``:
    hyperbolic series, divided through by ``cosh y`` (or ``sinh y``) so that nothing overflows as
    ``m -> 1``.

    Every series keeps ``q^(j^2+j)`` (odd) and ``q^(j^2)`` (even) for ``j <= 3``; on ``[0, K/2]``
    the first term left out is below ``1e-19`` of the sum (trigonometric: for every real ``z``,
    each term being at most ``q^(j^2)``). With ``c = cos 2z`` (or ``cosh 2y``) each series divided
    by its first harmonic is a cubic in ``c``, the same cubic for both kinds:

    * ``A(c) = 1 - q^2 (2c+1) + q^6 (4c^2+2c-1) - q^12 (8c^3+4c^2-4c-1)`` (``θ1`` over ``sin z``,
      ``sinh y``)
    * ``B(c) = 1 + q^2 (2c-1) + q^6 (4c^2-2c-1) + q^12 (8c^3-4c^2-4c+1)`` (``θ2`` over ``cos z``,
      ``cosh y``)
    * ``C(c), D(c) = 1 ± 2q c + 2q^4 (2c^2-1) ± 2q^9 (4c^3-3c)`` (``θ3``, ``θ4``)

    so ``sn = (θ3/θ2) sin z A/D``, ``cn = (θ4/θ2) cos z B/D``, ``dn = (θ4/θ3) C/D`` and,
    hyperbolic, ``sn = (θ3/θ4) tanh y A/B``, ``cn = (θ2/θ4) D/(B cosh y)``,
    ``dn = (θ2/θ3) C/(B cosh y)``. Their coefficients (constant factors folded in) are set once; a
    sample is ``sin`` and ``cos`` (or ``sinh``, ``cosh``, ``tanh``) and four Horner cubics, whose
    terms fall off fast enough that none cancels: ``sn`` is a sine or ``tanh`` times a positive
    quotient and ``cn``, ``dn`` are quotients of sums without cancellation, so all three keep
    relative precision next to ``u = 0`` and next to the separatrix. A fixed count, and powers of
    ``q`` by products, keep each value the same whatever else is evaluated with it. The
    trigonometric cubics are kept in ``s = sin^2 z = (1 - c)/2`` (``sin(2j+1)z / sin z``,
    ``cos(2j+1)z / cos z`` and ``cos 2jz`` are polynomials in it), which a sample has without
    forming ``c``.

    Works on one parameter (floats) or on columns of parameters of one kind (``trigonometric`` the
    same for every column). The cubics of its :class:`_ThetaPhase` join the same Horner pass.
    """

    def __init__(self, K, K_complementary, trigonometric: bool, ops, phase: '_ThetaPhase'):
        self.trigonometric = trigonometric
        ratio = K_complementary / K if trigonometric else K / K_complementary
        # u -> z or y
        self.scale = np.asarray((0.5 * math.pi) / (K if trigonometric else K_complementary))
        q = ops.exp(-math.pi * ratio)  # the same value for one parameter and for columns
        q2 = q * q
        q4 = q2 * q2
        q6, q9, q12 = q4 * q2, q4 * q4 * q, q4 * q4 * q4
        t2 = ((1.0 + q2) + q6) + q12  # theta_2(0) / (2 q^(1/4))
        t3 = 1.0 + 2.0 * ((q + q4) + q9)
        t4 = 1.0 + 2.0 * ((q4 - q) - q9)
        # in s = sin^2 z; sn = sin z A/D, cn = cos z B/D, dn = C/D with the constants in A, B, C
        if trigonometric:
            a = (
                ((1.0 - 3.0 * q2) + 5.0 * q6) - 7.0 * q12,
                (4.0 * q2 - 20.0 * q6) + 56.0 * q12,
                16.0 * q6 - 112.0 * q12,
                64.0 * q12,
            )
            b = (t2, (-4.0 * q2 - 12.0 * q6) - 24.0 * q12, 16.0 * q6 + 80.0 * q12, -64.0 * q12)
            c = (t3, (-4.0 * q - 16.0 * q4) - 36.0 * q9, 16.0 * q4 + 96.0 * q9, -64.0 * q9)
            d = (t4, (4.0 * q - 16.0 * q4) + 36.0 * q9, 16.0 * q4 - 96.0 * q9, 64.0 * q9)
            factors = (t3 / t2, t4 / t2, t4 / t3, 1.0)
        else:  # in c = cosh 2y; sn = tanh A/B, cn = D/(B cosh), dn = C/(B cosh)
            a = (
                ((1.0 - q2) - q6) + q12,
                (2.0 * q6 - 2.0 * q2) + 4.0 * q12,
                4.0 * q6 - 4.0 * q12,
                -8.0 * q12,
            )
            b = (
                ((1.0 - q2) - q6) + q12,
                (2.0 * q2 - 2.0 * q6) - 4.0 * q12,
                4.0 * q6 - 4.0 * q12,
                8.0 * q12,
            )
            c = (1.0 - 2.0 * q4, 2.0 * q - 6.0 * q9, 4.0 * q4, 8.0 * q9)
            d = (1.0 - 2.0 * q4, 6.0 * q9 - 2.0 * q, 4.0 * q4, -8.0 * q9)
            factors = (t3 / t4, 1.0, t2 / t3, t2 / t4)
        self.rows = [
            (f * cubic[0], f * cubic[1], f * cubic[2], f * cubic[3])
            for f, cubic in zip(factors, (a, b, c, d))
        ]
        self.phase = phase

    @functools.cached_property
    def phased_cubics(self) -> tuple:
        """
        Return the four cubics and their phase's, stacked for one Horner pass.

        See :func:`_stack`.
        """
        return _stack(self.rows + list(self.phase.cubics))

    @functools.cached_property
    def cubics(self) -> tuple:
        """
        Return the functions' own four cubics: a view of the stack.

        The attitude takes all of the stack.
        """
        return tuple(k[:4] for k in self.phased_cubics)

    def __call__(self, u):
        """``sn, cn, dn`` at ``0 <= u <= K/2``."""
        x = self.scale * u  # (under JacobiElliptic's errstate: underflow is no error)
        if self.trigonometric:
            first_sin, first_cos = np.sin(x), np.cos(x)
            variable = first_sin * first_sin  # s = sin^2 z
        else:
            first_cos = np.cosh(x)
            first_sin = np.tanh(x)
            variable = 2.0 * (first_cos * first_cos) - 1.0  # cosh 2y (>= 1: no cancellation)
        k0, k1, k2, k3 = self.cubics
        A, B, C, D = ((k3 * variable + k2) * variable + k1) * variable + k0
        if self.trigonometric:
            inverse = 1.0 / D
            return first_sin * A * inverse, first_cos * B * inverse, C * inverse
        inverse = 1.0 / B
        over_cosh = inverse / first_cos
        return first_sin * A * inverse, D * over_cosh, C * over_cosh


def _stack(rows) -> tuple:
    """
    Stack cubics given as rows ``(c0, c1, c2, c3)`` by coefficient, for one Horner pass.

    Coefficient ``k`` is ``(rows, 1)`` for one parameter (``c`` of shape ``(M,)``),
    ``(rows, 1, N)`` for parameters over bodies (``c`` of shape ``(M, N)``).
    """
    coefficients = np.array([row[k] for k in range(4) for row in rows])
    return tuple(coefficients.reshape((4, len(rows), 1) + coefficients.shape[1:]))


def _phase_weight(ops, m, n):
    """
    Return ``w = sqrt(-n / ((m - n)(1 - n)))``, 0 for ``n = 0``.

    At ``n = 0``, ``S`` has no weight in ``n S``.
    """
    return ops.sqrt(-n / (ops.where(n < 0.0, m - n, 1.0) * (1.0 - n)))


def _third_kind_shift(ops, m, n):
    """
    Return ``b`` with ``n = -m sc^2(b|mc)``, and ``b' = K' - b``, each directly.

    Each comes from Carlson's ``R_F``, so that whichever is small is known to relative precision:
    ``sc^2(b|mc) = -n/m`` and ``sc^2(b'|mc) = -1/n``. ``n = 0`` gives ``b = 0``; ``m = 0``
    (``n < 0``) gives ``b = inf``.
    """
    moving = n < 0.0
    d = ops.where(moving, m - n, 1.0)
    b = ops.sqrt(-n / d) * ops.elliprf(
        ops.where(moving, m / d, 1.0), ops.where(moving, m * (1.0 - n) / d, 1.0), 1.0
    )
    b_complementary = ops.elliprf(-n / (1.0 - n), (m - n) / (1.0 - n), 1.0) / ops.sqrt(1.0 - n)
    return b, b_complementary


class _ThetaPhase:
    """
    The theta phase ``arg θ4(z + i beta)``: the constants of its cubics.

    ``z = pi u/(2K)``, ``beta = pi b/(2K)``, ``b`` from :func:`_third_kind_shift`. The cubics join
    :class:`_ThetaSeries`' Horner pass in the same variable. The real part stays positive, so one
    ``atan2`` gives the phase without any branch to follow.

    Trigonometric (``m <= 1/2``), for every real ``z`` from
    ``θ4(z + i beta) = θ4(i beta) + s P(s) + i sin z cos z Q(s)``, ``s = sin^2 z`` (``P``, ``Q``
    cubics with ``q^(j^2) cosh 2j beta``, ``q^(j^2) sinh 2j beta``, ``j <= 4``). When ``|n|`` is
    large (a thin rod) ``θ4(i beta)`` is tiny, and it comes from the product form with
    ``1 - q e^(2 beta) = -expm1(-pi b'/K)``: the near zero is exact, not a difference.

    Hyperbolic (``m > 1/2``), by Jacobi's imaginary transformation (DLMF 20.7(viii)),
    ``arg θ4(z + i beta) = arg θ2(gamma - i y) - kappa u`` on the first half and
    ``= kappa v - arg θ3(gamma - i y_v)`` on the second (``v = K - u``; ``θ4(pi/2 - z) = θ3(z)``),
    with ``y = pi u/(2K')``, ``gamma = pi b/(2K')``, ``kappa = pi b/(2KK')`` and the complementary
    nome ``q'``: ``Re θ2 / cosh y = R(C)``, ``Im θ2 / cosh y = tanh y I(C)``, ``Re θ3 = R'(C)``,
    ``Im θ3 = 2 tanh y cosh^2 y I'(C)`` with ``C = cosh 2y``. The multiple angles of ``gamma`` are
    polynomials in ``sin^2 gamma`` times ``sin gamma`` or ``cos gamma``, which come from the
    smaller of ``b``, ``b'``: ``cos gamma``, the near zero for a thin rod, keeps relative
    precision.

    The series keep the terms that reach float64 on the reduced range, as :class:`_ThetaSeries`
    does.
    """

    def __init__(self, ops, K, K_complementary, m, n, trigonometric: bool):
        self.trigonometric = trigonometric
        b, b_complementary = _third_kind_shift(ops, m, n)
        Kc = K_complementary
        if trigonometric:
            self.cubics, base = self._trigonometric(ops, K, Kc, b, b_complementary)
            self.base = np.asarray(base)
        else:
            self.cubics = self._hyperbolic(ops, K, Kc, b, b_complementary)
            kappa = (math.pi * b) / (2.0 * K * Kc)
            self.kappa, self.first_half_kappa = np.asarray(kappa), np.asarray(-kappa)

    @staticmethod
    def _trigonometric(ops, K, Kc, b, bc):
        L = math.pi / K
        # q, rho = q e^(2 beta) = exp(-pi b'/K) (up to 1: a thin rod) and sigma = q e^(-2 beta),
        # each from its own exponent (K' = b + b'), so that none is a quotient of huge or tiny
        # numbers
        q, rho, sigma = ops.exp(-L * Kc), ops.exp(-L * bc), ops.exp(-L * (Kc + b))
        q2 = q * q
        q6 = q2 * q2 * q2
        # q^(j(j-1)): q^(j^2) e^(+-2j beta) = (rho or sigma)^j q^(j(j-1))
        spread = (1.0, q2, q6, q6 * q6)
        up = (
            rho,
            rho * rho * spread[1],
            rho * rho * rho * spread[2],
            (rho * rho) * (rho * rho) * spread[3],
        )
        down = (
            sigma,
            sigma * sigma * spread[1],
            sigma * sigma * sigma * spread[2],
            (sigma * sigma) * (sigma * sigma) * spread[3],
        )
        C1, C2, C3, C4 = (0.5 * (a + d) for a, d in zip(up, down))  # q^(j^2) cosh(2j beta)
        # q^(j^2) sinh(2j beta): for 2j beta < 1 from sinh(2 beta) by the multiple-angle formulas
        # (no cancellation), else the difference of the two exponentials (which loses nothing
        # there)
        x = L * b
        sh = ops.sinh(ops.clip(x, 0.0, 1.0))
        sh2 = sh * sh
        sinh2 = 2.0 * sh * ops.sqrt(1.0 + sh2)
        small = (sh, sinh2, sh * (3.0 + 4.0 * sh2), 2.0 * sinh2 * (1.0 + 2.0 * sh2))
        q_squares = (q, q2 * q2, q6 * q2 * q, (q6 * q2) * (q6 * q2))  # q^(j^2)
        S1, S2, S3, S4 = (
            ops.where(
                j * x < 1.0, q_squares[j - 1] * small[j - 1], 0.5 * (up[j - 1] - down[j - 1])
            )
            for j in range(1, 5)
        )
        # θ4(i beta) = (1 - rho) prod (1 - q^2j)(1 - sigma q^(2j-2))(1 - rho q^2j)
        base = -ops.expm1(-L * bc)
        q_even = 1.0
        for _ in range(6):
            q_before, q_even = q_even, q_even * q2
            base = base * ((1.0 - q_even) * (1.0 - sigma * q_before) * (1.0 - rho * q_even))
        # Re θ4 - θ4(i beta) = 4 sum (-1)^(j+1) C_j sin^2 jz and Im θ4 = 2 sum (-1)^(j+1) S_j sin
        # 2jz, over s = sin^2 z and sin z cos z: sin^2 jz / s and sin 2jz / sin 2z are polynomials
        # in s
        re = (
            4.0 * (((C1 - 4.0 * C2) + 9.0 * C3) - 16.0 * C4),
            4.0 * ((4.0 * C2 - 24.0 * C3) + 80.0 * C4),
            4.0 * (16.0 * C3 - 128.0 * C4),
            256.0 * C4,
        )
        im = (
            4.0 * (((S1 - 2.0 * S2) + 3.0 * S3) - 4.0 * S4),
            4.0 * ((4.0 * S2 - 16.0 * S3) + 40.0 * S4),
            4.0 * (16.0 * S3 - 96.0 * S4),
            256.0 * S4,
        )
        return (re, im), base

    @staticmethod
    def _hyperbolic(ops, K, Kc, b, bc):
        q = ops.exp(-math.pi * (K / Kc))  # the nome of _ThetaSeries' hyperbolic series
        q2 = q * q
        q4 = q2 * q2
        q6, q9, q12 = q4 * q2, q4 * q4 * q, q4 * q4 * q4
        direct = b <= bc
        angle = (0.5 * math.pi / Kc) * ops.where(direct, b, bc)
        sin_angle, cos_angle = ops.sin(angle), ops.cos(angle)
        # of gamma
        sg, cg = ops.where(direct, sin_angle, cos_angle), ops.where(direct, cos_angle, sin_angle)
        v = sg * sg
        # cos (2j+1) gamma
        cos_odd = (
            cg,
            cg * (1.0 - 4.0 * v),
            cg * ((1.0 - 12.0 * v) + 16.0 * v * v),
            cg * (((1.0 - 24.0 * v) + 80.0 * v * v) - 64.0 * v * v * v),
        )
        sin_odd = (
            sg,
            sg * (3.0 - 4.0 * v),
            sg * ((5.0 - 20.0 * v) + 16.0 * v * v),
            sg * (((7.0 - 56.0 * v) + 112.0 * v * v) - 64.0 * v * v * v),
        )
        cos2 = 1.0 - 2.0 * v
        sin2 = 2.0 * sg * cg
        cos4, sin4 = 2.0 * cos2 * cos2 - 1.0, 2.0 * sin2 * cos2
        cos6, sin6 = cos2 * (4.0 * cos2 * cos2 - 3.0), sin2 * (3.0 - 4.0 * sin2 * sin2)
        c0, c1, c2, c3 = cos_odd
        s0, s1, s2, s3 = sin_odd
        # θ2(gamma - i y) / cosh y: cos gamma + q^2 cos 3gamma (2C-1) + q^6 cos 5gamma (4C^2-2C-1)
        # + q^12 cos 7gamma (8C^3-4C^2-4C+1), the imaginary part the same in sines and sinh/cosh
        re_first = (
            ((c0 - q2 * c1) - q6 * c2) + q12 * c3,
            (2.0 * q2 * c1 - 2.0 * q6 * c2) - 4.0 * q12 * c3,
            4.0 * q6 * c2 - 4.0 * q12 * c3,
            8.0 * q12 * c3,
        )
        im_first = (
            ((s0 + q2 * s1) - q6 * s2) - q12 * s3,
            (2.0 * q2 * s1 + 2.0 * q6 * s2) - 4.0 * q12 * s3,
            4.0 * q6 * s2 + 4.0 * q12 * s3,
            8.0 * q12 * s3,
        )
        # θ3(gamma - i y): 1 + 2q cos 2gamma C + 2q^4 cos 4gamma (2C^2-1) + 2q^9 cos 6gamma
        # (4C^3-3C), and 2 sinh 2y [q sin 2gamma + 2q^4 sin 4gamma C + q^9 sin 6gamma (4C^2-1)],
        # its phase negated
        re_second = (
            1.0 - 2.0 * q4 * cos4,
            2.0 * q * cos2 - 6.0 * q9 * cos6,
            4.0 * q4 * cos4,
            8.0 * q9 * cos6,
        )
        im_second = (
            4.0 * q9 * sin6 - 4.0 * q * sin2,
            -8.0 * q4 * sin4,
            -16.0 * q9 * sin6,
            0.0 * q,
        )
        return re_first, im_first, re_second, im_second
