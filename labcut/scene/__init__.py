"""The scene: lights, viewers and wear scenarios, one vocabulary for every command.

This layer sits below rendering and orientation; both take a :class:`Scenario`
(or the lights and views of one) and work in the mesh frame it produces.

* :class:`Lights`, :class:`Views`: weighted distant directions; presets by name in
  :data:`LIGHTING` and :data:`VIEWING`; lamps of finite size; environment maps
  (:meth:`Lights.from_envmap`).
* :class:`Scenario`: the stone's pose in a world with +Z up, lights and viewers
  in that world, a rocking motion; presets by name in :data:`SCENARIOS`.
* :class:`Quality`: every knob that trades accuracy for time (``draft``, ``standard``, ``high``).
"""

from .directions import FRONT_AZIMUTH_DEG, direction, lamella_normal, normalize_normal, tilt_azimuth
from .effects import EFFECTS, ESTIMATORS, SWITCHABLE, check_effects, parse_effects
from .envmap import Environment, studio_environment
from .presets import LIGHTING, VIEWING
from .quality import QUALITIES, Quality
from .scenario import SCENARIOS, Scenario, Setting, resolve_scene, scenario_from
from .sets import Lights, Views, lights_from, views_from
from .variants import Variant, Variation, scenario_variants

__all__ = [
    "EFFECTS",
    "ESTIMATORS",
    "FRONT_AZIMUTH_DEG",
    "SWITCHABLE",
    "LIGHTING",
    "QUALITIES",
    "SCENARIOS",
    "VIEWING",
    "Environment",
    "Lights",
    "Quality",
    "Scenario",
    "Setting",
    "Variant",
    "Variation",
    "Views",
    "check_effects",
    "direction",
    "lamella_normal",
    "lights_from",
    "scenario_variants",
    "normalize_normal",
    "parse_effects",
    "resolve_scene",
    "scenario_from",
    "studio_environment",
    "tilt_azimuth",
    "views_from",
]
