"""One palette (`emonav_drake/palette.py`): no colour is written anywhere else in the
code that draws, and the palette's roles stay apart (also for colour-blind readers)."""

from __future__ import annotations

import ast
import colorsys
import itertools
import json
import re
from pathlib import Path

import numpy as np
import pytest

from emonav_drake import palette
from emonav_drake.planners.legacy import method_label

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "emonav_drake"

# Files of the package that may hold colours of their own, with the reason.
EXEMPT = {
    PACKAGE / "palette.py": "the one definition",
}


# ---------------------------------------------------------------------------------------
# The scan: a colour written as a literal
# ---------------------------------------------------------------------------------------

# keyword arguments that take a colour (matplotlib, and `cmap` for a named colormap)
COLOUR_KWARGS = {
    "c",
    "color",
    "colors",
    "colour",
    "colours",
    "fc",
    "ec",
    "facecolor",
    "edgecolor",
    "facecolors",
    "edgecolors",
    "mfc",
    "mec",
    "markerfacecolor",
    "markeredgecolor",
    "ecolor",
    "cmap",
    "rgba",
}
NOT_A_COLOUR = {"none", "None", "face", "auto", "inherit"}
# a matplotlib format string ("k.-", "C3x--", "ks") with a colour in it
_FMT = re.compile(r"(?:[-.:,ov^<>12348spP*hH+xXDd|_]|C\d|[bgrcmykw])+")
_FMT_COLOUR = re.compile(r"C\d|[bgrcmykw]")
_HEX = re.compile(r"#(?:[0-9a-fA-F]{6}|[0-9a-fA-F]{3})(?![0-9a-zA-Z])")
_CSS_FUNCTION = re.compile(r"\brgba?\(|\bhsla?\(")
_PREFIXED = re.compile(r"^(?:tab|xkcd|css4):")
_GREY_LEVEL = re.compile(r"0?\.\d+|1\.0*")
_CYCLE = re.compile(r"C\d")


def _named_colours() -> set[str]:
    from matplotlib import colors

    return {n for n in colors.CSS4_COLORS} | {"grey", "gray"}


def _colormap_names() -> set[str]:
    import matplotlib

    return set(matplotlib.colormaps)


def _docstrings(tree: ast.AST) -> set[int]:
    ids = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                ids.add(id(body[0].value))
    return ids


def _is_colour_literal(node: ast.AST) -> bool:
    """A literal colour value: a colour string, or a tuple/list of 3–4 plain numbers (or of
    colour strings)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value not in NOT_A_COLOUR
    if isinstance(node, ast.Tuple | ast.List):
        elts = node.elts
        numbers = all(
            isinstance(e, ast.Constant) and isinstance(e.value, int | float) for e in elts
        )
        if numbers and len(elts) in (3, 4):
            return True
        return any(_is_colour_literal(e) for e in elts if not isinstance(e, ast.Starred))
    return False


_COLOUR_NAME = re.compile(r"rgb|colou?r|cmap", re.IGNORECASE)
_COLORMAP_MAKERS = {"from_list", "ListedColormap", "LinearSegmentedColormap"}


def _numeric_triples(node: ast.AST) -> list[ast.AST]:
    """Tuples/lists of 3–4 plain numbers in [0, 1], one of them a float, inside `node`."""
    out = []
    for n in ast.walk(node):
        if isinstance(n, ast.Tuple | ast.List) and len(n.elts) in (3, 4):
            vals = [e.value for e in n.elts if isinstance(e, ast.Constant)]
            if (
                len(vals) == len(n.elts)
                and all(isinstance(v, int | float) and not isinstance(v, bool) for v in vals)
                and all(0 <= v <= 1 for v in vals)
                and any(isinstance(v, float) for v in vals)
            ):
                out.append(n)
    return out


def _name_of(target: ast.AST) -> str:
    return getattr(target, "id", getattr(target, "attr", ""))


def _colour_contexts(tree: ast.AST):
    """Expressions whose numbers are colours: what is assigned to a name saying so (`*_RGB`,
    `colors`), returned by a function saying so (`_cause_color`), given to a colormap."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign | ast.AnnAssign) and node.value is not None:
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(_COLOUR_NAME.search(_name_of(t)) for t in targets):
                yield node.value
        elif isinstance(node, ast.FunctionDef) and _COLOUR_NAME.search(node.name):
            yield from (n.value for n in ast.walk(node) if isinstance(n, ast.Return) and n.value)
        elif isinstance(node, ast.Call):
            if _name_of(node.func) in _COLORMAP_MAKERS:
                yield from node.args
            yield from (kw.value for kw in node.keywords if _COLOUR_NAME.search(kw.arg or ""))


