"""Wear scenarios: how a stone is lit, worn and seen (DESIGN.md §3).

A :class:`Scenario` places the stone in a world with +Z up (its *pose*: the
rotation taking mesh-frame vectors to world vectors), lights and viewers given
in that world, and optionally a rocking motion (the stone tilted in the hand).
:meth:`Scenario.settings` turns it into the mesh frame, one :class:`Setting` per
pose of the rocking motion; the optimiser and the renderer work only with
settings, in the mesh frame.

Poses: ``face-up`` (mesh +Z = world up: bench, ring, display, outdoor) and
``face-front`` (mesh +Z horizontal towards the viewer at world -Y, mesh +Y = world
up: the bail of a pendant is at the stone's +Y end). A rocking motion rotates the
stone about the world X axis (front-to-back, ±``rock_deg``) and the world Y axis
(side-to-side, ±``sway_deg``), with the lights and viewers fixed in the world.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..validation import check_number
from .directions import check_rotation, rotation
from .registry import Registry
from .quality import Quality
from .sets import Lights, Views, check_quality, lights_from, views_from

SCENARIOS = Registry("scenario", "or a scenario JSON file")

POSES = {
    "face-up": np.eye(3),
    "face-front": rotation([1.0, 0.0, 0.0], 90.0),  # mesh +Z -> world -Y, mesh +Y -> world +Z
}
SCENARIO_KEYS = ("name", "description", "pose", "tilt_back_deg", "lighting", "viewing", "rock_deg", "sway_deg",
                 "motion_view_share")


@dataclass(frozen=True, eq=False)
class Setting:
    """One pose of a scenario, in the mesh frame: its lights and views, and its weight
    (the settings of a scenario have weights summing to 1). ``pose`` maps mesh to world."""

    lights: Lights
    views: Views
    weight: float = 1.0
    pose: np.ndarray = None  # type: ignore[assignment]

    def up(self) -> np.ndarray:
        """World up (+Z) in the mesh frame: the top of a render's image."""
        pose = np.eye(3) if self.pose is None else self.pose
        return pose.T @ np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True, eq=False)
