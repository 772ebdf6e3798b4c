"""One stone explored live: :class:`ExploreSession`, what ``labcut explore`` and
:func:`labcut.explore` serve.

A session holds the explorer's state (:class:`~labcut.explorer.state.ExploreState`: lamp,
scenario, material, quality, cabochon outline and dome, lamella normal, look) and answers from
:class:`~labcut.Study` objects, one per (stone, scenario, lights, material, quality), kept in a
small cache: a change of lamp, material or scenario makes one new Study (its effect plan and flash
problem), a change of the normal makes nothing new, and going back to a lamp already seen costs
nothing. Every answer is the library's: the metrics are the sample estimator's
(:meth:`labcut.orientation.scoring.Scorer.metrics`), the score map :meth:`labcut.Study.score_map`,
"recommend here" :meth:`labcut.Study.recommend` (the planned estimator, as
``labcut recommend-orientation``), the pictures :func:`labcut.render` under its look and
exposure rules (the reference exposure: a dimmer lamp looks dimmer).

The metrics' error bars are their surface-sampling error at the normal shown
(:func:`labcut.orientation.uncertainty.sampling_error`); a recommendation's own bars (normal and
score, with the directions' part) come with it.

Frames and units: the mesh frame (mm, +Z face-up, the front at -Y); angles in degrees.
"""

from __future__ import annotations

import io
import json
import tempfile
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..backend import serial_blas
from ..commands.render import render
from ..errors import ParameterError
from ..geometry.cabochon import cabochon
from ..geometry.stone import Stone
from ..orientation.recommend import Recommendation, describe, metrics_dict, workshop
from ..orientation.uncertainty import sampling_error
from ..physics.material import Labradorite
from ..rendering.images import to_uint8
from ..scene.directions import direction, lamella_normal, tilt_azimuth
from ..scene.quality import Quality
from ..scene.sets import Lights
from ..study import Study
from .hemisphere import DiscRaster, data_url
from .state import ControlError, ExploreState, changed

#: Studies kept (each holds a flash problem of a few MB at standard quality)
STUDIES_KEPT = 12

#: what the page says of a recommendation's estimator until the live Study's plan is made (after the
#: state's first picture: :meth:`ExploreSession.planned_estimator`)
PLAN_PENDING = "planned after the picture"
#: cabochons built from the outline and dome controls, kept
STONES_KEPT = 6
#: the preview: pixels and samples per pixel (a few tens of milliseconds on 2 cores)
PREVIEW = (128, 4)
#: the refined picture: pixels, and the look's samples per pixel in passes of this many (diagram:
#: 64 = labcut render's default, averaged over passes so a change can stop it between two)
REFINED_PIXELS = 384
REFINE_PASS_SPP = 4
DIAGRAM_SPP = 64
#: the studio look's refined picture: labcut render's default, 16 spp denoised, in one call
STUDIO_SPP = 16


class Superseded(Exception):
    """A refinement stopped because the state changed (the server starts another)."""


