"""Compiled (numba) decision of the inverse catenary problem from the family of cables
that carry the prescribed end tension: infeasible data, or the taut cable through both
ends.

The kernel's Newton (:mod:`catenary.solve.kernels`) settles most cables. The ones it
does not, and data whose tension is too small to hold the cable at all, are decided
here, one cable at a time, without the numpy path's bracketing search
(:mod:`catenary.solve.length_bracket`, the reference these decisions are tested
against).

Method
------
Take the tension ``T`` as prescribed at one end (the "near" end) and let ``h`` be the
height of the other ("far") end over it (``h = -z`` for end B, ``z`` for end A). With
the hyperbolic end angles ``V = H sinh(phi)`` (``a`` at A, ``b`` at B) and ``L0 = (V_B -
V_A) / w``, the elastic span equations (:func:`catenary.solve.kernels.spans_one`) read::

    w x = H (b - a) + H^2 (sinh b - sinh a) / EA
    w z = (T_B - T_A) (1 + (T_A + T_B) / (2 EA))

The second is free of ``H``: the far tension is fixed by ``T`` and ``h`` alone
(:func:`far_tension`, the root of a quadratic), and it must be positive, else no cable
reaches the far end. Call ``T_lo <= T_hi`` the two end tensions and ``rho = T_hi /
T_lo``. The ``cosh`` of the end angles are ``T_lo / H`` and ``T_hi / H``, so ``H <=
T_lo`` and only the signs of the angles are free: with ``t`` the angle at the
low-tension end and ``beta >= 0`` the other (``cosh beta = rho cosh t``), every member is
``b - a = beta - t``, ``sinh b - sinh a = sinh beta - sinh t`` (mirrored where the low
end is B), and::

    w x(t) = H (beta - t) + H^2 (sinh beta - sinh t) / EA,     H = T_lo / cosh t.

As ``t`` falls from ``+inf`` (a vertical cable, ``x = 0``) to ``-inf`` (one sagging
without end, ``x = 0``) the span first grows, then shrinks:

* for ``t >= 0`` (both angles of one sign: the cable rises, or falls, all the way)
  ``d(w x)/dt = -H tanh(t) (psi(cosh beta) - psi(cosh t))`` plus an elastic term of the
  same sign, with ``psi(r) = acosh(r) - r / sqrt(r^2 - 1)`` increasing: ``x`` grows as
  ``t`` falls;
* for ``t < 0`` (a low point between the ends) ``w x = phi(H)``, ``phi(H) = H (acosh(T_lo
  / H) + acosh(T_hi / H)) + H (sqrt(T_lo^2 - H^2) + sqrt(T_hi^2 - H^2)) / EA``, a sum of
  concave functions of ``H`` on ``(0, T_lo]`` (second derivatives ``-r^3 / (H (r^2 -
  1)^(3/2))``, ``r = T / H``, and ``H (2 H^2 - 3 T^2) / (T^2 - H^2)^(3/2) / EA``) whose
  derivative runs from ``+inf`` (``H -> 0``) to ``-inf`` (``H -> T_lo``): one maximum.

So the cables with end tension ``T`` span every ``x`` in ``(0, max phi / w)`` twice,
and no other: the data are **feasible exactly when** ``T_far > 0`` **and** ``w x <= max
phi``. The taut root (larger ``H``, shorter: the one the numpy search brackets) lies on
the rising side, ``t > -t*`` (``-t*`` the low-end angle of the widest member), where
``x(t)`` is monotone.

The maximum of the concave ``phi`` is found by safeguarded Newton on ``phi' = 0`` in
``1 / t`` (where ``phi'`` is nearly linear; ``t* <= 1.1997``, the level inextensible
optimum) and bounded above by the tangent at the last iterate, ``max phi <= phi(H) +
|phi'(H)| T_lo``, below by ``phi(H)`` (:func:`widest_span`). A cheaper upper bound needs
no iteration (:func:`span_bound`): the four terms of ``phi`` maximised apart, ``H acosh(T
/ H) <= C_LEVEL T`` (``C_LEVEL = max acosh(r) / r = 1 / sinh(1.1997...)``) and ``H
sqrt(T^2 - H^2) <= T^2 / 2``, or their values at ``H = T_lo`` where they still rise
there. It is within 12.5 % of ``max phi`` (:data:`BAND`).

A decision must hold for every cable the solvers' certificate would accept (spans within
``1e-8`` of the chord, tension within ``1e-9``), so it is taken on the data moved by
``MARGIN`` of the chord and ``T_MARGIN`` of the tension towards the other answer;
cables closer to the edge are left undecided, as are data where the numpy path's search
may not decide (:data:`HEAVY`). Every loop has a hard cap.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["BAND", "C_LEVEL", "FEASIBLE", "HEAVY", "INFEASIBLE", "MARGIN", "NEARLY_LEVEL",
           "STRETCHY", "T_MARGIN", "UNDECIDED", "family_decision", "far_tension",
           "span_bound", "taut_member", "widest_span"]

#: Outcomes of :func:`family_decision`.
FEASIBLE, INFEASIBLE, UNDECIDED = 0, 1, 2
#: ``max over r >= 1 of acosh(r) / r`` = ``1 / sinh(t)`` at ``t tanh(t) = 1``, rounded up.
C_LEVEL = 0.6627434193491817
#: Angle ``t`` of that maximum (the level inextensible cable of least tension).
_T_LEVEL = 1.1996786402577338
#: Shift of the spans (of the chord) and of the tension (relative) towards the other
#: answer under which a decision must still hold: ten times the certificate's.
MARGIN, T_MARGIN = 1e-7, 1e-8
#: Relative rounding allowance of the span bounds.
_ROUND = 1e-12
_MAX_STEPS = 60
#: Data left undecided: cables heavier than ``HEAVY`` times their tension over the
#: chord (``w c / T``), stretched more than ``STRETCHY``-fold (``T / EA``), or nearly
#: but not exactly level (``0 < |z| < NEARLY_LEVEL c``). The numpy path's search may
#: stop there without an answer (seen from ``w c / T = 83`` with ``T / EA = 236``, from
#: ``w c / T = 99`` inextensible, and up to ``|z| = 4e-8 c``, where it finds the mean
#: end angle, ``~|z| / c``, from its second-order effect on the span, below its
#: tolerance), while this decision would give one; the solvers' answer must be the
#: numpy path's.
HEAVY, STRETCHY, NEARLY_LEVEL = 30.0, 100.0, 1e-6
#: Fraction of the cheap bound above which the screen of :func:`family_decision` tries
#: the widest span: below the least ratio of the widest span to the cheap bound (0.875,
#: at rho ~ 5.6; seen over rho in [1, 1e12] and T / EA in [0, 1e4]), so that every
#: infeasible cable is shown so before Newton (a matter of speed, not of soundness).
BAND = 0.87


@njit(cache=True, error_model="numpy")
def far_tension(T: float, wh: float, inv_EA: float) -> float:
    """Tension at the far end of any cable with tension ``T`` at the near end.

    ``wh`` is the weight per length times the height of the far end over the near one
    (N), ``inv_EA`` the axial compliance (1/N). The root ``T_far = T + v`` of ``w h = v
    (1 + (2 T + v) / (2 EA))`` that tends to ``T + w h`` as ``EA -> inf``, written
    without cancellation; NaN where there is none. No cable reaches the far end unless
    it is positive. Units: any force unit.
    """
    a = 1.0 + T * inv_EA
    disc = a * a + 2.0 * inv_EA * wh
    if not disc >= 0.0:
        return math.nan
    return T + 2.0 * wh / (a + math.sqrt(disc))


@njit(cache=True, error_model="numpy")
def span_bound(T_lo: float, T_hi: float, inv_EA: float) -> float:
    """Upper bound (N) of ``w x`` over the cables with end tensions ``T_lo <= T_hi``:
    the four terms of ``phi`` maximised apart, no iteration (module notes)."""
    bound = C_LEVEL * T_lo + 0.5 * inv_EA * T_lo * T_lo
    if T_hi <= 1.8101705806989772 * T_lo:  # cosh(t_level): the free maximum is allowed
        bound += C_LEVEL * T_hi
    else:  # H acosh(T_hi / H) still rising at H = T_lo
        bound += T_lo * math.acosh(T_hi / T_lo)
    if T_hi * T_hi <= 2.0 * T_lo * T_lo:
        bound += 0.5 * inv_EA * T_hi * T_hi
    else:
        bound += inv_EA * T_lo * math.sqrt((T_hi - T_lo) * (T_hi + T_lo))
    return bound * (1.0 + _ROUND)


@njit(cache=True, error_model="numpy")
def _angles(t: float, T_lo: float, T_hi: float
            ) -> tuple[float, float, float, float, float, float]:
    """``(H, sinh t, sinh beta, beta - t, sinh beta - sinh t, sinh beta - rho sinh t)``
    of the member with low-end angle ``t`` (differences without cancellation)."""
    c, s = math.cosh(t), math.sinh(t)
    H = T_lo / c
    rho_m1 = (T_hi - T_lo) / T_lo
    rr = rho_m1 * (T_hi + T_lo) / T_lo  # rho^2 - 1
    rho = T_hi / T_lo
    sb = math.sqrt(rho * rho * s * s + rr)
    if t > 0.0:  # sinh(beta - t) = cosh t (sinh beta - rho sinh t), both of one sign
        d = rr / (sb + rho * s)
        return H, s, sb, math.asinh(c * d), d + rho_m1 * s, d
    return H, s, sb, math.asinh(sb) - t, sb - s, sb - rho * s


@njit(cache=True, error_model="numpy")
def _phi(t: float, T_lo: float, T_hi: float, inv_EA: float) -> tuple[float, float, float]:
    """``(phi, phi', d(phi')/d|t|)`` at ``H = T_lo / cosh t`` (module notes): the span
    ``w x`` of the member with low-end angle ``-|t|`` and its derivatives in ``H``."""
    H, s, sb, spread, gap, _ = _angles(-abs(t), T_lo, T_hi)
    wx = H * spread + inv_EA * H * H * gap
    # phi'(H) = psi(cosh beta) + psi(cosh t) + H (sinh - 1 / sinh, of both) / EA, with
    # psi(cosh u) = u - coth u.
    a = abs(s)
    ch, cbh = math.sqrt(1.0 + a * a), math.sqrt(1.0 + sb * sb)
    ct, cb = ch / a, cbh / sb
    dphi = (abs(t) - ct) + (math.asinh(sb) - cb) + inv_EA * H * (a - 1.0 / a + sb - 1.0 / sb)
    # phi''(H) = -(coth^3 beta + coth^3 t) / H - ((3 cosh^2 - 2) / sinh^3, of both) / EA;
    # dH/d|t| = -H tanh|t|.
    d2 = -(cb ** 3 + ct ** 3) / H - inv_EA * ((3.0 * cbh * cbh - 2.0) / sb ** 3
                                               + (3.0 * ch * ch - 2.0) / a ** 3)
    return wx, dphi, -d2 * H * (a / ch)


@njit(cache=True, error_model="numpy")
def widest_span(T_lo: float, T_hi: float, inv_EA: float
                ) -> tuple[float, float, float, bool]:
    """``(lower, upper, t*, found)``: bounds of ``max phi``, the largest ``w x`` (N) of
    the cables with end tensions ``T_lo <= T_hi`` (N) and compliance ``inv_EA`` (1/N),
    and ``t* > 0``, minus the low end's angle on the widest one.

    Safeguarded Newton on ``phi'(H(t)) = 0`` in ``s = 1 / t`` (``phi'`` rises with
    ``t``, nearly linearly in ``1 / t`` for small ``t``; ``t* <= 1.1997``), at most
    ``_MAX_STEPS`` steps; ``found`` False where it did not converge. The bounds hold
    (to rounding, allowed for by ``_ROUND``) wherever they are finite.
    """
    s_lo, s_hi = 1.0 / (_T_LEVEL * (1.0 + 1e-9)), math.inf  # phi' >= 0 at s_lo, t* <= it
    s = 1.0 / _T_LEVEL
    # For rho >> 1: t* ~ 1 / (log(2 rho) - 1) (psi(cosh beta) ~ log(2 rho / cosh t) - 1).
    lr = math.log(2.0 * T_hi / T_lo)
    if lr > 2.0:
        s = lr - 1.0
    found = False
    for _ in range(_MAX_STEPS):
        wx, dphi, dt = _phi(1.0 / s, T_lo, T_hi, inv_EA)
        if not (math.isfinite(dphi) and math.isfinite(dt)):
            break
        if dphi > 0.0:  # t too large: s too small
            s_lo = max(s_lo, s)
        else:
            s_hi = min(s_hi, s)
        sn = s + dphi * s * s / dt  # d(phi')/ds = -dt / s^2 (dt: d(phi')/dt)
        if abs(dphi) * T_lo <= 1e-14 * wx or abs(sn - s) <= 1e-10 * s:
            found = True
            s = sn if s_lo <= sn <= s_hi else s
            break
        if not (s_lo < sn < s_hi):
            sn = 2.0 * s if s_hi == math.inf else 0.5 * (s_lo + s_hi)
        s = sn
    # Concave phi lies below its tangent: max phi <= phi(H) + |phi'(H)| T_lo.
    wx, dphi, _ = _phi(1.0 / s, T_lo, T_hi, inv_EA)
    lower = wx * (1.0 - _ROUND)
    upper = (wx + abs(dphi) * T_lo) * (1.0 + _ROUND)
    found = found and math.isfinite(lower) and math.isfinite(upper) and lower > 0.0
    return lower, upper, 1.0 / s, found


@njit(cache=True, error_model="numpy")
def taut_member(T_lo: float, T_hi: float, inv_EA: float, wx: float, t_star: float
                ) -> tuple[float, float, float, float, bool]:
    """The taut member spanning ``w x = wx`` (N): ``(H, t, sinh beta, sinh beta - sinh
    t, found)``.

    ``w x(t)`` falls from ``max phi`` at ``t = -t*`` to 0 as ``t -> inf`` (module
    notes); safeguarded Newton on ``log(w x(t) / wx)`` in ``t``, after widening the
    bracket's upper end by doubling (at most ``_MAX_STEPS`` steps each).
    """
    lo, hi = -t_star, max(0.0, -t_star) + 1.0
    H, _, _, spread, gap, _ = _angles(lo, T_lo, T_hi)
    if not H * spread + inv_EA * H * H * gap > wx:  # no bracket of the taut root
        return math.nan, math.nan, math.nan, math.nan, False
    for _ in range(_MAX_STEPS):
        H, _, _, spread, gap, _ = _angles(hi, T_lo, T_hi)
        if not H * spread + inv_EA * H * H * gap >= wx:
            break
        lo, hi = hi, 2.0 * hi + 1.0
    t = 0.5 * (lo + hi)
    found = False
    for _ in range(_MAX_STEPS):
        g, dg = _log_span(t, T_lo, T_hi, inv_EA, wx)
        if g != g:
            break
        if g > 0.0:
            lo = t
        else:
            hi = t
        tn = t - g / dg
        if abs(tn - t) <= 1e-12 * (1.0 + abs(t)) or abs(g) <= 1e-15:
            found = True
            t = tn if lo <= tn <= hi else t
            break
        if not (lo < tn < hi):
            tn = 0.5 * (lo + hi)
        t = tn
    H, _, sb, _, gap, _ = _angles(t, T_lo, T_hi)
    return H, t, sb, gap, found and math.isfinite(H) and H > 0.0 and gap > 0.0


@njit(cache=True, error_model="numpy")
def _log_span(t: float, T_lo: float, T_hi: float, inv_EA: float, wx: float
              ) -> tuple[float, float]:
    """``log(w x(t) / wx)`` and its ``t``-derivative (negative on the taut side)."""
    H, s, sb, spread, gap, d = _angles(t, T_lo, T_hi)
    c = math.cosh(t)
    rho = T_hi / T_lo
    f = H * spread + inv_EA * H * H * gap
    # dH/dt = -H tanh t, d beta/dt = rho sinh t / sinh beta, d sinh beta/dt = rho^2
    # sinh t cosh t / sinh beta; d beta/dt - 1 = -d / sinh beta.
    th = s / c
    dsb = rho * rho * s * c / sb
    df = -H * th * spread - H * d / sb + inv_EA * H * H * (dsb - c - 2.0 * th * gap)
    return math.log(f / wx), df / f


@njit(cache=True, error_model="numpy")
def family_decision(at_b: bool, x: float, z: float, T: float, w: float, inv_EA: float,
                    full: bool) -> tuple[int, float, float, float]:
    """Decide one cable with tension ``T`` at end B (``at_b``) or A, ``x > 0``, ``w > 0``.

    Returns ``(outcome, p, q, L0)``: :data:`INFEASIBLE` (no catenary through both ends
    carries ``T``, even with the data moved by ``MARGIN`` / ``T_MARGIN`` towards
    feasible), :data:`FEASIBLE` with the taut member's unit direction ``(p, q)`` at the
    prescribed end and its ``L0`` (a start for Newton; the data moved towards
    infeasible are still feasible), or :data:`UNDECIDED`. Without ``full`` (the
    screen before Newton) only infeasibility is tried: by the cheap bound
    (:func:`span_bound`), and where that is within ``BAND`` of the span, by the widest
    span. Data heavier than ``HEAVY``, more stretched than ``STRETCHY`` or nearly level
    (``NEARLY_LEVEL``) are :data:`UNDECIDED`. Spans (m), tension (N), weight (N/m),
    compliance (1/N), or any consistent units, best the chord and ``T`` of order one.
    """
    nan = math.nan
    h = -z if at_b else z
    # The screen's widest span needs w x > BAND * span_bound >= 2 BAND C_LEVEL T_lo, and
    # T_lo >= T - w max(0, -h) (the far tension falls by at most w |h|): a few flops
    # pass most cables on to Newton.
    if not full and w * x <= 2.0 * BAND * C_LEVEL * (T - w * max(0.0, -h)):
        return UNDECIDED, nan, nan, nan
    c = math.hypot(x, z)
    if not (w * c <= HEAVY * T and T * inv_EA <= STRETCHY
            and (z == 0.0 or abs(z) >= NEARLY_LEVEL * c)):
        return UNDECIDED, nan, nan, nan
    dx = MARGIN * c
    # Towards feasible: shorter span, higher far end (larger far tension), larger T.
    Tp = T * (1.0 + T_MARGIN)
    Tf = far_tension(Tp, w * (h + dx), inv_EA)
    if not Tf > 0.0:
        return INFEASIBLE, nan, nan, nan
    T_lo, T_hi = min(Tp, Tf), max(Tp, Tf)
    need = w * (x - dx)
    bound = span_bound(T_lo, T_hi, inv_EA)
    if need > bound:
        return INFEASIBLE, nan, nan, nan
    if not (full or need > BAND * bound):
        return UNDECIDED, nan, nan, nan
    upper = widest_span(T_lo, T_hi, inv_EA)[1]
    if need > upper:
        return INFEASIBLE, nan, nan, nan
    if not full:
        return UNDECIDED, nan, nan, nan
    # Towards infeasible: the widest member must still span the longer chord.
    Tm = T * (1.0 - T_MARGIN)
    Tf = far_tension(Tm, w * (h - dx), inv_EA)
    if not Tf > 0.0:
        return UNDECIDED, nan, nan, nan
    T_lo, T_hi = min(Tm, Tf), max(Tm, Tf)
    lower = widest_span(T_lo, T_hi, inv_EA)[0]
    if not w * (x + dx) < lower:
        return UNDECIDED, nan, nan, nan
    return _taut_start(at_b, x, h, T, w, inv_EA)


@njit(cache=True, error_model="numpy")
def _taut_start(at_b: bool, x: float, h: float, T: float, w: float, inv_EA: float
                ) -> tuple[int, float, float, float]:
    """:data:`FEASIBLE` and the taut member's ``(p, q, L0)`` (as
    :func:`family_decision`) of feasible data, far end at height ``h`` over the near
    one; :data:`UNDECIDED` where the search fails."""
    nan = math.nan
    Tf = far_tension(T, w * h, inv_EA)
    T_lo, T_hi = min(T, Tf), max(T, Tf)
    t_star = widest_span(T_lo, T_hi, inv_EA)[2]
    H, t, sb, gap, found = taut_member(T_lo, T_hi, inv_EA, w * x, t_star)
    if not found:
        return UNDECIDED, nan, nan, nan
    L0 = H * gap / w
    # The near end's angle: beta where it is the high-tension end, else -t (its
    # vertical force points along the cable from A to B; mirrored for end A).
    sn = sb if T >= Tf else -math.sinh(t)
    cn = math.sqrt(1.0 + sn * sn)
    p, q = 1.0 / cn, sn / cn
    if not at_b:
        q = -q
    if not (math.isfinite(q) and math.isfinite(L0) and L0 > 0.0):
        return UNDECIDED, nan, nan, nan
    return FEASIBLE, p, q, L0
