"""fosls_ref: independent Python reference for the fosls FOSLS functional (docs/design.md §2-§8)."""
__version__ = "0.1.0"

from .errors import InputError  # noqa: F401


def evaluate_files(vtu, scene_path, norm=None, layout=None, allow_unknown=False, **kw):
    """Read SOLUTION.vtu + SCENE.toml and return the result dictionary (see README.md)."""
    from .evaluate import evaluate
    from .mesh import read_solution
    from .scene import load_scene

    scene = load_scene(scene_path, allow_unknown=allow_unknown)
    sol = read_solution(vtu, scene, layout_override=layout)
    out = evaluate(sol, scene, norm=norm, **kw)
    out["version"] = __version__
    return out