class ExploreSession:
    """A stone under the explorer's controls (module docstring).

    ``stone``: a :class:`~labcut.Stone`, a trimesh or a mesh path (read once, here). ``material``:
    the material the ``given`` choice means (a :class:`~labcut.Labradorite` or a preset name;
    default the blue-green labradorite). ``scenario``, ``quality``: the starting scenario and
    quality. ``seed``: the surface sampling and render seed."""

    def __init__(self, stone: Any, material: Any = None, scenario: str = "bench", quality: str = "standard", *,
                 seed: int = 0) -> None:
        self.stone = Stone.load(stone) if isinstance(stone, (str, Path)) else Stone.of(stone, "stone").validate("stone")
        self.given_material = Labradorite.coerce(material)
        self.seed = int(seed)
        height = float(np.ptp(self.stone.mesh.vertices[:, 2]))
        start = changed(ExploreState(), {"scenario": scenario, "quality": quality, "dome": round(max(height, 0.1), 2)})
        self.initial = start
        self.state = start
        self.lock = threading.RLock()
        self._studies: OrderedDict[tuple[Any, ...], Study] = OrderedDict()
        self._answers: dict[tuple[Any, ...], Study] = {}
        self._stones: OrderedDict[tuple[str, float], Stone] = OrderedDict()
        self._maps: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._rasters: dict[bytes, DiscRaster] = {}
        self._view_png: bytes | None = None
        self._view_meta: dict[str, Any] = {}

    # ------------------------------------------------------------------ the controls
    def set(self, changes: Mapping[str, Any]) -> ExploreState:
        """Apply ``changes`` (``{control: value}``, :func:`~labcut.explorer.state.changed`), all or
        none; a cabochon the outline and dome controls ask for is built here, so a dome it cannot
        have is refused as the control's error."""
        with self.lock:
            new = changed(self.state, changes)
            if new.outline != "as loaded":
                try:
                    self._stone_for(new)
                except ParameterError as exc:
                    control = "dome" if "dome" in changes or "dome" in str(exc) else "outline"
                    raise ControlError(control, str(exc)) from None
            self.state = new
            return new

    def reset(self) -> ExploreState:
        """Back to the state the session started in."""
        with self.lock:
            self.state = self.initial
            return self.state

    # ------------------------------------------------------------------ what the state means
    def current_stone(self, state: ExploreState | None = None) -> Stone:
        """The stone of ``state`` (default the current one): as loaded, or the cabochon its outline
        and dome ask for at the loaded stone's length and width."""
        return self._stone_for(self.state if state is None else state)

    def _stone_for(self, s: ExploreState) -> Stone:
        if s.outline == "as loaded":
            return self.stone
        key = (s.outline, round(s.dome, 3))
        hit = self._stones.get(key)
        if hit is None:
            lo, hi = self.stone.mesh.bounds
            length, width = float(hi[0] - lo[0]), float(hi[1] - lo[1])
            if s.outline == "round":
                length = width = min(length, width)
            hit = Stone(cabochon(s.outline, length=length, width=width, dome=float(s.dome)), kind="cabochon",
                        name=f"{s.outline} cabochon {length:g} x {width:g} mm, dome {s.dome:g} mm")
            self._stones[key] = hit
            while len(self._stones) > STONES_KEPT:
                self._stones.popitem(last=False)
        self._stones.move_to_end(key)
        return hit

    def material(self, state: ExploreState | None = None) -> Labradorite:
        """The material of ``state``: the given one, a preset, or the flash peak's."""
        s = self.state if state is None else state
        if s.material == "given":
            return self.given_material
        if s.material == "peak":
            return Labradorite.from_peak_wavelength(s.peak_nm, name=f"peak {s.peak_nm:g} nm")
        return Labradorite.preset(s.material)

    def lights(self, state: ExploreState | None = None) -> Lights | None:
        """The lamp of ``state`` (a disc of ``lamp_size`` degrees, sampled as the quality samples a
        lamp, of unit irradiance as every preset lamp), or None: the scenario's own lights."""
        s = self.state if state is None else state
        if s.lights == "scenario":
            return None
        samples = Quality.coerce(s.quality).lamp_samples
        return Lights.lamp(direction(90.0 - s.lamp_elevation, s.lamp_azimuth), s.lamp_size, 1.0, samples, "lamp")

    def _key(self, s: ExploreState) -> tuple[Any, ...]:
        lamp = None if s.lights == "scenario" else (s.lamp_elevation, s.lamp_azimuth, s.lamp_size)
        peak = s.peak_nm if s.material == "peak" else None
        return (s.outline, s.dome if s.outline != "as loaded" else None, s.scenario, lamp, s.material, peak, s.quality)

    def study(self, state: ExploreState | None = None) -> Study:
        """The live :class:`~labcut.Study` of ``state`` (made once per stone, scenario, lights,
        material and quality, and kept): the score map and metrics come from its surface samples
        (:attr:`~labcut.Study.surface_scorer`), and its plan renders no pilots (a carving's light
        between its parts is measured when a recommendation asks: :meth:`answer_study`)."""
        s = self.state if state is None else state
        key = self._key(s)
        hit = self._studies.get(key)
        if hit is None:
            hit = Study(self._stone_for(s), self.material(s), s.scenario, s.quality, lighting=self.lights(s), seed=self.seed,
                        pilot_seconds_max=0.0)
            self._studies[key] = hit
            while len(self._studies) > STUDIES_KEPT:
                old_key, old = self._studies.popitem(last=False)
                self._maps.pop(id(old), None)
                self._answers.pop(old_key, None)
        self._studies.move_to_end(key)
        return hit

    def answer_study(self, state: ExploreState | None = None, *, make: bool = True) -> Study | None:
        """The :class:`~labcut.Study` that recommends for ``state`` as ``labcut recommend-orientation``
        does (its full plan, pilots included, and the planned estimator), made when first asked
        (``make``) and kept while its live Study is; None when not made and ``make`` is False."""
        s = self.state if state is None else state
        key = self._key(s)
        hit = self._answers.get(key)
        if hit is None and make:
            live = self.study(s)
            hit = Study(live.stone, live.material, s.scenario, s.quality, lighting=self.lights(s), seed=self.seed)
            self._answers[key] = hit
        return hit

    def normal(self, state: ExploreState | None = None) -> np.ndarray:
        s = self.state if state is None else state
        return lamella_normal(None, s.normal_tilt, s.normal_azimuth)

    def view_name(self) -> str:
        """The current stone's name as the page shows it."""
        return _stone_name(self._stone_for(self.state))

    def recommendation(self) -> Recommendation | None:
        """The current state's recommendation, when "recommend here" has made it."""
        answer = self.answer_study(make=False)
        return None if answer is None else answer.recommended()

    # ------------------------------------------------------------------ answers
    def score_map(self) -> tuple[np.ndarray, np.ndarray]:
        """The current Study's score map (its normals and scores), made once per Study."""
        study = self.study()
        hit = self._maps.get(id(study))
        if hit is None:
            hit = study.score_map(surface=True)
            self._maps[id(study)] = hit
        return hit

    def raster(self, normals: np.ndarray) -> DiscRaster:
        key = np.ascontiguousarray(normals).tobytes()
        hit = self._rasters.get(key)
        if hit is None:
            hit = self._rasters[key] = DiscRaster(normals)
        return hit

    def view(self) -> dict[str, Any]:
        """Everything the page shows but the picture, as plain JSON: the state, the metrics of the
        normal with their sampling error, the score map (a PNG ``data:`` URL, with its highest
        score), the recommendation when made, the normal in a cutter's words, the lights and the
        stone, and the milliseconds each part took. numpy's BLAS runs on one thread meanwhile
        (:func:`~labcut.backend.serial_blas`, as in a recommendation): the metrics' bootstrap is a
        few small products, which OpenBLAS's own threads, contending with Dr.Jit's pool, made
        several times slower on two cores."""
        with self.lock, serial_blas():
            times: dict[str, float] = {}
            t0 = time.perf_counter()
            state, study = self.state, self.study()
            scorer = study.surface_scorer
            times["study"] = _ms(t0)
            t = time.perf_counter()
            normals, scores = self.score_map()
            picture = data_url(self.raster(normals).png(scores))
            times["score_map"] = _ms(t)
            t = time.perf_counter()
            m = self.normal()
            metrics = scorer.metrics(m)
            errors = sampling_error(scorer.problem, m, seed=self.seed)
            times["metrics"] = _ms(t)
            stone = self._stone_for(state)
            scenario = study.scenario
            rec = self.recommendation()
            best = int(np.argmax(scores))
            bt, ba = tilt_azimuth(normals[best])
            return {
                "state": state.to_dict(),
                "objective": study.question.objective,
                "metrics": metrics_dict(metrics),
                "errors": errors,
                "score": float(metrics.score(study.question.objective)),
                "score_map": {"png": picture, "max": float(np.max(scores)), "best_tilt": bt, "best_azimuth": ba,
                              "normals": len(normals)},
                "recommendation": None if rec is None else _recommendation_json(rec),
                "words": {"orientation": describe(m, scenario), "workshop": workshop(m, stone.mesh, scenario)["text"]},
                "lights": _lights_label(state, scenario),
                "stone": {"name": _stone_name(stone), "kind": stone.kind, "triangles": int(len(stone.mesh.faces)),
                          "size_mm": [round(float(x), 2) for x in np.ptp(stone.mesh.vertices, axis=0)]},
                "material": self.material(state).name or "labradorite",
                "estimator": "samples (live); recommend: " + (_planned(study, self.answer_study(make=False)) or PLAN_PENDING),
                "timings_ms": {**times, "total": _ms(t0)},
            }

    def planned_estimator(self) -> dict[str, Any]:
        """The current Study's effect plan made (its inter-reflection left unmeasured, as a live plan
        leaves it), and what the page says of it, as :meth:`view`'s ``estimator`` text. The view answers
        without the plan (a new material's depth and polarisation decisions take tenths of a second):
        the server sends the estimator after
        the first picture of the state. ``{"state": the state asked about, "estimator": the view's text}``.
        Under the session's lock, as the view: numpy's BLAS limits (:func:`~labcut.backend.serial_blas`)
        are the process's, and two blocks on two threads would undo each other's."""
        with self.lock, serial_blas():
            state, study = self.state, self.study()
            study.plan()
            text = "samples (live); recommend: " + (_planned(study, self.answer_study(make=False)) or PLAN_PENDING)
            return {"state": state.to_dict(), "estimator": text}

    def recommend(self) -> Recommendation:
        """"Recommend here": the current Study's recommendation (the planned estimator, as
        ``labcut recommend-orientation`` answers the same question); the normal control moves to it."""
        with self.lock:
            rec = self.answer_study().recommend()
            self.state = changed(self.state, {"normal_tilt": rec.tilt_deg, "normal_azimuth": rec.azimuth_deg})
            return rec

    # ------------------------------------------------------------------ pictures
    def _render(self, state: ExploreState, resolution: int, spp: int, seed: int, **kwargs: Any) -> Any:
        study = self.study(state)
        return render(self._stone_for(state), self.material(state), self.normal(state), scenario=study.scenario,
                      resolution=resolution, spp=spp, seed=seed, look=state.look, check_flash=False, **kwargs)

    def preview(self) -> bytes:
        """A quick picture of the current state (:data:`PREVIEW` pixels and samples), PNG bytes."""
        with self.lock:
            state = self.state
            result = self._render(state, *PREVIEW, seed=self.seed, denoise=False)
            return self._keep(state, result.image, result, "preview")

    def refine(self, stop: Callable[[], bool] = lambda: False) -> Any:
        """The refined picture of the current state, pass by pass: yields PNG bytes after each pass
        (diagram look: :data:`DIAGRAM_SPP` samples in passes of :data:`REFINE_PASS_SPP`, averaged;
        studio look: :data:`STUDIO_SPP` denoised at once). ``stop()`` is asked between passes;
        True ends the refinement with :class:`Superseded`."""
        state = self.state
        if state.look == "studio":
            result = self._render(state, REFINED_PIXELS, STUDIO_SPP, seed=self.seed)
            if stop():
                raise Superseded
            yield self._keep(state, result.image, result, f"refined, {STUDIO_SPP} spp denoised")
            return
        total = None
        passes = DIAGRAM_SPP // REFINE_PASS_SPP
        for k in range(passes):
            result = self._render(state, REFINED_PIXELS, REFINE_PASS_SPP, seed=self.seed + 1 + k, denoise=False)
            total = result.image.astype(np.float64) if total is None else total + result.image
            if stop():
                raise Superseded
            yield self._keep(state, total / (k + 1), result, f"refined, {(k + 1) * REFINE_PASS_SPP} spp")

    def _keep(self, state: ExploreState, image: np.ndarray, result: Any, stage: str) -> bytes:
        from PIL import Image
        from PIL.PngImagePlugin import PngInfo

        info = PngInfo()
        meta = {"state": state.to_dict(), "stage": stage, "exposure": result.exposure,
                "exposure_mode": result.exposure_mode, "look": result.look}
        info.add_text("labcut:explore", json.dumps(meta))
        info.add_text("labcut:exposure", f"{result.exposure:.6g}")
        buf = io.BytesIO()
        Image.fromarray(to_uint8(image, result.exposure, result.tonemap), "RGB").save(buf, format="PNG", pnginfo=info)
        png = buf.getvalue()
        if state == self.state:
            self._view_png, self._view_meta = png, meta
        return png

    # ------------------------------------------------------------------ exports
    def export_state(self) -> dict[str, Any]:
        """The current state as JSON a later session or script can read: the controls, the stone's
        provenance, the material, the scenario, the metrics and the recommendation when made."""
        with self.lock:
            state, study = self.state, self.study()
            rec = self.recommendation()
            return {
                "labcut_explore": 1,
                "state": state.to_dict(),
                "stone": self._stone_for(state).provenance_dict(),
                "material": self.material(state).to_dict(),
                "scenario": study.scenario.to_dict(),
                "normal": [float(x) for x in self.normal()],
                "metrics": metrics_dict(study.surface_scorer.metrics(self.normal())),
                "recommendation": None if rec is None else rec.to_dict(),
            }

    def view_png(self) -> bytes:
        """The picture shown last (the refined one when it finished), else a preview made now."""
        with self.lock:
            if self._view_png is not None and self._view_meta.get("state") == self.state.to_dict():
                return self._view_png
            return self.preview()

    def report_html(self, progress: Callable[[int, int], None] | None = None) -> bytes:
        """The comparison report (``labcut compare``) of the current cut under the current
        scenario, lights and material: one self-contained HTML page."""
        from ..reports.compare import compare_cuts

        with self.lock:
            state, study = self.state, self.study()
            stone = self._stone_for(state)
            name = _stone_name(stone)
            comparison = compare_cuts([(name, stone.mesh)], material=self.material(state), scenarios=[study.scenario],
                                      quality=state.quality, seed=self.seed, progress=progress)
        with tempfile.TemporaryDirectory(prefix="labcut-explore-") as tmp:
            path = Path(tmp) / "report.html"
            comparison.save_html(path)
            return path.read_bytes()


