"""Self-verification of fosls_ref:  python -m fosls_ref.selftest  (exit 0 iff all checks pass).

(a) exact polynomial solutions in the discrete space give F/energy < 1e-20 (every preset,
    plane strain / plane stress, P1 / P2, nu = 0.5 with robust and seed, frictionless, Coulomb
    slip and stick);
(b) known perturbations give the hand-derived value of every term (derivations next to each test);
(c) scaling E, sigma, f (and tractions) by 1e9 leaves `relative` unchanged;
(d) curved P2 cells: area, energy, arc length, a divergence-theorem identity, and the contact
    quantities on a curved contact boundary against independent analytic / scipy.quad values.
Also: file-format invariance (stress layouts 3/4/6/9, ascii/binary/zlib, exploded meshes) and
bad-input errors (exit status 2).
Meshes and fields are built in code; VTU and TOML files go to a temporary directory.
"""
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy.integrate import quad

from . import evaluate_files
from .errors import InputError
from .testing import Poly2, elastic_stress, rect_mesh, write_case, write_text

RESULTS = []


def check(name, value, expected, rtol=1e-12, atol=0.0):
    if expected is None:
        ok = value is None
        err = 0.0
    else:
        err = abs(value - expected)
        ok = err <= atol + rtol * abs(expected)
    RESULTS.append((name, value, expected, err, ok))
    return ok


def check_lt(name, value, bound):
    ok = value is not None and abs(value) < bound
    RESULTS.append((name, value, f"|.|<{bound:g}", abs(value) if value is not None else None, ok))
    return ok


def lame(E, nu, model="plane_strain"):
    mu = E / (2 * (1 + nu))
    lam = math.inf if nu == 0.5 else E * nu / ((1 + nu) * (1 - 2 * nu))
    if model == "plane_stress":
        lam = 2 * mu if math.isinf(lam) else 2 * lam * mu / (lam + 2 * mu)
    return mu, lam


def integrate_x(p):
    """int_0^1 p(x, 0) dx for a Poly2 p."""
    return float(sum(p.c[i, 0] / (i + 1) for i in range(p.c.shape[0])))


class Case:
    """An exact (or perturbed) field on the unit square with the standard boundaries:
    top (tag 3) Dirichlet = exact u, right (`where x > 0.999`) and left (tag 4) Neumann = exact
    traction, bottom (tag 1) contact with the rigid plane y = 0 (m = (0, 1)): g = y."""

    def __init__(self, tmp, E, nu, u1, u2, s11, s22, s12, model="plane_strain", friction=0.0,
                 normal="obstacle", body_force=True, bcs=True, nx=4, degree=2, jitter=0.3,
                 flip=0.3, seed=1, bottom_sag=0.0):
        self.tmp, self.E, self.nu, self.model = tmp, E, nu, model
        self.u1, self.u2, self.s11, self.s22, self.s12 = u1, u2, s11, s22, s12
        self.friction, self.normal, self.bcs = friction, normal, bcs
        self.f1 = -(s11.dx() + s12.dy())
        self.f2 = -(s12.dx() + s22.dy())
        self.body_force = body_force
        self.pts, self.cells, self.lines, self.tags, self.bottom = rect_mesh(
            nx, nx, degree, jitter=jitter, flip=flip, seed=seed, bottom_sag=bottom_sag)
        x, y = self.pts.T
        self.disp = np.stack([u1(x, y), u2(x, y)], axis=1)
        st = np.zeros((len(x), 2, 2))
        st[:, 0, 0], st[:, 1, 1] = s11(x, y), s22(x, y)
        st[:, 0, 1] = st[:, 1, 0] = s12(x, y)
        self.stress = st
        self.counter = 0

    def scene(self, norm=None, scale=1.0, extra=""):
        k = scale
        s = [f"[material]\nyoungs_modulus = {self.E * k!r}\npoisson_ratio = {self.nu!r}\n"
             f"model = \"{self.model}\"\n"]
        if self.body_force:
            s.append(f"[loads]\nbody_force = [\"{(k * self.f1).expr()}\", \"{(k * self.f2).expr()}\"]\n")
        s.append("[boundaries]\ntag_array = \"boundary_tag\"\n")
        if self.bcs:
            s.append(f"[[boundary]]\nname = \"top\"\ntag = 3\nkind = \"dirichlet\"\n"
                     f"displacement = [\"{self.u1.expr()}\", \"{self.u2.expr()}\"]\n")
            s.append(f"[[boundary]]\nname = \"right\"\nwhere = \"x > 0.999\"\nkind = \"neumann\"\n"
                     f"traction = [\"{(k * self.s11).expr()}\", \"{(k * self.s12).expr()}\"]\n")
            s.append(f"[[boundary]]\nname = \"left\"\ntag = 4\nkind = \"neumann\"\n"
                     f"traction = [\"{(-k * self.s11).expr()}\", \"{(-k * self.s12).expr()}\"]\n")
        s.append("[[boundary]]\nname = \"bottom\"\ntag = 1\nkind = \"contact\"\n"
                 "obstacle = { plane = { point = [0.0, 0.0], normal = [0.0, 1.0] } }\n"
                 f"normal = \"{self.normal}\"\nfriction = {self.friction!r}\n")
        if norm:
            s.append(f"[estimate]\nnorm = \"{norm}\"\n")
        return "".join(s) + extra

    def run(self, norm=None, disp=None, stress=None, scale=1.0, ncomp=4, exploded=False,
            binary=True, compression="zlib", extra="", **kw):
        self.counter += 1
        name = f"case{id(self)}_{self.counter}"
        d = self.disp if disp is None else disp
        st = (self.stress if stress is None else stress) * scale
        vtu = write_case(self.tmp, name, self.pts, self.cells, self.lines, self.tags, d, st,
                         ncomp=ncomp, exploded=exploded, binary=binary, compression=compression)
        sc = write_text(self.tmp, name + ".toml", self.scene(norm, scale, extra))
        return evaluate_files(vtu, sc, norm=norm, **kw), vtu, sc


