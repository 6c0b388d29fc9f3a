"""Manufactured smooth contact solutions on the unit square, Gamma_C = bottom y = 0 (n = n_Ω = (0,-1),
t = (1,0), so u_n = -u_y, u_t = u_x, sigma_n = sigma_yy, sigma_t = -sigma_xy on y = 0).

    u_x = w(x) + y m(x) + y^2 A(x,y),      u_y = c0 + y v(x) + y^2 B(x,y)

with p(x) = P0 max(x0 - x, 0)^3 (contact pressure), v = -(p + lam w')/(lam + 2 mu), so that on y = 0
sigma_yy = -p and sigma_xy = mu m.  Frictionless: m = 0.  Coulomb (coefficient F): w = -W0 max(x - x1, 0)^4 max(x2 - x, 0)^4
with x2 = 1 (slip u_t < 0 on x1 < x < x0, stick u_t = 0 on x < x1; the same w is used without friction), m = -F p psi / mu with psi = 1 on the slip zone and
psi = 1 - C max(x1 - x, 0)^4 / x1^4 in [1/2, 1] in the stick zone, so sigma_t = F p psi (= F|sigma_n| where it
slips, strictly inside the cone where it sticks except at x1).  Gap g(x) = -c0 + S0 max(x - x0, 0)^2: active
(u_n = g, sigma_n < 0) on 0 <= x < x0, inactive (u_n < g, sigma_n = 0) on x0 < x <= 1.

Everything (u, sigma, body force f = -div sigma, boundary data) is built as expression strings in the
scene-file language of docs/design.md §7 (max, sin, cos, ^), and evaluated from the same strings in numpy, so
the scene data and the reference solution cannot disagree.  self_test() checks the derivatives by
finite differences.  u is C^2 across x = x0 (p is C^2) and C^3 across x = x1, u in H^{3.5-}: enough for
the optimal rates of P1 and P2; f = -div sigma is continuous.
"""
import numpy as np

E, NU = 1000.0, 0.3
MU = E / (2 * (1 + NU))
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
X0, X1 = 0.6, 0.3
C0 = -0.01
X2 = 1.0
P0 = 10.0 / X0 ** 3                                  # p(0) = 10
W0 = 0.0005 / ((X2 - X1) / 2) ** 8                   # max |w| = 0.0005 (at x = (x1 + x2)/2)
S0 = 0.005 / (1 - X0) ** 2                           # extra gap 0.005 at x = 1
ALPHA, BETA = 0.002, 0.002
CPSI = 0.5


def configure(x0, x1, w_max=0.0005):
    """Moves the end of the contact zone (x0) and of the stick zone (x1) and sets max |w| (the slip
    profile); the other constants follow (p(0) = 10, extra gap 0.005 at x = 1).  x0 = 0.5 puts the
    kink of f = -div sigma (from p'') onto a mesh line of every n x n mesh with n even, and w_max = 0
    (frictionless only) removes the degree-8 slip profile, whose high derivatives keep coarse meshes
    pre-asymptotic: u, sigma and f are then smooth on every cell and the P2/RT_1 pair converges at the
    optimal rate h^2 from n = 4 on (with x0 = 0.6 the kinks cut through cells and limit the
    equilibrium term to h^1.5)."""
    global X0, X1, P0, W0, S0
    X0, X1 = float(x0), float(x1)
    P0 = 10.0 / X0 ** 3
    W0 = float(w_max) / ((X2 - X1) / 2) ** 8
    S0 = 0.005 / (1 - X0) ** 2


def r(v):
    return repr(float(v))


def q(k, t):
    return f"max({t}, 0)^{k}" if k > 1 else f"max({t}, 0)"