class Scenario:
    """How a stone is lit, worn and seen: a pose, world-frame lights and views, a rocking motion."""

    name: str
    pose: np.ndarray
    lights: Lights
    views: Views
    rock_deg: float = 0.0
    sway_deg: float = 0.0
    description: str = ""
    quality: Quality | str = "standard"  # coerced to a Quality: its direction counts and rocking steps
    #: the share of the viewers each pose of the motion but the rest pose keeps (a stratified subset,
    #: a different one per pose): a moving stone seen from many sides averages over poses and viewers
    #: alike, and the product of both grids costs their product; 1: every pose keeps every viewer
    motion_view_share: float = 1.0

    def __repr__(self) -> str:
        """One line: the name, the lights and views (:meth:`Lights.__repr__`), the rocking and the
        quality (``to_dict()`` holds every number)."""
        rock = f", rock ±{self.rock_deg:g}°, sway ±{self.sway_deg:g}°" if self.rock_deg or self.sway_deg else ""
        return f"Scenario({self.name!r}, {self.lights!r}, {self.views!r}{rock}, quality={str(self.quality)!r})"

    def __post_init__(self) -> None:
        object.__setattr__(self, "pose", check_rotation(self.pose, f"scenario {self.name!r} pose"))
        for key in ("rock_deg", "sway_deg"):
            value = getattr(self, key)
            if not (isinstance(value, int | float) and math.isfinite(value) and 0.0 <= value <= 60.0):
                raise ParameterError(f"scenario {self.name!r}: {key} must lie in [0, 60] degrees, got {value!r}")
        share = self.motion_view_share
        if not (isinstance(share, int | float) and not isinstance(share, bool) and math.isfinite(share) and 0.0 < share <= 1.0):
            raise ParameterError(f"scenario {self.name!r}: motion_view_share must lie in (0, 1], got {share!r}")
        if not isinstance(self.lights, Lights) or not isinstance(self.views, Views):
            raise ParameterError(f"scenario {self.name!r} needs labcut.Lights and labcut.Views")
        object.__setattr__(self, "quality", check_quality(self.quality))
        main = self.pose.T @ self.views.main
        if main[2] <= 1e-3:
            raise ParameterError(f"scenario {self.name!r}: the main viewer does not see the face of the stone")

    # ------------------------------------------------------------------ construction
    @classmethod
    def preset(cls, name: str, quality: Quality | str = "standard") -> Scenario:
        """A named wear scenario: :data:`labcut.scene.SCENARIOS` lists them (docs/scenarios.md).

        Examples
        --------
        >>> import labcut
        >>> pendant = labcut.Scenario.preset("pendant", "draft")
        >>> pendant.lights.name, pendant.views.name
        ('room', 'eye-level')
        >>> pendant.main_setting().up().round(3).tolist()  # world up is the stone's +Y (bail) end
        [0.0, 1.0, 0.0]
        """
        return SCENARIOS.get(name).factory(check_quality(quality))

    @classmethod
    def from_json(cls, path: str | os.PathLike[str], quality: Quality | str = "standard") -> Scenario:
        """A scenario from a JSON file (keys: name, description, pose, tilt_back_deg, lighting,
        viewing, rock_deg, sway_deg, motion_view_share; docs/scenarios.md)."""
        from ..fileio import read_json

        data = read_json(path, "scenario file")
        return cls.from_dict(data, quality, source=str(path), base=Path(path).parent)

    @classmethod
    def from_dict(cls, data: Any, quality: Quality | str = "standard", source: str = "scenario", base: Path | None = None) -> Scenario:
        if not isinstance(data, dict):
            raise ParameterError(f"{source} must hold a JSON object with keys {', '.join(SCENARIO_KEYS)}")
        unknown = sorted(set(data) - set(SCENARIO_KEYS))
        if unknown:
            raise ParameterError(f"{source}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(SCENARIO_KEYS)}")
        for key in ("lighting", "viewing"):
            if key not in data:
                raise ParameterError(f"{source}: missing {key!r}")
        name = str(data.get("name", Path(source).stem))
        pose = _pose(data.get("pose", "face-up"), data.get("tilt_back_deg", 0.0), source)
        lights = _lighting(data["lighting"], quality, source, base)
        views = _viewing(data["viewing"], quality, source, base)
        rock, sway = (_number(data.get(k, 0.0), f"{source}: {k}") for k in ("rock_deg", "sway_deg"))
        share = _number(data.get("motion_view_share", 1.0), f"{source}: motion_view_share")
        return cls(name, pose, lights, views, rock, sway, str(data.get("description", "")), quality, share)

    def with_lights(self, lights: Lights) -> Scenario:
        return replace(self, lights=lights)

    def with_views(self, views: Views) -> Scenario:
        return replace(self, views=views)

    def with_env_samples(self, n: int | None) -> Scenario:
        """This scenario with its environment map seen through ``n`` sampled directions
        (:meth:`Lights.with_env_samples`); ``None``, or lights without a map: itself."""
        if n is None or self.lights.environment is None:
            return self
        return replace(self, lights=self.lights.with_env_samples(n))

    # ------------------------------------------------------------------ use
    @property
    def worn_upright(self) -> bool:
        """Whether the stone is worn upright (its +Y end up: pendant, brooch); then its sides are
        named top and bottom rather than back and front."""
        return float((np.asarray(self.pose) @ np.array([0.0, 1.0, 0.0]))[2]) > 0.7

    def poses(self) -> list[tuple[np.ndarray, float]]:
        """(mesh-to-world rotation, weight) of each pose of the rocking motion; the rest pose first."""
        out = [self.pose]
        n_rock, n_sway = self.quality.rock_steps
        for axis, amp, k in (([1.0, 0.0, 0.0], self.rock_deg, n_rock), ([0.0, 1.0, 0.0], self.sway_deg, n_sway)):
            if amp <= 0.0:
                continue
            angles = np.linspace(-amp, amp, k + (k % 2 == 0))  # symmetric, an odd count holds 0
            out += [rotation(axis, a) @ self.pose for a in angles if abs(a) > 1e-9]
        return [(p, 1.0 / len(out)) for p in out]

    def settings(self) -> list[Setting]:
        """The scenario in the mesh frame, one :class:`Setting` per pose (made once per scenario:
        a recommendation asks for them from its planner, its problem and its error bars; a new
        list of the same frozen settings each time)."""
        made = self.__dict__.get("_settings")
        if made is None:
            made = [Setting(self.lights.rotated(p.T), self.views_of_pose(k).rotated(p.T), w, p)
                    for k, (p, w) in enumerate(self.poses())]
            if not any(np.any(s.views.directions[:, 2] > 0.0) for s in made):
                raise ParameterError(f"scenario {self.name!r}: no viewer sees the face of the stone")
            object.__setattr__(self, "_settings", made)
        return list(made)

    def views_of_pose(self, k: int) -> Views:
        """The viewers (world frame) of pose ``k`` of :meth:`poses`: all of them at rest (pose 0) and
        wherever :attr:`motion_view_share` is 1; else ``keep = max(1, round(share x count))`` of them.
        The viewers are put in a stratified order (every ``count // keep``-th, then the same from the
        next offset, ...) and pose ``k`` takes the next ``keep`` of that order, cyclically: each pose's
        viewers lie spread over the set, and the poses sweep through all of it in turn."""
        v = self.views
        n = len(v.weights)
        keep = max(1, round(self.motion_view_share * n))
        if k == 0 or keep >= n:
            return v
        stride = max(1, n // keep)
        order = np.concatenate([np.arange(o, n, stride) for o in range(stride)])
        return v.subset(order[((k - 1) * keep + np.arange(keep)) % n])

    def main_setting(self) -> Setting:
        """The rest pose in the mesh frame: what a render of this scenario shows."""
        p = self.pose
        return Setting(self.lights.rotated(p.T), self.views.rotated(p.T), 1.0, p)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "description": self.description,
            "pose": self.pose.tolist(),
            "lighting": self.lights.name,
            "viewing": self.views.name,
            "rock_deg": self.rock_deg,
            "sway_deg": self.sway_deg,
            "motion_view_share": self.motion_view_share,
            "poses": len(self.poses()),
            "lights": len(self.lights),
            "views": len(self.views),
        }


