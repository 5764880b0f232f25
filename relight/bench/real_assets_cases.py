"""The cases of :mod:`relight.bench.real_assets`: each a way of rendering every scene (a label,
the ``[render]`` settings it changes, the split-sum case it is judged against), the eight of
that module's docstring, the candidate estimator files of ``--estimator``, the candidate
student files of ``--student`` and the variants of ``--variant``."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from viewer.errors import RelightError

from .real_assets_splats import ESTIMATOR_CASE

SCREEN = {"raytrace": False, "ssao": True, "indirect": True}  # screen-space visibility evidence


@dataclass(frozen=True)
class Case:
    """One rendering of every scene: a label, the ``[render]`` settings it changes and the label
    of the split-sum case with the same visibility evidence (None: it is that baseline)."""

    label: str
    render: dict = field(default_factory=dict)
    baseline: str | None = None


def shadow_net_file() -> Path:
    from assets import ASSET_ROOT

    return ASSET_ROOT / "weights" / "shadow_net_mesh.safetensors"


def sx_student_file() -> Path:
    """The student shipped before the ``ssao`` student, whose network read S(x) (``vis``)."""
    from assets import ASSET_ROOT

    return ASSET_ROOT / "weights" / "students" / "sx-w32x2-split-sun.safetensors"



def estimator_case(label: str, net) -> Case:
    """Split-sum in the frame the estimator file ``net`` was trained on, times its V, judged
    against split-sum screen-space."""
    from viewer.neural.shadow_net import frame_settings, read_shadow_net

    frame = frame_settings(read_shadow_net(net).training)
    return Case(label, {"model": frame["model"], "raytrace": False, "ssao": bool(frame["ssao"]),
                        "indirect": bool(frame["indirect"]),
                        "specular_occlusion": bool(frame["specular_occlusion"]),
                        "shadow_net": str(net)},
                "split-sum, screen")


VARIANT = "; "  # a variant's label: its case's, this, then its settings (variant_case)


def variant_case(case: Case, settings: dict) -> Case:
    """``case`` with ``[render]`` ``settings`` changed (``--variant CASE KEY=VALUE ...``),
    judged against ``case`` itself: what the settings cost or gain against the truth, e.g.
    ``ray_scale=2`` on ``split-sum, rays``."""
    text = " ".join(f"{k}={v}" for k, v in settings.items())
    return Case(f"{case.label}{VARIANT}{text}", case.render | settings, case.label)


def student_cases(name: str, path, v_use: dict) -> tuple[Case, Case, Case]:
    """The student file ``path`` drawn as the shipped one is, with rays, screen-space and the
    estimator's V (``neural NAME, rays`` / ``, screen`` / ``, estimator's V``; ``v_use``: the
    last's settings), each judged against split-sum with the same visibility evidence: a
    candidate scored on the issue's criterion before it ships."""
    return (Case(f"neural {name}, rays", {"model": "neural", "weights": str(path)},
                 "split-sum, rays"),
            Case(f"neural {name}, screen", {"model": "neural", "weights": str(path), **SCREEN},
                 "split-sum, screen"),
            Case(f"neural {name}, estimator's V", {"model": "neural", "weights": str(path),
                                                    **v_use}, "split-sum, estimator's V"))


def cases(estimators: tuple[tuple[str, str], ...] = (),
          variants: tuple[tuple[str, dict], ...] = (),
          students: tuple[tuple[str, str], ...] = ()) -> tuple[Case, ...]:
    """The eight cases of the module docstring (the estimator's frame read from its weights),
    then one case per candidate estimator file of ``estimators`` (``(name, path)``: ``--estimator
    NAME=FILE``), as the shipped file's, labelled ``split-sum, screen + NAME``, three per candidate
    student file of ``students`` (``--student NAME=FILE``: :func:`student_cases`), then one per
    ``variants`` entry ``(label of a case before, [render] settings)``: :func:`variant_case`."""
    net = shadow_net_file()
    # the estimator's V in place of SSAO's O(x) and the student's S(x) (shadow_net_use)
    V_USE = SCREEN | {"shadow_net": str(net), "shadow_net_use": "visibility"}
    base = (Case("split-sum, rays", {"model": "ggx_split_sum"}),
            Case("neural, rays", {"model": "neural"}, "split-sum, rays"),
            Case("split-sum, screen", {"model": "ggx_split_sum", **SCREEN}),
            Case("neural, screen", {"model": "neural", **SCREEN}, "split-sum, screen"),
            Case("neural S(x), screen",
                 {"model": "neural", "weights": str(sx_student_file()), **SCREEN},
                 "split-sum, screen"),
            estimator_case(ESTIMATOR_CASE + "estimator", net),
            Case("split-sum, estimator's V", {"model": "ggx_split_sum", **V_USE}),
            Case("neural, estimator's V", {"model": "neural", **V_USE},
                 "split-sum, estimator's V"),
            *(estimator_case(ESTIMATOR_CASE + name, path) for name, path in estimators),
            *(c for name, path in students for c in student_cases(name, path, V_USE)))
    by_label = {c.label: c for c in base}
    for label, _ in variants:
        if label not in by_label:
            raise RelightError(f"no case {label!r} (one of: {', '.join(by_label)})",
                               where="--variant")
    out = base + tuple(variant_case(by_label[label], dict(s)) for label, s in variants)
    student_labels = {c.label for name, path in students
                      for c in student_cases(name, path, V_USE)}
    seen: set[str] = set()
    for c in out:  # one label, one image: a repeated one would replace another case's
        if c.label in seen:
            where = "--estimator" if c.label.startswith(ESTIMATOR_CASE) else \
                "--student" if c.label in student_labels else "--variant"
            raise RelightError(f"the case {c.label!r} is given twice", where=where)
        seen.add(c.label)
    return out