def colour_literals(source: str) -> list[tuple[int, str]]:
    """(line, what) of every colour written as a literal in `source` (Python)."""
    tree = ast.parse(source)
    docs = _docstrings(tree)
    named, cmaps = _named_colours(), _colormap_names()
    found, seen = [], set()
    for expr in _colour_contexts(tree):
        for n in _numeric_triples(expr):
            if id(n) not in seen:
                found.append((n.lineno, ast.unparse(n)))
                seen.update(id(m) for m in ast.walk(n))
    for node in ast.walk(tree):  # breadth first: a call before the literals in it
        if isinstance(node, ast.JoinedStr) and node.values:
            head = node.values[0]
            if isinstance(head, ast.Constant) and head.value == "C" and len(node.values) > 1:
                found.append((node.lineno, ast.unparse(node)))  # f"C{i}": the default cycle
        if isinstance(node, ast.Call):
            name = getattr(node.func, "attr", getattr(node.func, "id", ""))
            for a in node.args:
                if not (isinstance(a, ast.Constant) and isinstance(a.value, str)):
                    continue
                text = a.value
                if name in ("plot", "step", "errorbar", "semilogy", "loglog") and (
                    _FMT.fullmatch(text) and _FMT_COLOUR.search(text)
                ):
                    found.append((node.lineno, f"{name}(..., {text!r})"))
                elif _GREY_LEVEL.fullmatch(text) or _CYCLE.fullmatch(text):
                    found.append((node.lineno, f"{name}(..., {text!r})"))
                else:
                    continue
                seen.add(id(a))
            for kw in node.keywords:
                if id(kw.value) in seen:
                    continue
                if kw.arg in COLOUR_KWARGS and _is_colour_literal(kw.value):
                    found.append((node.lineno, f"{kw.arg}={ast.unparse(kw.value)}"))
                    seen.update(id(n) for n in ast.walk(kw.value))
            if name == "Rgba" and any(
                isinstance(a, ast.Constant) and isinstance(a.value, int | float) for a in node.args
            ):
                found.append((node.lineno, ast.unparse(node)))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            text = node.value
            if id(node) in docs or id(node) in seen:
                continue
            if (
                _HEX.search(text)
                or _CSS_FUNCTION.search(text)
                or _PREFIXED.match(text)
                or text.lower() in named
            ):
                found.append((node.lineno, repr(text)))
        elif (
            isinstance(node, ast.Attribute)
            and node.attr in cmaps
            and getattr(node.value, "attr", getattr(node.value, "id", "")) == "cm"
        ):
            found.append((node.lineno, ast.unparse(node)))
    return sorted(found, key=lambda f: f[0])


def _notebook_code(path: Path) -> list[tuple[int, str]]:
    """(cell number, Python source) of a notebook's code cells, magics blanked."""
    cells = json.loads(path.read_text())["cells"]
    out = []
    for i, c in enumerate(cells):
        if c["cell_type"] == "code":
            lines = "".join(c["source"]).splitlines()
            out.append((i, "\n".join("" if ln.lstrip()[:1] in "%!" else ln for ln in lines)))
    return out


