"""Sign changes of a scalar function on an interval (edge parameter), to round-off.

Candidates: roots of a degree-16 Chebyshev interpolant (exact for the polynomial traces of P1/P2
fields on straight edges, and close for smooth non-polynomial ones), plus a uniform grid; every
bracket with a sign change between consecutive sample points is refined with Brent's method on
the function itself (xtol ~ 1e-16 of the interval).
"""
import numpy as np
from numpy.polynomial import chebyshev as C
from scipy.optimize import brentq


def roots(f, a, b, ngrid=64, deg=16):
    """Sorted parameters in (a, b) where f changes sign (or vanishes in isolation)."""
    if not b > a:
        return np.zeros(0)
    k = np.arange(deg + 1)
    t = np.cos(np.pi * k / deg)[::-1]
    vals = f(0.5 * (a + b) + 0.5 * (b - a) * t)
    if not np.all(np.isfinite(vals)):
        vals = np.nan_to_num(vals)
    cands = []
    if np.any(vals != 0):
        coef = C.chebfit(t, vals, deg)
        try:
            r = C.chebroots(coef)
        except np.linalg.LinAlgError:
            r = np.zeros(0)
        r = r[np.abs(r.imag) <= 1e-7]
        r = r.real[(r.real > -1.0) & (r.real < 1.0)]
        cands = list(0.5 * (a + b) + 0.5 * (b - a) * np.sort(r))
    mids = [0.5 * (p + q) for p, q in zip(cands[:-1], cands[1:])]
    S = np.unique(np.concatenate([np.linspace(a, b, ngrid + 1), cands, mids]))
    F = f(S)
    F = np.where(np.isfinite(F), F, 0.0)
    if np.count_nonzero(F == 0) > len(F) // 2:
        return np.zeros(0)  # (numerically) identically zero: no kink
    out = []
    fs = lambda x: float(f(np.array([x]))[0])
    sg = np.sign(F)
    for i in range(len(S)):
        if sg[i] == 0 and a < S[i] < b:
            out.append(S[i])
    for i in range(len(S) - 1):
        if sg[i] * sg[i + 1] < 0:
            out.append(brentq(fs, S[i], S[i + 1], xtol=1e-16 * (b - a) + 1e-300, rtol=8.9e-16,
                              maxiter=200))
    return np.unique(np.array(out, dtype=float))
