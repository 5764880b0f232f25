"""The bench against truth: every mesh model and knob scored against a path-traced reference.

For every scene in ``assets/scenes/reference/`` whose reference ``assets/references/<stem>.exr``
is stored (Mitsuba 3, our BSDF, pixel-centre rays; :mod:`relight.reference`), each case of the
bench that shades meshes is rendered at the reference's own size and scored twice with
:func:`relight.reference.compare.score` (energy bias, median per-pixel relative error, PSNR over
covered pixels):

* ``*_truth``: against the path-traced reference (visibility, inter-reflection included): what a
  user sees;
* ``*_mc``: against a converged ``ggx_mc`` render of the same scene (``truth_spp`` samples, the
  same integrand with no visibility): the model's approximation error alone. The difference of the
  two is what the rasteriser's missing visibility costs.

The converged ``ggx_mc`` is rendered once per scene as two halves with independent seeds; their
mean is the image and ``|a - b| / 2`` estimates its per-pixel standard error (an unbiased, if
noisy, estimate of the variance of a two-sample mean), so ``bias_noise_mc`` is meaningful too. It
is cached in the bench's cache folder beside a hash of the scene file.

Rows (``kind = "truth"``) join the bench's other rows, are logged to ``rows.jsonl`` and resume like
them; :func:`truth_summary` aggregates them per case for the tables and the Pareto plot.
"""
from __future__ import annotations

import hashlib
import math
import statistics
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from assets import ASSET_ROOT
from relight.reference import Reference, read_reference, write_reference
from relight.reference.compare import score
from viewer.errors import RelightError
from viewer.scene.description import Scene, load_scene

from .scenes import rasterised

REFERENCE_SCENES = ASSET_ROOT / "scenes" / "reference"
REFERENCES = ASSET_ROOT / "references"
# --quick: a diffuse sphere, two rough conductors under two skies, and the sphere on a plane
QUICK_SCENES = ("park_diffuse", "park_conductor_r03", "sky_conductor_r08", "park_sphere_on_plane")
TRUTH_KEYS = ("psnr_truth", "median_rel_truth", "bias_truth", "psnr_mc", "median_rel_mc", "bias_mc")
MC_SEEDS = (1234567, 7654321)  # the two halves of the converged ggx_mc (not the bench cases' seed)
BASELINE = ("ggx_split_sum", "single-scatter")  # ms ratios are relative to this case


@dataclass(frozen=True)
class TruthScene:
    name: str            # the file stem, e.g. "park_sphere_on_plane"
    path: Path           # the scene's TOML
    reference: Path      # its path-traced reference (.exr; .stderr.exr and .json beside it)

    @property
    def scene(self) -> Scene:
        """The scene file, :func:`~relight.bench.scenes.rasterised` (the rungs add their rays)."""
        return rasterised(load_scene(self.path))

    @property
    def group(self) -> str:
        """``"convex"`` (one object: nothing to occlude) or ``"occluded"`` (contact shadows,
        inter-reflection between objects)."""
        return "occluded" if len(self.scene.objects) > 1 else "convex"


def truth_scenes(quick: bool = False, folder: Path = REFERENCE_SCENES,
                 references: Path = REFERENCES) -> list[TruthScene]:
    """Reference scenes with a stored reference, sorted by name (``quick``: those of
    :data:`QUICK_SCENES`); a scene without one is left out with a warning."""
    found = [TruthScene(p.stem, p, references / f"{p.stem}.exr")
             for p in sorted(Path(folder).glob("*.toml"))]
    if quick:
        found = [t for t in found if t.name in QUICK_SCENES]
    missing = [t.name for t in found if not t.reference.is_file()]
    if missing:
        warnings.warn(f"relight bench: no stored reference for {', '.join(missing)} in "
                      f"{references} (relight reference); left out", stacklevel=2)
    return [t for t in found if t.reference.is_file()]