def P(c, i, j):
    return Poly2.mono(c, i, j)


# ------------------------------------------------------------------------------------------------
def base_solution(E=210.0, nu=0.3, model="plane_strain"):
    """Exact solution A: u quadratic, sigma = C eps(u) linear, f = -div sigma constant.
    On y = 0: u2 = 0 (= g, contact with zero gap), sigma_12 = mu(du1/dy + du2/dx) = 0 (u1 has no
    y-linear or xy term and u2(x, 0) = 0), sigma_22 = (2mu+lam)(a + d x) + lam(al + 2 be x) < 0."""
    mu, lam = lame(E, nu, model)
    al, be, ga, a, b, d = 0.01, 0.005, -0.02, -0.05, 0.015, 0.01
    u1 = P(al, 1, 0) + P(be, 2, 0) + P(ga, 0, 2)
    u2 = P(a, 0, 1) + P(b, 0, 2) + P(d, 1, 1)
    return (mu, lam, u1, u2) + elastic_stress(u1, u2, mu, lam)


def test_exact(tmp):
    print("(a) exact solutions ...", flush=True)
    for model in ("plane_strain", "plane_stress"):
        mu, lam, u1, u2, s11, s22, s12 = base_solution(model=model)
        case = Case(tmp, 210.0, 0.3, u1, u2, s11, s22, s12, model=model)
        for norm in ("energy", "robust", "seed"):
            o, _, _ = case.run(norm)
            r = o["functional"]["total"] / o["energy"]
            check_lt(f"a/exact P2 {model} {norm}: F/energy", r, 1e-20)
        # normal force = int_0^1 -sigma_22(x, 0) dx, active = contact length = 1
        check(f"a/exact P2 {model}: normal_force", o["contact"]["normal_force"], -integrate_x(s22))
        check(f"a/exact P2 {model}: active_length", o["contact"]["active_length"], 1.0)
        sc = max(abs(s22(0, 0)), abs(s22(1, 0)))
        for k, v in o["admissibility"].items():
            check_lt(f"a/exact P2 {model}: {k} (rel. to |sigma|)", v / sc, 1e-13)
        check("a/exact P2: bound guaranteed", float(o["bound"]["guaranteed"]), 1.0)

    # P1: u linear, sigma constant, f = 0
    E, nu = 3.0, 0.25
    mu, lam = lame(E, nu)
    u1 = P(0.02, 1, 0)
    u2 = P(-0.03, 0, 1)
    s11, s22, s12 = elastic_stress(u1, u2, mu, lam)
    case = Case(tmp, E, nu, u1, u2, s11, s22, s12, degree=1, nx=5)
    for norm in ("energy", "robust", "seed"):
        o, _, _ = case.run(norm)
        check_lt(f"a/exact P1 {norm}: F/energy", o["functional"]["total"] / o["energy"], 1e-20)

    # Coulomb slip (F = 1/2, a power of two so that sigma_12 = -F sigma_22 holds exactly in
    # floating point at the bottom nodes): u_t = u1(x,0) = u0 + al x + be x^2 > 0 and
    # sigma_t = -sigma_12 = F sigma_n = F sigma_22 < 0 on y = 0, i.e.
    # mu (dl + ep x) = -F sigma_22(x, 0) with u1 = ... + dl y + ep x y.
    Fr = 0.5
    E, nu = 210.0, 0.3
    mu, lam = lame(E, nu)
    al, be, ga, a, b, d, u0 = 0.01, 0.005, -0.02, -0.05, 0.015, 0.01, 0.004
    dl = -Fr * ((2 * mu + lam) * a + lam * al) / mu
    ep = -Fr * ((2 * mu + lam) * d + 2 * lam * be) / mu
    u1 = P(u0, 0, 0) + P(al, 1, 0) + P(be, 2, 0) + P(ga, 0, 2) + P(dl, 0, 1) + P(ep, 1, 1)
    u2 = P(a, 0, 1) + P(b, 0, 2) + P(d, 1, 1)
    s11, s22, s12 = elastic_stress(u1, u2, mu, lam)
    slip = Case(tmp, E, nu, u1, u2, s11, s22, s12, friction=Fr)
    bot = slip.pts[:, 1] == 0.0
    slip.stress[bot, 0, 1] = slip.stress[bot, 1, 0] = -Fr * slip.stress[bot, 1, 1]
    for norm in ("energy", "robust", "seed"):
        o, _, _ = slip.run(norm)
        check_lt(f"a/exact Coulomb slip {norm}: F/energy", o["functional"]["total"] / o["energy"], 1e-20)
    check("a/exact Coulomb slip: slip_length", o["contact"]["slip_length"], 1.0)
    check("a/exact Coulomb slip: stick_length", o["contact"]["stick_length"], 0.0, atol=1e-15)
    check_lt("a/exact Coulomb slip: cone_violation_max", o["admissibility"]["cone_violation_max"], 1e-14)

    # Coulomb stick: u1(x, 0) = 0 (u_t = 0), |sigma_t| = mu|dl + ep x| < F |sigma_n|
    u1 = P(ga, 0, 2) + P(0.002, 0, 1) + P(0.001, 1, 1)
    s11, s22, s12 = elastic_stress(u1, u2, mu, lam)
    stick = Case(tmp, E, nu, u1, u2, s11, s22, s12, friction=Fr)
    o, _, _ = stick.run("energy")
    check_lt("a/exact Coulomb stick energy: F/energy", o["functional"]["total"] / o["energy"], 1e-20)
    check("a/exact Coulomb stick: stick_length", o["contact"]["stick_length"], 1.0)

    # nu = 0.5: div u = 0 (u1 = al x + be x^2 + ga y^2, u2 = -al y - 2 be x y),
    # sigma = 2 mu eps(u) + p I with p linear; A sigma = dev(sigma)/(2mu) = eps(u).
    E, nu = 210.0, 0.5
    mu = E / 3.0
    al, be, ga = 0.01, 0.005, -0.02
    u1 = P(al, 1, 0) + P(be, 2, 0) + P(ga, 0, 2)
    u2 = P(-al, 0, 1) + P(-2 * be, 1, 1)
    t11, t22, t12 = elastic_stress(u1, u2, mu, None)
    p = P(-0.1 * mu, 0, 0) + P(0.02 * mu, 1, 0) + P(0.03 * mu, 0, 1)
    inc = Case(tmp, E, nu, u1, u2, t11 + p, t22 + p, t12)
    for norm in (None, "seed"):
        o, _, _ = inc.run(norm)
        check_lt(f"a/exact nu=0.5 {o['norm']}: F/energy", o["functional"]["total"] / o["energy"], 1e-20)
    o, _, _ = inc.run(None)
    check("a/exact nu=0.5: default norm is robust", float(o["norm"] == "robust"), 1.0)
    try:
        inc.run("energy")
        check("a/nu=0.5 with energy -> InputError", 0.0, 1.0)
    except InputError:
        check("a/nu=0.5 with energy -> InputError", 1.0, 1.0)

    # nu = 0.4999999 with the energy norm: A sigma suffers cancellation (tr sigma ~ lam tr eps),
    # so the exact solution only reaches ~eps * lam/mu relative (informative).
    mu9, lam9, w1, w2, r11, r22, r12 = base_solution(210.0, 0.4999999)
    o, _, _ = Case(tmp, 210.0, 0.4999999, w1, w2, r11, r22, r12).run("energy")
    RESULTS.append(("a/info: nu=0.4999999 energy F/energy", o["functional"]["total"] / o["energy"],
                    "(conditioning)", 0.0, True))
    check_lt("a/nu=0.4999999 energy: F/energy", o["functional"]["total"] / o["energy"], 1e-12)

    # nonzero gap: the boundary terms are linear in the data, so round-off in v_n - g
    # (~eps |g|) enters F linearly: expect |F|/energy ~ 1e-16, not 1e-28 (reported, not a defect).
    mu, lam, u1, u2, s11, s22, s12 = base_solution()
    c0 = 0.1
    gapcase = Case(tmp, 210.0, 0.3, u1, u2 - c0, s11, s22, s12)
    o, _, _ = gapcase.run("energy", extra="")
    # (plane y = 0 but the body's bottom is displaced by -c0 ... use the plane y = -c0 instead)
    txt = gapcase.scene("energy").replace("point = [0.0, 0.0]", f"point = [0.0, {-c0!r}]")
    vtu = write_case(tmp, "gapcase", gapcase.pts, gapcase.cells, gapcase.lines, gapcase.tags,
                     gapcase.disp, gapcase.stress)
    sc = write_text(tmp, "gapcase.toml", txt)
    o = evaluate_files(vtu, sc)
    RESULTS.append(("a/info: gap 0.1, |F|/energy (linear round-off, informative)",
                    abs(o["functional"]["total"]) / o["energy"], "~1e-16", 0.0, True))
    check_lt("a/gap 0.1: constitutive/energy", o["functional"]["constitutive"] / o["energy"], 1e-20)
    check_lt("a/gap 0.1: |F|/energy", abs(o["functional"]["total"]) / o["energy"], 1e-14)