def _planned(live: Study, answer: Study | None) -> str | None:
    """The estimator a recommendation answers with: the answer Study's plan once made, else the live
    plan's once made (:meth:`ExploreSession.planned_estimator` makes it), saying when that plan left a
    carving's light between its parts unmeasured; None while neither is made."""
    if answer is not None:
        return answer.plan().estimator
    plan = live.planned()
    if plan is None:
        return None
    unmeasured = "interreflection_pilots_skipped_seconds" in plan.facts
    return plan.estimator + (" (light between the parts measured when asked)" if unmeasured else "")


def _stone_name(stone: Stone) -> str:
    """A stone's name as the page shows it: its own, else its file's, else "stone"."""
    source = stone.provenance.source
    return stone.name or (Path(source).name if source else "stone")


def _ms(since: float) -> float:
    return round((time.perf_counter() - since) * 1000.0, 1)


def _recommendation_json(rec: Recommendation) -> dict[str, Any]:
    bar = rec.uncertainty
    return {
        "tilt_deg": rec.tilt_deg, "azimuth_deg": rec.azimuth_deg, "score": rec.score, "objective": rec.objective,
        "tolerance_deg": rec.tolerance_deg, "tolerance_by_axis": rec.tolerance_by_axis,
        "angle_error_deg": None if bar is None else bar.angle_deg,
        "score_rel_error": None if bar is None else bar.score_rel,
        "description": rec.description, "workshop": rec.workshop.get("text"), "estimator": rec.estimator,
        "seconds": rec.seconds,
    }


def _lights_label(state: ExploreState, scenario: Any) -> str:
    if state.lights == "scenario":
        return f"the {scenario.name} scenario's own lights ({scenario.lights.name})"
    size = "a point" if state.lamp_size == 0 else f"{state.lamp_size:g}° radius"
    return (f"one lamp {state.lamp_elevation:g}° above the horizon at azimuth {state.lamp_azimuth:g}° ({size}); "
            f"the {scenario.name} scenario's viewers and motion")