def truth_cases(cases: list[tuple[str, str, dict]], quick: bool = False,
                students: Path | None = None) -> list[tuple[str, str, dict]]:
    """The bench's mesh cases (``cases``, from :func:`relight.bench.run._cases`), the screen-space
    knobs on the split sum (SSAO, SSAO + indirect: the rasteriser's answer to visibility) and, in
    the full bench, every candidate neural student (``assets/weights/students``)."""
    out = list(cases)
    split = [i for i, (m, _, _) in enumerate(out) if m == "ggx_split_sum"]
    if split:  # after the split sum's own cases
        out[split[-1] + 1:split[-1] + 1] = [
            ("ggx_split_sum", "single-scatter +ssao", {"multiscatter": False, "ssao": True}),
            ("ggx_split_sum", "single-scatter +ssao +indirect",
             {"multiscatter": False, "ssao": True, "indirect": True})]
    if not quick and any(m == "neural" for m, _, _ in cases):
        from .neural import students_dir

        folder = Path(students) if students else students_dir()
        for path in sorted(folder.glob("*.safetensors")) if folder.is_dir() else []:
            out.append(("neural", f"student {path.stem}", {"weights": str(path)}))
    return out


def _scene_hash(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def converged_mc(renderer, ts: TruthScene, cache: Path, spp: int = 4096) -> Reference:
    """``ggx_mc`` (``mis``) of ``ts`` at ``spp`` samples, as a :class:`Reference` with per-pixel
    standard errors (module docstring); cached as ``cache/truth_<name>_ggx_mc_<spp>spp.exr``
    (+ ``.stderr.exr``, ``.json``) and re-rendered when the scene file changed."""
    path = Path(cache) / f"truth_{ts.name}_ggx_mc_{spp}spp.exr"
    key = _scene_hash(ts.path)
    try:
        ref = read_reference(path)
        if ref.meta.get("scene_sha256") == key:
            return ref
    except (RelightError, OSError):  # missing or unreadable: render it
        pass
    half = max(1, spp // 2)
    base = ts.scene.with_render(model="ggx_mc", sampling="mis", samples=half)
    a, b = (renderer.render(base.with_render(seed=s)).radiance for s in MC_SEEDS)
    mean = 0.5 * (a.astype(np.float64) + b)
    stderr = 0.5 * np.abs(a[..., :3].astype(np.float64) - b[..., :3])
    ref = Reference(radiance=mean.astype(np.float32), stderr=stderr.astype(np.float32),
                    meta={"model": "ggx_mc", "sampling": "mis", "spp": 2 * half,
                          "seeds": list(MC_SEEDS), "scene": str(ts.path), "scene_sha256": key,
                          "stderr": "|a - b| / 2 of two independent halves"})
    write_reference(ref, path)
    return ref


def truth_errors(image: np.ndarray, truth: Reference, mc: Reference | None) -> dict:
    """Scores of ``image`` (``[H, W, 4]`` linear radiance, alpha = coverage) against the
    path-traced ``truth`` and the converged ``mc``: fractions (bias, median relative error) and
    dB, keys :data:`TRUTH_KEYS` plus ``bias_noise_*`` and ``pixels``."""
    row = {}
    for suffix, ref in (("truth", truth), ("mc", mc)):
        if ref is None:
            row.update({f"{k}_{suffix}": math.nan for k in ("psnr", "median_rel", "bias",
                                                             "bias_noise")})
            continue
        s = score(image, ref)
        row.update({f"psnr_{suffix}": s.psnr, f"median_rel_{suffix}": s.median_rel,
                    f"bias_{suffix}": s.bias, f"bias_noise_{suffix}": s.bias_noise})
        if suffix == "truth":
            row["pixels"] = s.pixels
    return row


def truth_row(renderer, ts: TruthScene, case: tuple[str, str, dict], truth: Reference,
              mc: Reference | None, config, scene: Scene | None = None) -> dict:
    """One bench row: ``case`` (model, variant, setting changes) on ``ts``, timed as every bench
    case is (:func:`relight.bench.timing.time_frames`) at the reference's size, and scored by
    :func:`truth_errors`. A model that cannot render the scene gives NaNs and a ``note``."""
    from .timing import time_frames

    model, variant, changes = case
    scene = scene or ts.scene
    h, w = truth.radiance.shape[:2]
    size = (w, h)
    case_scene = scene.with_render(model=model, **changes)
    row = {"scene": ts.name, "kind": "truth", "group": ts.group, "model": model,
           "variant": variant, "samples": int(changes.get("samples", 1)), "size": [w, h]}
    try:
        ms, per_pass = time_frames(renderer, case_scene, size, config)
        image = renderer.render(case_scene, size=size).radiance
    except RelightError as exc:
        row.update({"ms": math.nan, "passes": {}, "note": str(exc)})
        row.update({f"{k}_{ref}": math.nan for ref in ("truth", "mc")
                    for k in ("psnr", "median_rel", "bias", "bias_noise")})
        return row
    row.update({"ms": ms, "passes": per_pass, **truth_errors(image, truth, mc)})
    return row


# ---- aggregation --------------------------------------------------------------------------

def _finite(values) -> list[float]:
    return [float(v) for v in values if v is not None and math.isfinite(v)]


def truth_summary(rows: list[dict], group: str | None = None) -> list[dict]:
    """One entry per (model, variant) over the truth rows (of ``group`` when given), in the rows'
    order: ``scenes``, ``ms`` (median), ``ms_ratio`` (median over scenes of ms / the
    :data:`BASELINE` case's ms on the same scene), and per reference the mean over scenes of the
    median relative error and of PSNR, the mean |bias| and the worst signed bias."""
    rows = [r for r in rows if r.get("kind") == "truth" and (group is None or r.get("group") == group)]
    base = {r["scene"]: r["ms"] for r in rows if (r["model"], r["variant"]) == BASELINE}
    cases: dict[tuple, list[dict]] = {}
    for r in rows:
        cases.setdefault((r["model"], r["variant"]), []).append(r)
    out = []
    for (model, variant), group_rows in cases.items():
        ms = _finite(r.get("ms") for r in group_rows)
        ratios = _finite(r["ms"] / base[r["scene"]] for r in group_rows
                         if r["scene"] in base and base[r["scene"]] > 0)
        entry = {"model": model, "variant": variant, "scenes": len(group_rows),
                 "ms": statistics.median(ms) if ms else math.nan,
                 "ms_ratio": statistics.median(ratios) if ratios else math.nan}
        for ref in ("truth", "mc"):
            med = _finite(r.get(f"median_rel_{ref}") for r in group_rows)
            psnr = _finite(r.get(f"psnr_{ref}") for r in group_rows)
            bias = _finite(r.get(f"bias_{ref}") for r in group_rows)
            entry[f"median_rel_{ref}"] = statistics.fmean(med) if med else math.nan
            entry[f"psnr_{ref}"] = statistics.fmean(psnr) if psnr else math.nan
            entry[f"abs_bias_{ref}"] = statistics.fmean(abs(b) for b in bias) if bias else math.nan
            entry[f"worst_bias_{ref}"] = max(bias, key=abs) if bias else math.nan
        out.append(entry)
    return out


def truth_front(summary: list[dict], ref: str) -> list[dict]:
    """Summary entries not dominated in (lower ``ms``, lower ``median_rel_<ref>``), by time."""
    pts = [e for e in summary if math.isfinite(e["ms"]) and math.isfinite(e[f"median_rel_{ref}"])]
    front, best = [], math.inf
    for e in sorted(pts, key=lambda e: (e["ms"], e[f"median_rel_{ref}"])):
        if e[f"median_rel_{ref}"] < best:
            front.append(e)
            best = e[f"median_rel_{ref}"]
    return front