# ---------------------------------------------------------------------- JSON pieces
def _number(value: Any, what: str) -> float:
    return check_number(value, what)


def _count(value: Any, what: str) -> int:
    return check_number(value, what, 1, 100_000, integer=True)


def _pose(value: Any, tilt_back: Any, source: str) -> np.ndarray:
    tilt = _number(tilt_back, f"{source}: tilt_back_deg")
    if isinstance(value, str):
        if value not in POSES:
            raise ParameterError(f"{source}: pose must be {', '.join(POSES)} or a 3 x 3 rotation matrix, got {value!r}")
        p = POSES[value]
    else:
        p = check_rotation(value, f"{source}: pose")
    # tilting back turns the face upwards about the world X axis
    return rotation([1.0, 0.0, 0.0], -tilt) @ p


def _path(text: str, base: Path | None) -> str:
    p = Path(text)
    if not p.is_absolute() and base is not None and (base / p).exists():
        return str(base / p)
    return text


def _lighting(value: Any, quality: Quality | str, source: str, base: Path | None) -> Lights:
    if isinstance(value, str):
        return lights_from(_path(value, base), quality)
    if isinstance(value, dict) and "directions" in value:
        if not value["directions"]:
            raise ParameterError(f"{source}: lighting has no directions")
        return Lights(value["directions"], value.get("weights"), str(value.get("name", "custom")))
    if isinstance(value, list) and value and all(isinstance(x, dict) for x in value):
        parts = []
        for part in value:
            share = _number(part.get("share", 1.0), f"{source}: lighting share")
            if "preset" in part:
                lights = lights_from(str(part["preset"]), quality)
            elif "envmap" in part:
                lights = Lights.from_envmap(_path(str(part["envmap"]), base), _count(part.get("n", check_quality(quality).env_samples), f"{source}: n"))
            elif "lamp" in part:
                lights = Lights.lamp(part["lamp"], _number(part.get("radius_deg", 0.0), f"{source}: radius_deg"), 1.0,
                                     _count(part.get("n", check_quality(quality).lamp_samples), f"{source}: n"))
            else:
                raise ParameterError(f"{source}: each lighting part needs 'preset', 'envmap' or 'lamp'")
            parts.append((lights, share))
        return Lights.combine(parts, "+".join(p[0].name for p in parts))
    raise ParameterError(f"{source}: lighting must be a preset name, a file, {{'directions': ...}} or a list of parts")


