"""Exact bivariate polynomials with rational (Fraction) coefficients.

A polynomial is built from float coefficients (each float is converted to the Fraction of its
exact binary value), so "the" field of a fixture is the polynomial with exactly the float
coefficients that are also written into scene.toml.  Products, derivatives and integrals over
rectangles and intervals are exact; float() is taken only at the very end.
"""
from fractions import Fraction

import numpy as np


def F(v):
    """float/int/Fraction -> Fraction (exact binary value of a float)."""
    if isinstance(v, Fraction):
        return v
    if isinstance(v, int):
        return Fraction(v)
    return Fraction(float(v))


class Poly:
    """sum c[(i, j)] x^i y^j with Fraction coefficients."""

    def __init__(self, coeffs=None):
        self.c = {}
        for k, v in (coeffs or {}).items():
            v = F(v)
            if v != 0:
                self.c[k] = v

    # -- constructors --
    @staticmethod
    def const(v):
        return Poly({(0, 0): v})

    @staticmethod
    def x():
        return Poly({(1, 0): 1})

    @staticmethod
    def y():
        return Poly({(0, 1): 1})

    @staticmethod
    def of(*terms):
        """Poly.of((coef, i, j), ...)"""
        out = {}
        for coef, i, j in terms:
            out[(i, j)] = out.get((i, j), Fraction(0)) + F(coef)
        return Poly(out)

    # -- arithmetic --
    def _lift(self, o):
        return o if isinstance(o, Poly) else Poly.const(o)

    def __add__(self, o):
        o = self._lift(o)
        out = dict(self.c)
        for k, v in o.c.items():
            out[k] = out.get(k, Fraction(0)) + v
        return Poly(out)

    __radd__ = __add__

    def __neg__(self):
        return Poly({k: -v for k, v in self.c.items()})

    def __sub__(self, o):
        return self + (-self._lift(o))

    def __rsub__(self, o):
        return self._lift(o) - self

    def __mul__(self, o):
        if not isinstance(o, Poly):
            o = F(o)
            return Poly({k: v * o for k, v in self.c.items()})
        out = {}
        for (i, j), a in self.c.items():
            for (k, l), b in o.c.items():
                key = (i + k, j + l)
                out[key] = out.get(key, Fraction(0)) + a * b
        return Poly(out)

    __rmul__ = __mul__

    def __truediv__(self, o):
        return self * (Fraction(1) / F(o))

    def dx(self):
        return Poly({(i - 1, j): i * v for (i, j), v in self.c.items() if i > 0})

    def dy(self):
        return Poly({(i, j - 1): j * v for (i, j), v in self.c.items() if j > 0})

    def degree(self):
        return max((i + j for i, j in self.c), default=0)

    def is_zero(self):
        return not self.c

    def rounded(self):
        """The polynomial whose coefficients are the floats of this one's (as Fractions)."""
        return Poly({k: Fraction(float(v)) for k, v in self.c.items()})

    # -- evaluation --
    def __call__(self, x, y):
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        out = np.zeros(np.broadcast(x, y).shape)
        for (i, j), v in sorted(self.c.items()):
            out = out + float(v) * x ** i * y ** j
        return out

    def exact_at(self, x, y):
        x, y = F(x), F(y)
        return sum((v * x ** i * y ** j for (i, j), v in self.c.items()), Fraction(0))

    def restrict_y(self, y0):
        """p(x, y0) as a Poly in x only."""
        y0 = F(y0)
        out = {}
        for (i, j), v in self.c.items():
            out[(i, 0)] = out.get((i, 0), Fraction(0)) + v * y0 ** j
        return Poly(out)

    # -- integrals --
    def integrate_rect(self, x0, x1, y0, y1):
        x0, x1, y0, y1 = map(F, (x0, x1, y0, y1))
        s = Fraction(0)
        for (i, j), v in self.c.items():
            s += v * (x1 ** (i + 1) - x0 ** (i + 1)) / (i + 1) * (y1 ** (j + 1) - y0 ** (j + 1)) / (j + 1)
        return s

    def integrate_x(self, a, b):
        """integral over x in [a, b] of a polynomial in x only."""
        a, b = F(a), F(b)
        assert all(j == 0 for (_, j) in self.c), "integrate_x needs a polynomial of x only"
        return sum((v * (b ** (i + 1) - a ** (i + 1)) / (i + 1) for (i, _), v in self.c.items()),
                   Fraction(0))

    # -- text --
    def expr(self):
        """Expression string of the docs/design.md §7 language with the float coefficients (repr)."""
        if not self.c:
            return "0.0"
        parts = []
        for (i, j), v in sorted(self.c.items(), key=lambda kv: (kv[0][0] + kv[0][1], kv[0])):
            f = float(v)
            mono = "*".join([("x" if i == 1 else f"x^{i}")] * (i > 0) + [("y" if j == 1 else f"y^{j}")] * (j > 0))
            mag = repr(abs(f))
            term = mag if not mono else (mono if abs(f) == 1.0 else f"{mag}*{mono}")
            sign = "-" if f < 0 else "+"
            parts.append((sign, term))
        s = ("-" if parts[0][0] == "-" else "") + parts[0][1]
        for sign, term in parts[1:]:
            s += f" {sign} {term}"
        return s

    def pretty(self):
        return self.expr()

    def __repr__(self):
        return f"Poly({self.expr()})"