def test_perturbations(tmp):
    print("(b) perturbations ...", flush=True)
    E, nu = 210.0, 0.3
    mu, lam, u1, u2, s11, s22, s12 = base_solution(E, nu)
    c = lam / (2 * mu + 2 * lam)  # A tau = (tau - c tr(tau) I)/(2mu)
    case = Case(tmp, E, nu, u1, u2, s11, s22, s12)
    x, y = case.pts.T
    N = -integrate_x(s22)        # exact normal force int -sigma_22(x,0) dx > 0
    delta = 1e-3
    ell = math.sqrt(2.0) / math.pi  # diameter of the unit square / pi (corners are mesh points)

    # b1: u += delta (x^2, 0).  eps(w) = diag(2x, 0), e = delta eps(w) (eps(u) = A sigma exactly).
    #   energy: int mu|e|^2 + lam/2 (tr e)^2 = delta^2 (4mu + 2lam) int x^2 = delta^2 (4mu+2lam)/3
    #   robust: 4 mu delta^2/3;  seed: 1/2 * 4 delta^2/3.  w_n = (0,-1).(x^2,0) = 0 on y = 0.
    #   dirichlet_max = delta (top edge, x = 1).
    d = case.disp.copy()
    d[:, 0] += delta * x ** 2
    exp = {"energy": delta ** 2 * (4 * mu + 2 * lam) / 3, "robust": 4 * mu * delta ** 2 / 3,
           "seed": 2 * delta ** 2 / 3}
    for norm in exp:
        o, _, _ = case.run(norm, disp=d)
        check(f"b1 u+=d(x^2,0) {norm}: constitutive", o["functional"]["constitutive"], exp[norm], 1e-11)
        check(f"b1 u+=d(x^2,0) {norm}: total", o["functional"]["total"], exp[norm], 1e-11)
    check("b1: dirichlet_max", o["admissibility"]["dirichlet_max"], delta, 1e-11)
    check("b1: dirichlet L2 = delta sqrt(1/5)", o["admissibility_l2"]["dirichlet"], delta * math.sqrt(0.2), 1e-11)

    # b2: u2 -= delta on the whole body (rigid shift into the obstacle): eps unchanged,
    #   v_n - g = -(u2 - delta) - 0 = delta on y = 0: complementarity = delta int sigma_22 = -delta N.
    #   penetration_max = delta, L2 = delta.  Separation (u2 += delta): +delta N.
    for sgn, nm in ((-1.0, "separation"), (1.0, "penetration")):
        d = case.disp.copy()
        d[:, 1] -= sgn * delta
        o, _, _ = case.run("energy", disp=d)
        check(f"b2 {nm}: complementarity", o["functional"]["complementarity"], -sgn * delta * N, 1e-11)
        check(f"b2 {nm}: penetration_max", o["admissibility"]["penetration_max"],
              delta if sgn > 0 else 0.0, 1e-11, atol=1e-18)
        check(f"b2 {nm}: complementarity_negative", o["functional"]["complementarity_negative"],
              -delta * N if sgn > 0 else 0.0, 1e-11, atol=1e-18)
    # penetration: F = -delta N < 0 (inadmissible pair): eta and relative are reported as null
    check("b2 penetration: total F = -delta N", o["functional"]["total"], -delta * N, 1e-11)
    check("b2 penetration: eta is null", o["eta"], None)
    check("b2 penetration: bound not guaranteed", float(o["bound"]["guaranteed"]), 0.0)

    # b3: sigma_11 += delta (every node). e = -delta A E11 = -delta/(2mu) diag(1-c, -c).
    #   energy = 1/2 (C e, e) = delta^2/2 (A E11 : E11) = delta^2 (1-c)/(4mu)   (area 1)
    #   robust = mu |e|^2 = delta^2 ((1-c)^2 + c^2)/(4mu);  seed = delta^2 ((1-c)^2 + c^2)/(8mu^2)
    #   neumann_max = delta (sides, traction (+-delta, 0)).
    st = case.stress.copy()
    st[:, 0, 0] += delta
    q = (1 - c) ** 2 + c ** 2
    exp = {"energy": delta ** 2 * (1 - c) / (4 * mu), "robust": delta ** 2 * q / (4 * mu),
           "seed": delta ** 2 * q / (8 * mu ** 2)}
    for norm in exp:
        o, _, _ = case.run(norm, stress=st)
        check(f"b3 s11+=d {norm}: total", o["functional"]["total"], exp[norm], 1e-10)
    check("b3: neumann_max", o["admissibility"]["neumann_max"], delta, 1e-10)
    b3 = exp

    # b4: sigma_11 += delta x: div tau + f = (delta, 0):
    #   equilibrium = 1/2 w_d delta^2 (w_d = ell^2/(2mu), ell = sqrt(2)/pi; seed: w_d = 1),
    #   constitutive = b3 value * int x^2 = b3/3.
    st = case.stress.copy()
    st[:, 0, 0] += delta * x
    for norm in b3:
        o, _, _ = case.run(norm, stress=st)
        wd = 1.0 if norm == "seed" else ell ** 2 / (2 * mu)
        check(f"b4 s11+=d x {norm}: equilibrium", o["functional"]["equilibrium"], 0.5 * wd * delta ** 2, 1e-10)
        check(f"b4 s11+=d x {norm}: constitutive", o["functional"]["constitutive"], b3[norm] / 3, 1e-10)
    # with an explicit length_scale
    o, _, _ = case.run(None, stress=st, extra="[estimate]\nlength_scale = 0.25\n")
    check("b4 length_scale=0.25: equilibrium", o["functional"]["equilibrium"],
          0.5 * 0.25 ** 2 / (2 * mu) * delta ** 2, 1e-10)

    # b5: Coulomb slip solution (F = 1/2), sigma_12 += delta (both off-diagonal entries):
    #   sigma_t = -sigma_12 -> sigma_t - delta, |sigma_n| unchanged:
    #   friction = int (F|s_n||u_t| + (s_t - delta) u_t) = -delta int_0^1 u1(x, 0) dx (< 0),
    #   friction_negative = same;  constitutive: e = -delta/(2mu)(E12 + E21), tr e = 0:
    #   energy/robust mu|e|^2 = delta^2/(2mu); seed 1/2|e|^2 = delta^2/(4mu^2);
    #   cone_violation_max = delta.
    Fr = 0.5
    al, be, ga, a, b, dd, u0 = 0.01, 0.005, -0.02, -0.05, 0.015, 0.01, 0.004
    dl = -Fr * ((2 * mu + lam) * a + lam * al) / mu
    ep = -Fr * ((2 * mu + lam) * dd + 2 * lam * be) / mu
    v1 = P(u0, 0, 0) + P(al, 1, 0) + P(be, 2, 0) + P(ga, 0, 2) + P(dl, 0, 1) + P(ep, 1, 1)
    v2 = P(a, 0, 1) + P(b, 0, 2) + P(dd, 1, 1)
    slip = Case(tmp, E, nu, v1, v2, *elastic_stress(v1, v2, mu, lam), friction=Fr)
    ut_int = integrate_x(v1)
    st = slip.stress.copy()
    st[:, 0, 1] += delta
    st[:, 1, 0] += delta
    exp = {"energy": delta ** 2 / (2 * mu), "robust": delta ** 2 / (2 * mu), "seed": delta ** 2 / (4 * mu ** 2)}
    for norm in exp:
        o, _, _ = slip.run(norm, stress=st)
        check(f"b5 s12+=d {norm}: constitutive", o["functional"]["constitutive"], exp[norm], 1e-10)
        check(f"b5 s12+=d {norm}: friction", o["functional"]["friction"], -delta * ut_int, 1e-10)
    check("b5: friction_negative", o["functional"]["friction_negative"], -delta * ut_int, 1e-10)
    check("b5: cone_violation_max", o["admissibility"]["cone_violation_max"], delta, 1e-10)
    check("b5: cone_violation L2", o["admissibility_l2"]["cone_violation"], delta, 1e-10)

    # b6 (kink of |v_t| inside an edge): sigma = -Pr I, u = (x - 1/3, 0), f = 0, F = 1/2,
    #   bottom edges [0,1/4],[1/4,1/2],...: the kink x = 1/3 lies inside an edge.
    #   friction = int_0^1 F Pr |x - 1/3| dx = F Pr (1/18 + 4/18) = 5 F Pr / 18, stick everywhere
    #   (sigma_t = 0 < F Pr); complementarity = 0 (u_n = g = 0).
    #   constitutive (energy): e = E11 + k I, k = Pr/(2(mu+lam)):
    #   mu((1+k)^2 + k^2) + lam/2 (1+2k)^2.
    Pr = 2.0
    w1, w2 = P(1.0, 1, 0) + P(-1.0 / 3.0, 0, 0), Poly2([[0.0]])
    cst = Poly2([[-Pr]])
    kink = Case(tmp, E, nu, w1, w2, cst, cst, Poly2([[0.0]]), friction=Fr, body_force=False,
                bcs=False, jitter=0.0)
    o, _, _ = kink.run("energy")
    k = Pr / (2 * (mu + lam))
    check("b6 |v_t| kink: friction = 5 F P/18", o["functional"]["friction"], 5 * Fr * Pr / 18, 1e-13)
    check("b6: constitutive", o["functional"]["constitutive"],
          mu * ((1 + k) ** 2 + k ** 2) + 0.5 * lam * (1 + 2 * k) ** 2, 1e-12)
    check("b6: stick_length", o["contact"]["stick_length"], 1.0, 1e-13)
    o2, _, _ = kink.run("energy", edge_points=3)
    check("b6: friction with 3 Gauss points per piece (splitting makes it exact)",
          o2["functional"]["friction"], 5 * Fr * Pr / 18, 1e-13)

    # b7 (sign changes of sigma_n and v_n - g inside edges): sigma_22 = Pr (x - 0.3), other
    #   components 0, u = (0, ze (x - 0.5)): v_n - g = -ze (x - 0.5), sigma_n = Pr (x - 0.3).
    #   complementarity = -ze Pr int_0^1 (x-.5)(x-.3) = -ze Pr/12;
    #   negative part   = -ze Pr (int_0^.3 + int_.5^1)(x-.5)(x-.3) = -ze Pr (0.018 + 1/15);
    #   active_length = 0.3; normal_force = -Pr int (x - .3) = -0.2 Pr;
    #   tension_max = 0.7 Pr, tension L2 = Pr sqrt(0.7^3/3);
    #   penetration_max = ze/2 (x = 0), penetration L2 = ze sqrt(0.5^3/3).
    ze = 1e-3
    z = Poly2([[0.0]])
    sig22 = P(Pr, 1, 0) + P(-0.3 * Pr, 0, 0)
    b7 = Case(tmp, E, nu, z, P(ze, 1, 0) + P(-0.5 * ze, 0, 0), z, sig22, z, body_force=False,
              bcs=False, jitter=0.0)
    o, _, _ = b7.run("energy")
    check("b7: complementarity", o["functional"]["complementarity"], -ze * Pr / 12, 1e-12)
    check("b7: complementarity_negative", o["functional"]["complementarity_negative"],
          -ze * Pr * (0.018 + 1 / 15), 1e-12)
    check("b7: active_length", o["contact"]["active_length"], 0.3, 1e-13)
    check("b7: active_length_strict", o["contact"]["active_length_strict"], 0.3, 1e-13)
    check("b7: normal_force", o["contact"]["normal_force"], -0.2 * Pr, 1e-13)
    check("b7: tension_max", o["admissibility"]["tension_max"], 0.7 * Pr, 1e-13)
    check("b7: tension L2", o["admissibility_l2"]["tension"], Pr * math.sqrt(0.7 ** 3 / 3), 1e-12)
    check("b7: penetration_max", o["admissibility"]["penetration_max"], ze / 2, 1e-13)
    check("b7: penetration L2", o["admissibility_l2"]["penetration"], ze * math.sqrt(0.5 ** 3 / 3), 1e-12)
    # same on P1 (fields are linear): identical values
    b7p1 = Case(tmp, E, nu, z, P(ze, 1, 0) + P(-0.5 * ze, 0, 0), z, sig22, z, body_force=False,
                bcs=False, jitter=0.0, degree=1)
    o, _, _ = b7p1.run("energy")
    check("b7 P1: complementarity_negative", o["functional"]["complementarity_negative"],
          -ze * Pr * (0.018 + 1 / 15), 1e-12)
    check("b7 P1: active_length", o["contact"]["active_length"], 0.3, 1e-13)

    # b7n: separated zone carrying round-off noise: nodal sigma_22 = Pr (x - 0.5) for x < 0.5,
    #   +-1e-16 Pr noise for x >= 0.5 (nodes at x = 0.25 k; the field is linear on [0, 0.5]):
    #   active_length = 0.5 exactly (noise is below the tolerance), the strict measure is not.
    b7n = Case(tmp, E, nu, z, z, z, sig22, z, body_force=False, bcs=False, jitter=0.0)
    xx = b7n.pts[:, 0]
    rng = np.random.default_rng(3)
    stn = b7n.stress.copy()
    stn[:, 1, 1] = np.where(xx < 0.5, Pr * (xx - 0.5), Pr * 1e-16 * rng.standard_normal(len(xx)))
    o, _, _ = b7n.run("energy", stress=stn)
    check("b7n: active_length with noise in the separated zone", o["contact"]["active_length"], 0.5, 1e-13)
    RESULTS.append(("b7n/info: active_length_strict (noise counts)", o["contact"]["active_length_strict"],
                    "", 0.0, True))

    # b8: P1 mesh, sigma_11 += delta: same value as b3 (energy)
    E1, nu1 = 3.0, 0.25
    mu1, lam1 = lame(E1, nu1)
    c1 = lam1 / (2 * mu1 + 2 * lam1)
    q1, q2 = P(0.02, 1, 0), P(-0.03, 0, 1)
    p1 = Case(tmp, E1, nu1, q1, q2, *elastic_stress(q1, q2, mu1, lam1), degree=1, nx=5)
    st = p1.stress.copy()
    st[:, 0, 0] += delta
    o, _, _ = p1.run("energy", stress=st)
    check("b8 P1 s11+=d energy: total", o["functional"]["total"], delta ** 2 * (1 - c1) / (4 * mu1), 1e-10)

    # b9: body normal on the straight bottom gives the same numbers as the obstacle normal
    body = Case(tmp, E, nu, u1, u2, s11, s22, s12, normal="body")
    d = body.disp.copy()
    d[:, 1] -= delta
    o, _, _ = body.run("energy", disp=d)
    check("b9 body normal: complementarity", o["functional"]["complementarity"], -delta * N, 1e-11)


