"""Scene file (TOML) of docs/design.md §7: parsing and validation."""
import math
import tomllib
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .expr import Expr, ExprError, ScalarField, VectorField

_TOP = {"material", "fields", "loads", "boundaries", "boundary", "estimate"}
_KEYS = {
    "material": {"youngs_modulus", "poisson_ratio", "model"},
    "fields": {"displacement", "stress", "stress_layout"},
    "loads": {"body_force"},
    "boundaries": {"tag_array"},
    "estimate": {"norm", "length_scale"},
}
_BKEYS_COMMON = {"name", "tag", "where", "kind"}
_BKEYS = {
    "dirichlet": {"displacement"},
    "neumann": {"traction"},
    "contact": {"obstacle", "gap", "normal", "friction"},
}


@dataclass
class Material:
    E: float
    nu: float
    model: str
    mu: float = 0.0
    lam: float = 0.0  # effective lambda (lambda* for plane stress); math.inf for nu = 0.5 plane strain

    def __post_init__(self):
        self.mu = self.E / (2.0 * (1.0 + self.nu))
        if self.nu == 0.5:
            lam = math.inf
        else:
            lam = self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        if self.model == "plane_stress":
            # lambda* = 2 lam mu / (lam + 2 mu); limit 2 mu for lam -> inf
            lam = 2.0 * self.mu if math.isinf(lam) else 2.0 * lam * self.mu / (lam + 2.0 * self.mu)
        self.lam = lam

    @property
    def incompressible(self):
        return math.isinf(self.lam)

    @property
    def trace_coef(self):
        """c in A tau = (tau - c tr(tau) I)/(2 mu), c = lam/(2 mu + d lam), d = 2."""
        if math.isinf(self.lam):
            return 0.5
        return self.lam / (2.0 * self.mu + 2.0 * self.lam)


@dataclass
class Boundary:
    index: int
    name: str
    kind: str
    tag: int | None = None
    where: Expr | None = None
    displacement: VectorField | None = None
    traction: VectorField | None = None
    # contact
    plane_point: np.ndarray | None = None
    plane_normal: np.ndarray | None = None  # unit m, from obstacle towards the body
    gap: ScalarField | None = None
    normal: str = "body"
    friction: float = 0.0


@dataclass
class Scene:
    path: str
    material: Material
    displacement_name: str | None = None
    stress_name: str | None = None
    stress_layout: str | None = None
    body_force: VectorField | None = None
    tag_array: str | None = None
    boundaries: list = field(default_factory=list)
    norm: str | None = None
    length_scale: float | None = None
    unknown_keys: list = field(default_factory=list)


def _num(v, where, path, positive=False, nonneg=False):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{path}: {where}: expected a finite number, got {v!r}")
    if positive and not v > 0:
        raise InputError(f"{path}: {where}: must be > 0, got {v!r}")
    if nonneg and not v >= 0:
        raise InputError(f"{path}: {where}: must be >= 0, got {v!r}")
    return float(v)


def load_scene(path, allow_unknown=False):
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(f"{path}: scene file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: TOML syntax error: {exc}") from None
    return parse_scene(data, path, allow_unknown)


