"""Exact ("hand") value of the FOSLS functional for polynomial fields on a rectangle.

Independent of any mesh and of fosls_ref: all fields of the rectangle fixtures are global
polynomials that lie in the discrete spaces (P2 nodal u and sigma), so F of the P2 interpolant
equals F of the polynomials, which is computed here in rational arithmetic (fractions.Fraction)
by exact integration over [0, Lx] x [0, Ly] and over the contact side y = 0 (n = (0, -1),
t = (1, 0), g = y = 0: obstacle plane y = 0).  |.| in the friction term is integrated piecewise
between the given break points (where v_t or tau_n change sign); the sign on each piece is taken
at its midpoint.  Only the final sums are rounded to float.

Formulas (docs/design.md §3): e = eps(v) - A tau, A tau = (tau - c tr(tau) I)/(2 mu),
c = lam/(2 mu + 2 lam) (1/2 for lam = inf); r = div tau + f.
  energy: mu |e|^2 + lam/2 (tr e)^2,  robust: mu |e|^2,  seed: |e|^2 / 2
  equilibrium: w_d/2 |r|^2 (seed: w_d = 1)
  complementarity: int (v_n - g) tau_n,  v_n = -v_y, tau_n = tau_yy
  friction: int F |tau_n| |v_t| + tau_t v_t,  v_t = v_x, tau_t = -tau_xy
  energy (reported): energy norm 1/2 (C eps, eps) = mu |eps|^2 + lam/2 (tr eps)^2; robust/seed mu |eps|^2
"""
import math
from fractions import Fraction

from poly import F, Poly


def _sq(p):
    return p * p


def hand_functional(*, mu, lam, norm, w_d, u, tau, f, Lx, Ly, friction=0.0, breaks=()):
    """u = (ux, uy); tau = ((txx, txy), (tyx, tyy)); f = (fx, fy) Polys; mu, lam floats
    (lam = math.inf allowed); w_d float.  Returns dict of floats (and the exact Fractions)."""
    mu = F(mu)
    inf = math.isinf(lam)
    lamF = None if inf else F(lam)
    c = Fraction(1, 2) if inf else lamF / (2 * mu + 2 * lamF)
    ux, uy = u
    (txx, txy), (tyx, tyy) = tau
    fx, fy = f
    exx, eyy = ux.dx(), uy.dy()
    exy = (ux.dy() + uy.dx()) * Fraction(1, 2)
    tr_t = txx + tyy
    Axx = (txx - tr_t * c) / (2 * mu)
    Ayy = (tyy - tr_t * c) / (2 * mu)
    Axy = txy / (2 * mu)
    Ayx = tyx / (2 * mu)
    e11, e22, e12, e21 = exx - Axx, eyy - Ayy, exy - Axy, exy - Ayx
    frob = _sq(e11) + _sq(e22) + _sq(e12) + _sq(e21)
    tre = e11 + e22
    if norm == "energy":
        const_int = frob * mu + _sq(tre) * (lamF / 2)
    elif norm == "robust":
        const_int = frob * mu
    elif norm == "seed":
        const_int = frob * Fraction(1, 2)
    else:
        raise ValueError(norm)
    wd = Fraction(1) if norm == "seed" else F(w_d)
    r1 = txx.dx() + txy.dy() + fx
    r2 = tyx.dx() + tyy.dy() + fy
    equi_int = (_sq(r1) + _sq(r2)) * (wd / 2)
    epsfrob = _sq(exx) + _sq(eyy) + 2 * _sq(exy)
    if norm == "energy":
        en_int = epsfrob * mu + _sq(exx + eyy) * (lamF / 2)
    else:
        en_int = epsfrob * mu
    rect = lambda p: p.integrate_rect(0, Lx, 0, Ly)
    const = rect(const_int)
    equi = rect(equi_int)
    energy = rect(en_int)
    # contact side y = 0
    vn = -uy.restrict_y(0)
    vt = ux.restrict_y(0)
    tn = tyy.restrict_y(0)
    tt = -txy.restrict_y(0)
    comp = (vn * tn).integrate_x(0, Lx)  # g = 0
    fric = Fraction(0)
    if friction:
        Ff = F(friction)
        pts = [F(0)] + sorted(F(b) for b in breaks) + [F(Lx)]
        for a, b in zip(pts[:-1], pts[1:]):
            m = (a + b) / 2
            s_tn = 1 if tn.exact_at(m, 0) >= 0 else -1
            s_vt = 1 if vt.exact_at(m, 0) >= 0 else -1
            integrand = tn * vt * (Ff * s_tn * s_vt) + tt * vt
            fric += integrand.integrate_x(a, b)
    total = const + equi + comp + fric
    out = {"total": float(total), "constitutive": float(const), "equilibrium": float(equi),
           "complementarity": float(comp), "friction": float(fric), "energy": float(energy)}
    out["relative"] = math.sqrt(float(total / energy)) if total >= 0 else None
    out["method"] = ("exact rational integration of the polynomial fields over the rectangle and y = 0 "
                     "(reference/exact/hand.py); w_d, mu, lambda, F as doubles")
    return out