class Exact:
    def __init__(self, friction=0.0):
        F = self.F = float(friction)
        a, b = f"(x - {r(X1)})", f"({r(X0)} - x)"
        c = f"({r(X1)} - x)"
        L, M2 = r(LAM), r(LAM + 2 * MU)
        s = {}
        s["p"] = f"{r(P0)}*{q(3, b)}"
        s["p1"] = f"(-{r(3 * P0)}*{q(2, b)})"
        s["p2"] = f"{r(6 * P0)}*{q(1, b)}"
        d = f"({r(X2)} - x)"
        A0, A1, A2, A3 = q(4, a), f"4*{q(3, a)}", f"12*{q(2, a)}", f"24*{q(1, a)}"
        B0, B1, B2, B3 = q(4, d), f"(-4*{q(3, d)})", f"12*{q(2, d)}", f"(-24*{q(1, d)})"
        w0 = r(W0)
        s["w"] = f"(-{w0}*{A0}*{B0})"
        s["w1"] = f"(-{w0}*({A1}*{B0} + {A0}*{B1}))"
        s["w2"] = f"(-{w0}*({A2}*{B0} + 2*{A1}*{B1} + {A0}*{B2}))"
        s["w3"] = f"(-{w0}*({A3}*{B0} + 3*{A2}*{B1} + 3*{A1}*{B2} + {A0}*{B3}))"
        k = CPSI / X1 ** 4
        s["psi"] = f"(1 - {r(k)}*{q(4, c)})"
        s["psi1"] = f"({r(4 * k)}*{q(3, c)})"
        s["psi2"] = f"(-{r(12 * k)}*{q(2, c)})"
        if F > 0:
            fm = r(F / MU)
            s["m"] = f"(-{fm}*{s['p']}*{s['psi']})"
            s["m1"] = f"(-{fm}*({s['p1']}*{s['psi']} + {s['p']}*{s['psi1']}))"
            s["m2"] = f"(-{fm}*({s['p2']}*{s['psi']} + 2*{s['p1']}*{s['psi1']} + {s['p']}*{s['psi2']}))"
        else:
            s["m"] = s["m1"] = s["m2"] = "0"
        s["v"] = f"(-({s['p']} + {L}*{s['w1']})/{M2})"
        s["v1"] = f"(-({s['p1']} + {L}*{s['w2']})/{M2})"
        s["v2"] = f"(-({s['p2']} + {L}*{s['w3']})/{M2})"
        al, be = r(ALPHA), r(BETA)
        s["A"], s["Ax"], s["Ay"] = f"{al}*sin(2*x + y)", f"{r(2 * ALPHA)}*cos(2*x + y)", f"{al}*cos(2*x + y)"
        s["Axx"], s["Ayy"], s["Axy"] = f"(-{r(4 * ALPHA)}*sin(2*x + y))", f"(-{al}*sin(2*x + y))", f"(-{r(2 * ALPHA)}*sin(2*x + y))"
        s["B"], s["Bx"], s["By"] = f"{be}*cos(x - 2*y)", f"(-{be}*sin(x - 2*y))", f"{r(2 * BETA)}*sin(x - 2*y)"
        s["Bxx"], s["Byy"], s["Bxy"] = f"(-{be}*cos(x - 2*y))", f"(-{r(4 * BETA)}*cos(x - 2*y))", f"{r(2 * BETA)}*cos(x - 2*y)"
        e = {}
        e["u1"] = f"({s['w']} + y*{s['m']} + y^2*{s['A']})"
        e["u2"] = f"({r(C0)} + y*{s['v']} + y^2*{s['B']})"
        e["u1x"] = f"({s['w1']} + y*{s['m1']} + y^2*{s['Ax']})"
        e["u1y"] = f"({s['m']} + 2*y*{s['A']} + y^2*{s['Ay']})"
        e["u2x"] = f"(y*{s['v1']} + y^2*{s['Bx']})"
        e["u2y"] = f"({s['v']} + 2*y*{s['B']} + y^2*{s['By']})"
        e["u1xx"] = f"({s['w2']} + y*{s['m2']} + y^2*{s['Axx']})"
        e["u1yy"] = f"(2*{s['A']} + 4*y*{s['Ay']} + y^2*{s['Ayy']})"
        e["u1xy"] = f"({s['m1']} + 2*y*{s['Ax']} + y^2*{s['Axy']})"
        e["u2xx"] = f"(y*{s['v2']} + y^2*{s['Bxx']})"
        e["u2yy"] = f"(2*{s['B']} + 4*y*{s['By']} + y^2*{s['Byy']})"
        e["u2xy"] = f"({s['v1']} + 2*y*{s['Bx']} + y^2*{s['Bxy']})"
        mu, lam = r(MU), r(LAM)
        e["sxx"] = f"({M2}*{e['u1x']} + {lam}*{e['u2y']})"
        e["syy"] = f"({lam}*{e['u1x']} + {M2}*{e['u2y']})"
        e["sxy"] = f"({mu}*({e['u1y']} + {e['u2x']}))"
        e["szz"] = f"({lam}*({e['u1x']} + {e['u2y']}))"
        # f = -div sigma
        e["f1"] = f"(-({M2}*{e['u1xx']} + {mu}*{e['u1yy']} + {r(LAM + MU)}*{e['u2xy']}))"
        e["f2"] = f"(-({mu}*{e['u2xx']} + {M2}*{e['u2yy']} + {r(LAM + MU)}*{e['u1xy']}))"
        e["gap"] = f"({r(-C0)} + {r(S0)}*{q(2, f'(x - {r(X0)})')})"
        self.s, self.e = s, e

    def ev(self, name, x, y):
        from evaluate import safe_eval
        x = np.asarray(x, float)
        y = np.asarray(y, float)
        return np.broadcast_to(safe_eval(self.e[name] if name in self.e else self.s[name], x, y), np.broadcast(x, y).shape).astype(float)

    def u(self, x, y):
        return np.stack([self.ev("u1", x, y), self.ev("u2", x, y)], -1)

    def grad(self, x, y):
        return np.stack([np.stack([self.ev("u1x", x, y), self.ev("u1y", x, y)], -1),
                         np.stack([self.ev("u2x", x, y), self.ev("u2y", x, y)], -1)], -2)

    def sigma4(self, x, y):
        return np.stack([self.ev(k, x, y) for k in ("sxx", "syy", "szz", "sxy")], -1)

    def traction(self, nx, ny):
        """expression strings of sigma n for a constant normal (nx, ny)"""
        e = self.e

        def comb(a, b):
            parts = []
            if nx:
                parts.append(f"{r(nx)}*{a}")
            if ny:
                parts.append(f"{r(ny)}*{b}")
            return " + ".join(parts)
        return [comb(e["sxx"], e["sxy"]), comb(e["sxy"], e["syy"])]

    # exact contact quantities on Gamma_C (y = 0, 0 <= x <= 1)
    def contact_exact(self):
        g, w = np.polynomial.legendre.leggauss(20)
        tot_n = tot_t = 0.0
        for a_, b_ in ((0.0, X1), (X1, X0)):
            xs = a_ + (b_ - a_) * 0.5 * (g + 1)
            ws = 0.5 * (b_ - a_) * w
            tot_n += ws @ (-self.ev("syy", xs, 0 * xs))
            tot_t += ws @ (-self.ev("sxy", xs, 0 * xs))
        out = dict(normal_force=float(tot_n), tangential_force=float(tot_t), active_x_range=[0.0, X0],
                   pressure_max=float(P0 * X0 ** 3))
        if self.F > 0:
            out.update(stick_x_range=[0.0, X1], slip_x_range=[X1, X0])
        return out

    def self_test(self, n=50, h=1e-5, seed=1):
        rng = np.random.default_rng(seed)
        x, y = rng.uniform(0.01, 0.99, n), rng.uniform(0.01, 0.99, n)
        err = 0.0
        for base, dx_, dy_ in (("u1", "u1x", "u1y"), ("u2", "u2x", "u2y"), ("u1x", "u1xx", "u1xy"), ("u1y", "u1xy", "u1yy"),
                               ("u2x", "u2xx", "u2xy"), ("u2y", "u2xy", "u2yy")):
            fx = (self.ev(base, x + h, y) - self.ev(base, x - h, y)) / (2 * h)
            fy = (self.ev(base, x, y + h) - self.ev(base, x, y - h)) / (2 * h)
            sc = max(np.abs(self.ev(dx_, x, y)).max(), np.abs(self.ev(dy_, x, y)).max(), 1e-3)
            err = max(err, np.abs(fx - self.ev(dx_, x, y)).max() / sc, np.abs(fy - self.ev(dy_, x, y)).max() / sc)
        # boundary conditions on y = 0
        xs = np.linspace(0, 1, 101)
        z = 0 * xs
        assert np.allclose(self.ev("syy", xs, z), -self.ev("p", xs, z), atol=1e-12)
        assert np.allclose(-self.ev("sxy", xs, z), self.F * self.ev("p", xs, z) * self.ev("psi", xs, z), atol=1e-12)
        gapres = self.ev("gap", xs, z) - (-self.ev("u2", xs, z))
        assert (gapres >= -1e-15).all() and np.all(gapres[xs < X0] < 1e-15) and np.all(gapres[xs > X0] > 0)
        if self.F > 0:
            ut = self.ev("u1", xs, z)
            assert np.all(np.abs(ut[xs <= X1]) < 1e-15) and np.all(ut[(xs > X1) & (xs < X0)] < 0)
        return err