def _viewing(value: Any, quality: Quality | str, source: str, base: Path | None) -> Views:
    if isinstance(value, str):
        return views_from(_path(value, base), quality)
    if isinstance(value, dict) and "directions" in value:
        if not value["directions"]:
            raise ParameterError(f"{source}: viewing has no directions")
        return Views(value["directions"], value.get("weights"), str(value.get("name", "custom")), value.get("main"))
    raise ParameterError(f"{source}: viewing must be a preset name, a file or {{'directions': ...}}")


# ---------------------------------------------------------------------- presets
def _preset(name: str, pose: np.ndarray, lighting: str, viewing: str, quality: Quality | str, description: str,
            rock: float = 0.0, sway: float = 0.0) -> Scenario:
    return Scenario(name, pose, Lights.preset(lighting, quality), Views.preset(viewing, quality), rock, sway, description, quality)


@SCENARIOS.register("bench", "the cutter's check: lamp straight above, stone face-up, rocked ±30° front-to-back and ±15° sideways in the hand")
def bench(quality: Quality | str) -> Scenario:
    return _preset("bench", POSES["face-up"], "overhead", "cutter", quality, SCENARIOS.get("bench").summary, 30.0, 15.0)


#: how worn jewellery moves (docs/scenarios.md, "Moved as jewellery moves"): (rock_deg, sway_deg) about the
#: world's X (front-to-back) and Y (side-to-side; for a stone worn upright, a turn in its own plane) axes
MOTION = {"ring": (25.0, 25.0), "pendant": (10.0, 10.0), "brooch": (8.0, 8.0), "outdoor": (25.0, 25.0)}
#: the share of the viewers each moving pose keeps (Scenario.motion_view_share): the ring's and the
#: street's viewers stand all round, the pendant's and the brooch's in front
MOTION_VIEWS = {"ring": 0.1, "pendant": 0.15, "brooch": 0.15, "outdoor": 0.1}
BROOCH_TILT_BACK_DEG = 15.0
#: a brooch's pose (worn or still): the face vertical, tilted back by BROOCH_TILT_BACK_DEG
BROOCH_POSE = rotation([1.0, 0.0, 0.0], -BROOCH_TILT_BACK_DEG) @ POSES["face-front"]


def _worn(name: str, pose: np.ndarray, lighting: str, viewing: str, quality: Quality | str) -> Scenario:
    rock, sway = MOTION[name]
    return replace(_preset(name, pose, lighting, viewing, quality, SCENARIOS.get(name).summary, rock, sway),
                   motion_view_share=MOTION_VIEWS[name])


@SCENARIOS.register("ring", "a ring on a moving hand in an office: downlights, a window and the room's reflected light; "
                            "the hand turns the stone ±25° both ways; seen from every side looking down 20-60°")
def ring(quality: Quality | str) -> Scenario:
    return _worn("ring", POSES["face-up"], "room", "above", quality)


@SCENARIOS.register("pendant", "a pendant in an office: face vertical, bail at the stone's +Y end, swinging ±10° "
                               "forward-back and in its plane; downlights, a window, reflected light; viewers in front "
                               "at eye level within ±20°")
def pendant(quality: Quality | str) -> Scenario:
    return _worn("pendant", POSES["face-front"], "room", "eye-level", quality)


@SCENARIOS.register("brooch", "a brooch in an office: face vertical but tilted back 15°, moving ±8° with the body; "
                              "downlights, a window, reflected light; viewers at eye level")
def brooch(quality: Quality | str) -> Scenario:
    return _worn("brooch", BROOCH_POSE, "room", "eye-level", quality)


@SCENARIOS.register("display", "a shop window: stone face-up, spots 30-45° from the vertical, viewers 0-30° from the vertical in front")
def display(quality: Quality | str) -> Scenario:
    return _preset("display", POSES["face-up"], "shop", "front", quality, SCENARIOS.get("display").summary)