def _drawing_sources() -> list[tuple[str, str]]:
    """(name, source) of the package (less `EXEMPT`), scripts, benchmarks and notebooks."""
    files = [p for p in sorted(PACKAGE.rglob("*.py")) if p not in EXEMPT]
    files += sorted((ROOT / "scripts").glob("*.py")) + sorted((ROOT / "benchmarks").glob("*.py"))
    sources = [(str(p.relative_to(ROOT)), p.read_text()) for p in files]
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        for i, code in _notebook_code(nb):
            sources.append((f"{nb.relative_to(ROOT)} cell {i}", code))
    return sources


def test_the_scan_finds_colours_written_as_literals():
    bad = """
ax.plot(x, y, "k.-", color="0.6")
ax.plot(x, y, "C3x--")
ax.bar(x, y, color=(0.2, 0.4, 0.6), ec="tab:blue", mfc="w")
m.SetObject(path, shape, Rgba(0.1, 0.8, 0.2, 1.0))
colors = plt.cm.tab10.colors
UNKNOWN_RGB = (0.30, 0.30, 0.30)
cmap = LinearSegmentedColormap.from_list("t", [(0.7, 0.8, 0.97), ROBOT_RGB])
bars = [f"C{i}" for i in range(3)]
html = '<div style="color:#222;background:rgba(255,255,255,0.8)">'
label(ax, xy, "0.1")
name = "purple"
"""
    good = """
ax.plot(x, y, "o-", color=palette.ROBOT_RGB, mec=INK_RGB, fc="none")
ax.add_patch(Circle(c, r, fc=(*rgb, 0.45), ec=rgb))
ax.plot(x, y, "s--", label="robot path", ms=0.5)
m.SetTransform(path, RigidTransform([0, 0, 0.5]))
ring_radius = (0.2, 0.35, 0.5)
"""
    found = [what for _, what in colour_literals(bad)]
    assert found == [
        "plot(..., 'k.-')",
        "color='0.6'",
        "plot(..., 'C3x--')",
        "(0.2, 0.4, 0.6)",
        "ec='tab:blue'",
        "mfc='w'",
        "Rgba(0.1, 0.8, 0.2, 1.0)",
        "plt.cm.tab10",
        "(0.3, 0.3, 0.3)",
        "(0.7, 0.8, 0.97)",
        "f'C{i}'",
        """'<div style="color:#222;background:rgba(255,255,255,0.8)">'""",
        "label(..., '0.1')",
        "'purple'",
    ]
    assert colour_literals(good) == []


@pytest.mark.slow
def test_no_colour_is_written_outside_the_palette():
    offences = [
        f"{name}:{line}: {what}"
        for name, source in _drawing_sources()
        for line, what in colour_literals(source)
    ]
    assert not offences, "use a role of emonav_drake/palette.py:\n" + "\n".join(offences)


# ---------------------------------------------------------------------------------------
# The roles stay apart: in hue, and under simulated colour blindness
# ---------------------------------------------------------------------------------------

# Machado, Oliveira & Fernandes (2009), severity 1.0, on linear RGB
CVD = {
    "normal": np.eye(3),
    "protanopia": np.array(
        [
            [0.152286, 1.052583, -0.204868],
            [0.114503, 0.786281, 0.099216],
            [-0.003882, -0.048116, 1.051998],
        ]
    ),  # fmt: skip
    "deuteranopia": np.array(
        [
            [0.367322, 0.860646, -0.227968],
            [0.280085, 0.672501, 0.047413],
            [-0.011820, 0.042940, 0.968881],
        ]
    ),  # fmt: skip
    "tritanopia": np.array(
        [
            [1.255528, -0.076749, -0.178779],
            [-0.078411, 0.930809, 0.147602],
            [0.004733, 0.691367, 0.303900],
        ]
    ),  # fmt: skip
}


