"""Restricted expressions in x, y (and z) for scene files (docs/design.md §7).

Grammar: numbers, the names x, y, z, pi, the operators + - * / ^ (power, also **),
unary -, comparisons (< <= > >= == !=, chains allowed), `and`, `or`, `not`,
parentheses, and the functions sqrt, abs, sin, cos, exp, log, min, max.
`min`/`max` are element-wise (numpy.minimum/maximum, any number of arguments >= 2).
Evaluation walks the Python AST of the expression; nothing is passed to eval().
Results are numpy arrays broadcast to the shape of x.
"""
import ast
from functools import reduce

import numpy as np


class ExprError(ValueError):
    pass


_FUNCS = {
    "sqrt": np.sqrt,
    "abs": np.abs,
    "sin": np.sin,
    "cos": np.cos,
    "exp": np.exp,
    "log": np.log,
    "min": lambda *a: reduce(np.minimum, a),
    "max": lambda *a: reduce(np.maximum, a),
}
_CONSTS = {"pi": np.pi}
_BINOPS = {
    ast.Add: np.add,
    ast.Sub: np.subtract,
    ast.Mult: np.multiply,
    ast.Div: np.true_divide,
    ast.Pow: np.power,
}
_CMPOPS = {
    ast.Lt: np.less,
    ast.LtE: np.less_equal,
    ast.Gt: np.greater,
    ast.GtE: np.greater_equal,
    ast.Eq: np.equal,
    ast.NotEq: np.not_equal,
}


class Expr:
    """A compiled scalar expression; call with arrays x, y (z optional)."""

    def __init__(self, text):
        if not isinstance(text, str):
            raise ExprError(f"expression must be a string, got {text!r}")
        self.text = text
        src = text.replace("^", "**")
        try:
            self.tree = ast.parse(src.strip(), mode="eval")
        except SyntaxError as exc:
            raise ExprError(f"cannot parse expression {text!r}: {exc.msg}") from None
        self._check(self.tree.body)

    def _check(self, node):
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise ExprError(f"{self.text!r}: only numeric constants are allowed")
        elif isinstance(node, ast.Name):
            if node.id not in ("x", "y", "z") and node.id not in _CONSTS:
                raise ExprError(f"{self.text!r}: unknown name {node.id!r}")
        elif isinstance(node, ast.BinOp):
            if type(node.op) not in _BINOPS:
                raise ExprError(f"{self.text!r}: operator not allowed")
            self._check(node.left)
            self._check(node.right)
        elif isinstance(node, ast.UnaryOp):
            if not isinstance(node.op, (ast.USub, ast.UAdd, ast.Not)):
                raise ExprError(f"{self.text!r}: operator not allowed")
            self._check(node.operand)
        elif isinstance(node, ast.Compare):
            for op in node.ops:
                if type(op) not in _CMPOPS:
                    raise ExprError(f"{self.text!r}: comparison not allowed")
            self._check(node.left)
            for c in node.comparators:
                self._check(c)
        elif isinstance(node, ast.BoolOp):
            for v in node.values:
                self._check(v)
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in _FUNCS:
                raise ExprError(f"{self.text!r}: unknown function")
            if node.keywords:
                raise ExprError(f"{self.text!r}: keyword arguments not allowed")
            name = node.func.id
            if name in ("min", "max") and len(node.args) < 2:
                raise ExprError(f"{self.text!r}: {name} needs at least two arguments")
            if name not in ("min", "max") and len(node.args) != 1:
                raise ExprError(f"{self.text!r}: {name} takes one argument")
            for a in node.args:
                self._check(a)
        else:
            raise ExprError(f"{self.text!r}: syntax {type(node).__name__} not allowed")

    def _ev(self, node, env):
        if isinstance(node, ast.Constant):
            return float(node.value)
        if isinstance(node, ast.Name):
            return env[node.id] if node.id in env else _CONSTS[node.id]
        if isinstance(node, ast.BinOp):
            return _BINOPS[type(node.op)](self._ev(node.left, env), self._ev(node.right, env))
        if isinstance(node, ast.UnaryOp):
            v = self._ev(node.operand, env)
            if isinstance(node.op, ast.USub):
                return np.negative(v)
            if isinstance(node.op, ast.UAdd):
                return v
            return np.logical_not(_truth(v))
        if isinstance(node, ast.Compare):
            left = self._ev(node.left, env)
            out = None
            for op, comp in zip(node.ops, node.comparators):
                right = self._ev(comp, env)
                r = _CMPOPS[type(op)](left, right)
                out = r if out is None else np.logical_and(out, r)
                left = right
            return out
        if isinstance(node, ast.BoolOp):
            vals = [_truth(self._ev(v, env)) for v in node.values]
            f = np.logical_and if isinstance(node.op, ast.And) else np.logical_or
            return reduce(f, vals)
        if isinstance(node, ast.Call):
            return _FUNCS[node.func.id](*[self._ev(a, env) for a in node.args])
        raise ExprError("unreachable")  # pragma: no cover

    def __call__(self, x, y, z=None):
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if z is None:
            z = np.zeros_like(x)
        env = {"x": x, "y": y, "z": np.asarray(z, dtype=float)}
        with np.errstate(all="ignore"):
            v = self._ev(self.tree.body, env)
        v = np.asarray(v)
        if v.dtype == bool:
            v = v.astype(float)
        return np.broadcast_to(v.astype(float), np.broadcast(x, y).shape).copy()

    def selects(self, x, y):
        """Selector semantics of §7: true where the value is > 0 (booleans: where true)."""
        return self(x, y) > 0


def _truth(v):
    v = np.asarray(v)
    return v if v.dtype == bool else (v != 0)


class ScalarField:
    """A number or an expression string, evaluated at points x, y."""

    def __init__(self, spec):
        if isinstance(spec, bool):
            raise ExprError(f"expected a number or an expression string, got {spec!r}")
        if isinstance(spec, (int, float)):
            self.const = float(spec)
            self.expr = None
        elif isinstance(spec, str):
            self.const = None
            self.expr = Expr(spec)
        else:
            raise ExprError(f"expected a number or an expression string, got {spec!r}")

    def __call__(self, x, y):
        x = np.asarray(x, dtype=float)
        if self.expr is None:
            return np.full(np.broadcast(x, np.asarray(y)).shape, self.const)
        return self.expr(x, y)

    @property
    def is_zero(self):
        return self.expr is None and self.const == 0.0


class VectorField:
    """A 2-vector of ScalarField (a 3rd component, if given, must be 0 in 2D)."""

    def __init__(self, spec):
        if not isinstance(spec, (list, tuple)) or len(spec) not in (2, 3):
            raise ExprError(f"expected a list of 2 (or 3) components, got {spec!r}")
        self.comps = [ScalarField(s) for s in spec[:2]]

    def __call__(self, x, y):
        return np.stack([c(x, y) for c in self.comps], axis=-1)

    @property
    def is_zero(self):
        return all(c.is_zero for c in self.comps)