@SCENARIOS.register("outdoor", "outdoors on a moving hand: sun and sky, the stone turned ±25° both ways, seen from every "
                               "side looking down 20-60°")
def outdoor(quality: Quality | str) -> Scenario:
    return _worn("outdoor", POSES["face-up"], "daylight", "above", quality)


# the still, evenly lit scenarios of labcut's earlier releases, under their own names
@SCENARIOS.register("ring-diffuse", "a ring held still under an even office ceiling, seen from every side looking down 20-60°")
def ring_diffuse(quality: Quality | str) -> Scenario:
    return _preset("ring-diffuse", POSES["face-up"], "ceiling", "above", quality, SCENARIOS.get("ring-diffuse").summary)


@SCENARIOS.register("pendant-diffuse", "a still pendant: face vertical, bail at +Y; an even ceiling and a window; viewers "
                                       "in front at eye level within ±20°")
def pendant_diffuse(quality: Quality | str) -> Scenario:
    return _preset("pendant-diffuse", POSES["face-front"], "office", "eye-level", quality,
                   SCENARIOS.get("pendant-diffuse").summary)


@SCENARIOS.register("brooch-diffuse", "a still brooch tilted back 15°; an even ceiling and a window; viewers at eye level")
def brooch_diffuse(quality: Quality | str) -> Scenario:
    return _preset("brooch-diffuse", BROOCH_POSE, "office", "eye-level", quality, SCENARIOS.get("brooch-diffuse").summary)


@SCENARIOS.register("outdoor-still", "a still stone face-up in sun and sky, seen from every side looking down 20-60°")
def outdoor_still(quality: Quality | str) -> Scenario:
    return _preset("outdoor-still", POSES["face-up"], "daylight", "above", quality, SCENARIOS.get("outdoor-still").summary)


def scenario_from(spec: Any, quality: Quality | str = "standard") -> Scenario:
    """A :class:`Scenario` from an instance, a preset name or a JSON file."""
    if isinstance(spec, Scenario):
        return spec
    if isinstance(spec, str | Path):
        text = str(spec)
        if text.lower().endswith(".json"):
            return Scenario.from_json(text, quality)
        return Scenario.preset(text, quality)
    raise ParameterError(f"scenario must be one of {SCENARIOS.choices()} or labcut.Scenario, got {type(spec).__name__}")


def resolve_scene(scenario: Any = None, lighting: Any = None, viewing: Any = None, quality: Quality | str = "standard") -> Scenario:
    """The scenario a command runs under.

    * ``scenario`` given: that scenario, with its lights and/or views replaced by
      ``lighting``/``viewing`` when those are given too (in the scenario's world frame).
    * only ``lighting``/``viewing``: a still, face-up stone under them (``overhead`` and
      ``face-up`` fill in the one not given), as in labcut's first release.
    * nothing: the default scenario, ``bench``.
    """
    quality = check_quality(quality)
    if scenario is None and lighting is None and viewing is None:
        return Scenario.preset("bench", quality)
    if scenario is None:
        lights = lights_from("overhead" if lighting is None else lighting, quality)
        views = views_from("face-up" if viewing is None else viewing, quality)
        return Scenario("custom", np.eye(3), lights, views, description="a still stone, face-up", quality=quality)
    base = scenario_from(scenario, quality)
    if lighting is not None:
        base = base.with_lights(lights_from(lighting, quality))
    if viewing is not None:
        base = base.with_views(views_from(viewing, quality))
    return base


def scenarios_from(scenarios: Any, quality: Quality | str = "standard") -> list[Scenario]:
    """The :class:`~labcut.Scenario` of each name, JSON file or instance (default ``["bench"]``); a name
    given twice is an error."""
    if scenarios is None:
        scenarios = ["bench"]
    elif isinstance(scenarios, str | os.PathLike) or not isinstance(scenarios, list | tuple):
        scenarios = [scenarios]
    if not scenarios:
        raise ParameterError("give at least one scenario (default: bench)")
    out = [scenario_from(s, quality) for s in scenarios]
    names = [s.name for s in out]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ParameterError(f"scenario {twice[0]!r} is given twice; each scenario is compared once")
    return out