def parse_scene(data, path="<scene>", allow_unknown=False):
    unknown = []

    def check_keys(table, allowed, where):
        if not isinstance(table, dict):
            raise InputError(f"{path}: [{where}] must be a table")
        for k in table:
            if k not in allowed:
                unknown.append(f"{where}.{k}")

    check_keys(data, _TOP, "")
    for sec, keys in _KEYS.items():
        if sec in data:
            check_keys(data[sec], keys, sec)

    if "material" not in data:
        raise InputError(f"{path}: missing required table [material]")
    m = data["material"]
    for k in ("youngs_modulus", "poisson_ratio"):
        if k not in m:
            raise InputError(f"{path}: missing required key material.{k}")
    E = _num(m["youngs_modulus"], "material.youngs_modulus", path, positive=True)
    nu = _num(m["poisson_ratio"], "material.poisson_ratio", path)
    if not (-1.0 < nu <= 0.5):
        raise InputError(f"{path}: material.poisson_ratio = {nu} outside (-1, 0.5]")
    model = m.get("model", "plane_strain")
    if model not in ("plane_strain", "plane_stress"):
        raise InputError(f"{path}: material.model = {model!r}: expected plane_strain or plane_stress")
    scene = Scene(path=path, material=Material(E, nu, model))

    f = data.get("fields", {})
    for k in ("displacement", "stress", "stress_layout"):
        if k in f and not isinstance(f[k], str):
            raise InputError(f"{path}: fields.{k} must be a string")
    scene.displacement_name = f.get("displacement")
    scene.stress_name = f.get("stress")
    scene.stress_layout = f.get("stress_layout")

    loads = data.get("loads", {})
    if "body_force" in loads:
        try:
            scene.body_force = VectorField(loads["body_force"])
        except ExprError as exc:
            raise InputError(f"{path}: loads.body_force: {exc}") from None

    b = data.get("boundaries", {})
    if "tag_array" in b:
        if not isinstance(b["tag_array"], str):
            raise InputError(f"{path}: boundaries.tag_array must be a string")
        scene.tag_array = b["tag_array"]

    blist = data.get("boundary", [])
    if not isinstance(blist, list):
        raise InputError(f"{path}: [[boundary]] must be an array of tables")
    for i, bd in enumerate(blist):
        where = f"boundary[{i}]"
        if not isinstance(bd, dict):
            raise InputError(f"{path}: {where} must be a table")
        kind = bd.get("kind")
        if kind not in _BKEYS:
            raise InputError(f"{path}: {where}.kind = {kind!r}: expected dirichlet, neumann or contact")
        check_keys(bd, _BKEYS_COMMON | _BKEYS[kind], where)
        name = bd.get("name", f"boundary{i}")
        bo = Boundary(index=i, name=str(name), kind=kind)
        if ("tag" in bd) == ("where" in bd):
            raise InputError(f"{path}: {where} ({name}): give exactly one of `tag` or `where`")
        if "tag" in bd:
            t = bd["tag"]
            if isinstance(t, bool) or not isinstance(t, int):
                raise InputError(f"{path}: {where}.tag must be an integer")
            bo.tag = t
            if scene.tag_array is None:
                raise InputError(f"{path}: {where}.tag used but boundaries.tag_array is missing")
        else:
            try:
                bo.where = Expr(bd["where"])
            except ExprError as exc:
                raise InputError(f"{path}: {where}.where: {exc}") from None
        try:
            if kind == "dirichlet":
                if "displacement" not in bd:
                    raise InputError(f"{path}: missing required key {where}.displacement")
                bo.displacement = VectorField(bd["displacement"])
            elif kind == "neumann":
                bo.traction = VectorField(bd.get("traction", [0.0, 0.0]))
            else:
                bo.normal = bd.get("normal", "body")
                if bo.normal not in ("body", "obstacle"):
                    raise InputError(f"{path}: {where}.normal = {bo.normal!r}: expected body or obstacle")
                bo.friction = _num(bd.get("friction", 0.0), f"{where}.friction", path, nonneg=True)
                if ("obstacle" in bd) == ("gap" in bd):
                    raise InputError(f"{path}: {where} ({name}): give exactly one of `obstacle` or `gap`")
                if "gap" in bd:
                    bo.gap = ScalarField(bd["gap"])
                    if bo.normal == "obstacle":
                        raise InputError(f"{path}: {where}: normal = \"obstacle\" needs an `obstacle`, not `gap`")
                else:
                    ob = bd["obstacle"]
                    if not isinstance(ob, dict) or set(ob) != {"plane"}:
                        raise InputError(f"{path}: {where}.obstacle: only {{ plane = {{ point, normal }} }} is supported")
                    pl = ob["plane"]
                    if not isinstance(pl, dict) or set(pl) != {"point", "normal"}:
                        raise InputError(f"{path}: {where}.obstacle.plane needs exactly `point` and `normal`")
                    p = [_num(v, f"{where}.obstacle.plane.point", path) for v in pl["point"]]
                    mm = [_num(v, f"{where}.obstacle.plane.normal", path) for v in pl["normal"]]
                    if len(p) not in (2, 3) or len(mm) not in (2, 3):
                        raise InputError(f"{path}: {where}.obstacle.plane: point/normal need 2 components")
                    mv = np.array(mm[:2])
                    nrm = np.hypot(mv[0], mv[1])
                    if nrm == 0:
                        raise InputError(f"{path}: {where}.obstacle.plane.normal is zero")
                    bo.plane_point = np.array(p[:2])
                    bo.plane_normal = mv / nrm
        except ExprError as exc:
            raise InputError(f"{path}: {where}: {exc}") from None
        scene.boundaries.append(bo)

    est = data.get("estimate", {})
    if "norm" in est:
        if est["norm"] not in ("energy", "robust", "seed"):
            raise InputError(f"{path}: estimate.norm = {est['norm']!r}: expected energy, robust or seed")
        scene.norm = est["norm"]
    if "length_scale" in est:
        scene.length_scale = _num(est["length_scale"], "estimate.length_scale", path, positive=True)

    if unknown:
        if not allow_unknown:
            raise InputError(f"{path}: unknown key(s): {', '.join(unknown)}")
        scene.unknown_keys = unknown
    return scene