def test_scaling(tmp):
    print("(c) scaling ...", flush=True)
    E, nu = 210.0, 0.3
    mu, lam, u1, u2, s11, s22, s12 = base_solution(E, nu)
    case = Case(tmp, E, nu, u1, u2, s11, s22, s12, friction=0.0)
    x, y = case.pts.T
    d = case.disp.copy()
    d[:, 0] += 1e-3 * x ** 2
    d[:, 1] += 2e-4 * (x - 0.4) ** 2          # sign-changing gap residual
    st = case.stress.copy()
    st[:, 0, 0] += 0.3 * x + 0.1
    st[:, 0, 1] += 0.05 * y
    st[:, 1, 0] += 0.05 * y
    k = 1e9
    for norm in ("energy", "robust"):
        o1, _, _ = case.run(norm, disp=d, stress=st)
        o2, _, _ = case.run(norm, disp=d, stress=st, scale=k)
        check(f"c {norm}: relative(E,sigma,f x 1e9) = relative", o2["relative"], o1["relative"], 1e-12)
        check(f"c {norm}: F x 1e9", o2["functional"]["total"], k * o1["functional"]["total"], 1e-12)
        RESULTS.append((f"c/info {norm}: relative", o1["relative"], "", 0.0, True))


def test_curved(tmp):
    print("(d) curved P2 cells ...", flush=True)
    from .evaluate import diameter
    from .fem import cell_fields, edge_fields, gauss, tri_rule
    from .mesh import read_solution
    from .scene import load_scene

    E, nu = 210.0, 0.3
    mu, lam = lame(E, nu)
    n, sag = 4, 0.1
    # sigma = -p I, u = -k x with k = p/(2(mu+lam)) so that eps(u) = A sigma exactly
    # (linear fields are reproduced by the isoparametric P2 map), f = 0.
    pr = 3.0
    kk = pr / (2 * (mu + lam))
    u1, u2 = P(-kk, 1, 0), P(-kk, 0, 1)
    cs = Poly2([[-pr]])
    z = Poly2([[0.0]])
    for normal in ("obstacle", "body"):
        case = Case(tmp, E, nu, u1, u2, cs, cs, z, normal=normal, body_force=False, bcs=False,
                    nx=n, bottom_sag=sag)
        # obstacle plane y = -1 (m = (0,1), p = (0,-1))
        vtu = write_case(tmp, f"curved_{normal}", case.pts, case.cells, case.lines, case.tags,
                         case.disp, case.stress)
        txt = case.scene("energy").replace("point = [0.0, 0.0]", "point = [0.0, -1.0]")
        sc = write_text(tmp, f"curved_{normal}.toml", txt)
        o = evaluate_files(vtu, sc)
        # area of each parabolic segment = 2/3 chord * height (Archimedes): area = 1 + n*(2/3)(1/n)(sag/n)
        area = 1.0 + (2.0 / 3.0) * sag / n
        # energy = 1/2 (C eps, eps) area = (2 mu + 2 lam) k^2 area  (eps = -k I)
        check(f"d {normal}: energy = (2mu+2lam)k^2 * area", o["energy"], (2 * mu + 2 * lam) * kk ** 2 * area, 1e-12)
        # (the body does not touch the plane y = -1, so only the cell terms vanish here)
        check_lt(f"d {normal}: (F_const + F_div)/energy (linear u, constant sigma, curved cells)",
                 (o["functional"]["constitutive"] + o["functional"]["equilibrium"]) / o["energy"], 1e-20)
        # arc length of x(s) = A + s L e + 4 h s(1-s) nu:  (1/(4h)) [2h sqrt(L^2+16h^2) + L^2/2 asinh(4h/L)]
        L, h = 1.0 / n, sag / n
        arc = n * (2 * h * math.sqrt(L * L + 16 * h * h) + 0.5 * L * L * math.asinh(4 * h / L)) / (4 * h)
        check(f"d {normal}: contact_length = parabola arc length", o["contact"]["contact_length"], arc, 1e-13)
        check(f"d {normal}: active_length = arc length", o["contact"]["active_length"], arc, 1e-13)
        if normal == "obstacle":
            # sigma_n = n.(sigma n_O) = (0,-1).(-p n_O) = p n_O,y: normal_force = -p int n_y ds = p * 1
            check("d obstacle: normal_force = p (projected length)", o["contact"]["normal_force"], pr, 1e-13)
            # sigma_t = (1,0).(-p n_O) = -p n_x; max |n_x| = 4h / sqrt(L^2 + 16 h^2) (edge ends)
            check("d obstacle: cone_violation_max = p 4h/sqrt(L^2+16h^2)",
                  o["admissibility"]["cone_violation_max"], pr * 4 * h / math.sqrt(L * L + 16 * h * h), 1e-12)
            check("d obstacle: tangential force = 0", o["contact"]["tangential_force"], 0.0, atol=1e-14)
        else:
            # body normal: sigma_n = -p, normal force = p * arc length; sigma_t = 0
            check("d body: normal_force = p * arc", o["contact"]["normal_force"], pr * arc, 1e-13)
            check_lt("d body: cone_violation_max = 0", o["admissibility"]["cone_violation_max"], 1e-13)
        # complementarity: independent parametrisation + scipy quad.
        # body: n = n_O, g = (y + 1)/(-n_y);  obstacle: n = (0,-1), g = y + 1; sigma_n as above.
        tot = 0.0
        for A, B, M in case.bottom:
            if A[0] > B[0]:
                A, B = B, A

            def integrand(s, A=A, B=B, M=M):
                xs = A * (1 - s) * (1 - 2 * s) + B * s * (2 * s - 1) + M * 4 * s * (1 - s)
                T = A * (4 * s - 3) + B * (4 * s - 1) + M * (4 - 8 * s)
                jac = math.hypot(*T)
                nO = np.array([T[1], -T[0]]) / jac            # left-to-right traversal: outward = down
                uu = -kk * xs
                if normal == "body":
                    nn, g, sn = nO, (xs[1] + 1.0) / (-nO[1]), -pr
                else:
                    nn, g = np.array([0.0, -1.0]), xs[1] + 1.0
                    sn = nn @ (-pr * nO)
                return (nn @ uu - g) * sn * jac
            tot += quad(integrand, 0.0, 1.0, epsabs=0.0, epsrel=1e-13, limit=200)[0]
        check(f"d {normal}: complementarity vs scipy.quad", o["functional"]["complementarity"], tot, 1e-12)

    # area and a divergence-theorem identity for a P2 (isoparametric) tensor field:
    #   sum_T int_T div tau dx = int_dOmega tau n_O ds exactly (both integrands are polynomials
    #   in reference coordinates: adj(J) grad tau and tau J^perp).
    sol = read_solution(vtu, load_scene(sc))
    rng = np.random.default_rng(5)
    sol.stress = rng.standard_normal(sol.stress.shape)
    X, W = tri_rule(19)
    q = cell_fields(sol, np.arange(len(sol.cells)), X)
    dx = np.abs(q["det"]) * W
    check("d area = 1 + (2/3) sag/n", float(dx.sum()), 1.0 + (2.0 / 3.0) * sag / n, 1e-14)
    # int x dx: the segment below edge k has centroid x at its chord middle (symmetric parabola)
    xm = np.array([0.5 * (A[0] + B[0]) for A, B, M in case.bottom])
    check("d int x dx = 1/2 + sum (2/3) L h x_mid", float(np.sum(q["x"][..., 0] * dx)),
          0.5 + float(np.sum((2.0 / 3.0) * (1 / n) * (sag / n) * xm)), 1e-14)
    lhs = np.einsum("cqa,cq->a", q["div"], dx)
    s, w = gauss(20)
    S = np.broadcast_to(s, (len(sol.bedge_cell), len(s)))
    E_ = edge_fields(sol, sol.bedge_cell, sol.bedge_local, S)
    rhs = np.einsum("esab,esb,es,s->a", E_["tau"], E_["n"], E_["jac"], w)
    check("d divergence theorem (row 1)", lhs[0], rhs[0], 1e-12, atol=1e-13)
    check("d divergence theorem (row 2)", lhs[1], rhs[1], 1e-12, atol=1e-13)
    # diameter over mesh points (vertices and mid nodes): the corners still give sqrt(2)
    check("d diameter (mesh points) = sqrt(2)", diameter(sol), math.sqrt(2.0), 1e-15)
    # quadrature convergence on a curved mesh with a non-trivial field
    sol2 = read_solution(vtu, load_scene(sc))
    sol2.stress = sol2.stress + rng.standard_normal(sol2.stress.shape) * 0.1
    from .evaluate import evaluate
    sce = load_scene(sc)
    o19 = evaluate(sol2, sce, cell_order=19)
    o30 = evaluate(sol2, sce, cell_order=30, edge_points=30)
    check("d curved: F(order 19) vs F(order 30, 30 edge pts)", o19["functional"]["total"],
          o30["functional"]["total"], 1e-12)