def _lab(rgb, vision: str) -> np.ndarray:
    """CIELAB (D65) of an sRGB colour as seen with `vision` (a `CVD` key)."""
    c = np.asarray(rgb, dtype=float)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    lin = np.clip(CVD[vision] @ lin, 0.0, 1.0)
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
    t = (xyz @ lin) / np.array([0.95047, 1.0, 1.08883])
    f = np.where(t > (6 / 29) ** 3, np.cbrt(t), t / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def delta_e(a, b, vision: str = "normal") -> float:
    """CIE76 colour difference of two sRGB colours as seen with `vision`."""
    return float(np.linalg.norm(_lab(a, vision) - _lab(b, vision)))


def _hue_gap(a, b) -> float:
    """Hue difference [deg] of two colours, 180 when either has (almost) no hue."""
    (ha, _, sa), (hb, _, sb) = colorsys.rgb_to_hls(*a), colorsys.rgb_to_hls(*b)
    if min(sa, sb) < 0.15 or min(max(a), max(b)) - min(min(a), min(b)) < 0.1:
        return 180.0
    d = abs(ha - hb) * 360.0
    return min(d, 360.0 - d)


EMOTIONS = dict(zip(("happy", "neutral", "negative"), palette.EMOTION_RGB, strict=True))
# the scene's other roles: never to be read as an emotion
OTHERS = {
    "goal": palette.GOAL_RGB,
    "goal radius": palette.GOAL_RADIUS_RGB,
    "LiDAR rays": palette.LIDAR_RAY_RGB,
    "LiDAR hits": palette.LIDAR_HIT_RGB,
    "robot": palette.ROBOT_RGB,
    "static disc": palette.STATIC_RGB,
    "left footstep": palette.FOOTSTEP_RGB[0],
    "right footstep": palette.FOOTSTEP_RGB[1],
}


@pytest.mark.parametrize("vision", list(CVD))
def test_the_emotions_stay_apart_for_colour_blind_readers(vision):
    for (na, a), (nb, b) in itertools.combinations(EMOTIONS.items(), 2):
        assert delta_e(a, b, vision) > 15, (vision, na, nb, delta_e(a, b, vision))


@pytest.mark.parametrize("role", list(OTHERS))
def test_no_other_role_takes_an_emotions_colour_or_hue(role):
    rgb = OTHERS[role]
    for name, e in EMOTIONS.items():
        assert delta_e(rgb, e) > 40, (role, name)
        for vision in CVD:
            assert delta_e(rgb, e, vision) > 15, (role, name, vision, delta_e(rgb, e, vision))
    if role.startswith(("goal", "LiDAR", "static")):  # no hue at all: black / grey
        assert all(_hue_gap(rgb, e) == 180.0 for e in EMOTIONS.values()), role
    else:
        assert all(_hue_gap(rgb, e) > 30 for e in EMOTIONS.values()), role


def test_goal_and_rays_are_not_the_robot_and_the_footsteps_differ():
    assert delta_e(palette.GOAL_RGB, palette.ROBOT_RGB) > 20
    assert delta_e(palette.LIDAR_RAY_RGB, palette.ROBOT_RGB) > 20
    assert delta_e(palette.LIDAR_RAY_RGB, palette.STATIC_RGB) > 5
    assert delta_e(*palette.FOOTSTEP_RGB) > 20
    assert palette.EMOTION_RGB == tuple(
        palette.OKABE_ITO[n] for n in ("bluish_green", "orange", "vermillion")
    )


def test_meshcat_and_its_replay_legend_draw_with_the_palette():
    from emonav_drake.diagrams import meshcat_viewing as mv
    from emonav_drake.systems import navigation_meshcat_style as style

    def rgb(rgba):
        return (rgba.r(), rgba.g(), rgba.b())

    assert [rgb(c) for c in style.EMOTION_RGBA] == list(palette.EMOTION_RGB)
    assert rgb(style.GOAL_RGBA) == palette.GOAL_RGB and rgb(style.RAY_RGBA) == palette.LIDAR_RAY_RGB
    assert (
        rgb(style.ROBOT_RGBA) == palette.ROBOT_RGB and rgb(style.STATIC_RGBA) == palette.STATIC_RGB
    )
    assert [rgb(c) for c in style.FOOT_RGBA] == list(palette.FOOTSTEP_RGB)
    legend = dict([*mv.LEGEND, *mv.RAYS_LEGEND, *mv.FOOTSTEP_LEGEND])
    assert legend["goal"] == palette.css(palette.GOAL_RGB) == "#000000"
    assert legend["negative pedestrian"] == "#d55e00"
    assert legend["LiDAR rays (per walking step)"] == palette.css(palette.LIDAR_RAY_RGB)
    assert legend["LiDAR returns (per walking step, drawn above the heads)"] == palette.css(
        palette.LIDAR_HIT_RGB
    )


def test_methods_are_named_and_coloured_as_in_every_figure():
    from emonav_drake.evaluation.benchmark_plots import run_labels

    lip_trained = "/x/emonav_drake/data/policy_lgm.pt"
    assert method_label("sac") == "emobipednav"  # an old run's shipped policy
    assert method_label("sac", lip_trained) == "emobipednav"
    assert method_label("policy", lip_trained) == "emobipednav"  # the default then
    assert method_label("sac", "runs/sac/actor.pt") == "sac"  # a SAC-trained actor
    former = "/x/emonav_drake/data/policies/emobipednav_digit_mpc.pt"
    assert method_label("policy", former) == "emobipednav_digit_mpc"  # the default then
    default = "/x/emonav_drake/data/policies/emobipednav_distilled_digit.pt"
    assert method_label("policy", default) == "policy"  # today's default
    assert method_label("policy") == "policy"
    assert method_label("dwa") == "dwa"
    settings = json.loads((ROOT / "benchmarks/results/lip_table2/settings.json").read_text())
    assert run_labels(settings) == {"sac": "emobipednav", "mpc": "mpc", "dwa": "dwa"}
    v3 = json.loads((ROOT / "benchmarks/results/digit_table2_v3/settings.json").read_text())
    assert run_labels(v3)["policy"] == "emobipednav"  # policy_lgm.pt, the default then
    both = {"planners": ["sac", "emobipednav"], "methods": {}}
    assert run_labels(both) == {"sac": "sac", "emobipednav": "emobipednav"}  # never two alike
    names = ["policy", "mpc", "dwa", "round0", "round1", "dwa_digit", "orca"]
    colours = palette.method_colours(names)
    assert len(set(colours)) == len(names)
    assert not set(colours) & set(palette.EMOTION_RGB)
    assert colours[:3] == [palette.METHOD_RGB[m] for m in ("policy", "mpc", "dwa")]


def test_a_benchmark_of_every_method_gives_each_its_own_colour():
    """Table II with every method (three known + eight more): eleven distinct colours, none
    an emotion's (the IDT chart groups its bars by emotion)."""
    from emonav_drake.palette import EMOTION_RGB, method_colours

    names = ["dwa", "mpc", "emobipednav", "single_lgm", "lidar_sac", "sarl", "policy", "ogm"]
    names += ["lndnl", "drlvo", "rgl"]
    colours = method_colours(names)
    assert len(set(colours)) == len(names)
    assert not set(colours) & set(EMOTION_RGB)


def test_a_table_ii_method_keeps_its_colour_in_any_order():
    """The LIP and the Digit charts list the methods in different orders and subsets; each
    of the paper's Table II methods is drawn in the same colour in both."""
    from emonav_drake.palette import method_colours

    lip = ["dwa", "mpc", "emobipednav", "single_lgm", "lidar_sac", "sarl", "policy", "ogm"]
    lip += ["lndnl", "drlvo", "rgl"]
    digit = ["dwa", "lndnl", "drlvo", "lidar_sac", "single_lgm", "ogm", "emobipednav", "sarl"]
    digit += ["rgl", "mpc"]
    a = dict(zip(lip, method_colours(lip), strict=True))
    b = dict(zip(digit, method_colours(digit), strict=True))
    assert all(a[m] == b[m] for m in digit)