def test_formats(tmp):
    print("file formats ...", flush=True)
    E, nu = 210.0, 0.3
    mu, lam, u1, u2, s11, s22, s12 = base_solution(E, nu)
    case = Case(tmp, E, nu, u1, u2, s11, s22, s12, friction=0.25)
    x, y = case.pts.T
    d = case.disp.copy()
    d[:, 0] += 1e-3 * (x - 0.45) ** 2 - 1e-5
    d[:, 1] += 2e-4 * (x - 0.4) ** 2
    st = case.stress.copy()
    st[:, 0, 0] += 0.3 * x + 0.1
    st[:, 0, 1] += 0.05 * y + 0.01
    st[:, 1, 0] += 0.05 * y + 0.01
    ref, _, _ = case.run("energy", disp=d, stress=st, with_cells=True)
    check("cells: sum of eta_T^2 = F", float(np.sum(ref["cells"]["eta2"])), ref["functional"]["total"], 1e-13)
    check("cells: sum of friction_T = friction", float(np.sum(ref["cells"]["friction"])),
          ref["functional"]["friction"], 1e-13)
    keys = ("total", "constitutive", "equilibrium", "complementarity", "friction")
    variants = [dict(ncomp=3), dict(ncomp=6), dict(ncomp=4, binary=False),
                dict(ncomp=4, compression=None), dict(ncomp=4, exploded=True)]
    for v in variants:
        o, _, _ = case.run("energy", disp=d, stress=st, **v)
        # meshio's ascii writer keeps 12 significant digits: compare at 1e-10 there
        rt = 1e-10 if v.get("binary") is False else 1e-13
        for k in keys:
            check(f"formats {v}: {k}", o["functional"][k], ref["functional"][k], rt, atol=1e-18)
        check(f"formats {v}: active_length", o["contact"]["active_length"], ref["contact"]["active_length"], 1e-13)
    # ComponentName attributes (columns permuted to xx, xy, yy, zz and named so) and an explicit
    # stress_layout in the scene must give the reference values
    import meshio
    import re
    _, vtu, _ = case.run("energy", disp=d, stress=st)
    m = meshio.read(vtu)
    m.point_data["stress"] = m.point_data["stress"][:, [0, 3, 1, 2]]
    p2 = os.path.join(tmp, "permuted.vtu")
    meshio.write(p2, m, binary=True, compression="zlib")
    raw = open(p2).read()
    named = re.sub(r'Name="stress"', 'Name="stress" ComponentName0="XX" ComponentName1="XY" '
                   'ComponentName2="YY" ComponentName3="ZZ"', raw, count=1)
    p3 = os.path.join(tmp, "named.vtu")
    open(p3, "w").write(named)
    sc = write_text(tmp, "named.toml", case.scene("energy"))
    o = evaluate_files(p3, sc)
    check("formats ComponentName (xx,xy,yy,zz): total", o["functional"]["total"], ref["functional"]["total"], 1e-13)
    sc2 = write_text(tmp, "layout.toml", case.scene("energy").replace(
        "[boundaries]", "[fields]\nstress_layout = \"xx,xy,yy,zz\"\n[boundaries]"))
    o = evaluate_files(p2, sc2)
    check("formats scene stress_layout (xx,xy,yy,zz): total", o["functional"]["total"], ref["functional"]["total"], 1e-13)
    o = evaluate_files(p2, sc, layout="xx,xy,yy,zz")
    check("formats --stress-layout override: total", o["functional"]["total"], ref["functional"]["total"], 1e-13)

    # 9 components (row-major) with a non-symmetric tensor: compare to a hand-built value:
    # tau_12 = tau_21 + delta: A tau changes by delta/(2mu) E12 (no trace change), so
    # e_12 -= delta/(2mu) only: energy term = mu (delta/(2mu))^2 = delta^2/(4mu) (exact field).
    st9 = case.stress.copy()
    delta = 1e-3
    st9[:, 0, 1] += delta
    o, _, _ = case.run("energy", stress=st9, ncomp=9)
    check("formats 9 comps non-symmetric: constitutive", o["functional"]["constitutive"],
          delta ** 2 / (4 * mu), 1e-10)
    RESULTS.append(("info: reference functional for formats case", ref["functional"]["total"], "", 0.0, True))


def test_errors(tmp):
    print("bad input ...", flush=True)
    E, nu = 210.0, 0.3
    mu, lam, u1, u2, s11, s22, s12 = base_solution(E, nu)
    case = Case(tmp, E, nu, u1, u2, s11, s22, s12)
    _, vtu, sc = case.run("energy")
    good = open(sc).read()
    bad = {
        "unknown key": good + "\n[estimate2]\nx = 1\n",
        "tag absent": good.replace("tag = 1\n", "tag = 7\n"),
        "selector matches nothing": good.replace("x > 0.999", "x > 5"),
        "missing youngs_modulus": good.replace("youngs_modulus", "young"),
        "bad expression": good.replace("x > 0.999", "__import__('os')"),
    }
    for name, text in bad.items():
        p = write_text(tmp, "bad.toml", text)
        try:
            evaluate_files(vtu, p)
            check(f"errors: {name} -> InputError", 0.0, 1.0)
        except InputError:
            check(f"errors: {name} -> InputError", 1.0, 1.0)
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    r = subprocess.run([sys.executable, "-m", "fosls_ref", "evaluate", vtu, p, "--quiet"],
                       capture_output=True, text=True, env=env)
    check("cli: bad input exit status 2", float(r.returncode), 2.0)
    out = os.path.join(tmp, "out.json")
    r = subprocess.run([sys.executable, "-m", "fosls_ref", "evaluate", vtu, sc, "--json", out, "--quiet"],
                       capture_output=True, text=True, env=env)
    ok = r.returncode == 0 and set(json.load(open(out))) >= {"norm", "functional", "eta", "energy",
                                                              "relative", "admissibility", "contact", "cells"}
    check("cli: evaluate exit 0 and JSON keys", float(ok), 1.0)


def main():
    with tempfile.TemporaryDirectory() as tmp:
        test_exact(tmp)
        test_perturbations(tmp)
        test_scaling(tmp)
        test_curved(tmp)
        test_formats(tmp)
        test_errors(tmp)
    nfail = 0
    print()
    for name, val, exp, err, ok in RESULTS:
        nfail += not ok
        vs = f"{val:.16e}" if isinstance(val, float) else str(val)
        es = f"{exp:.16e}" if isinstance(exp, float) else str(exp)
        er = f"{err:.2e}" if isinstance(err, float) else str(err)
        print(f"{'ok  ' if ok else 'FAIL'} {name:70s} {vs:>24s}  expected {es:>24s}  err {er}")
    print(f"\n{len(RESULTS) - nfail} passed, {nfail} failed")
    return 1 if nfail else 0


if __name__ == "__main__":
    sys.exit(main())
