"""A render's plan: which Mitsuba variant, integrator, path depth and lobes a request needs for a
stone, and why (:func:`plan_render`). Decided before any scene is built; the request's checks
(:class:`~labcut.rendering.request.RenderRequest`) and the render (:mod:`labcut.rendering.api`) share it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from ..errors import ParameterError
from ..geometry.stone import Stone

#: the BSDF's lobes a render may switch (all by default; a flash map renders the schiller alone)
LOBES = ("surface", "schiller", "body")


@dataclass(frozen=True)
class RenderPlan:
    """What a render simulates, and why."""

    variant: str
    integrator: str
    max_depth: int
    lobes: tuple[str, ...]
    convex: bool
    polarizer_deg: float | None
    reasons: tuple[str, ...] = ()
    look: str = "diagram"
    denoise: bool = False
    zoning: str | None = None
    #: the effect planner's plan of the render (:meth:`labcut.planner.EffectPlan.to_dict`)
    effects: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def plan_render(
    stone: Any,
    lighting: Any = None,
    mode: str = "rgb",
    polarizer_deg: float | None = None,
    lobes: Sequence[str] = LOBES,
    max_depth: int | None = None,
    *,
    look: Any = "diagram",
    denoise: bool | None = None,
    zoning: Any = None,
) -> RenderPlan:
    """Choose variant, integrator and depth for a request (see the module docstring).

    ``stone``: a :class:`~labcut.Stone` or trimesh (whether it is convex decides the bounces), or
    True / False: a convex or non-convex stone (the checks that do not depend on the shape).
    ``lighting``: the :class:`~labcut.Lights` (mesh frame) the render uses, for the record.
    ``look``: ``"diagram"`` | ``"studio"`` | a :class:`~labcut.rendering.studio.Studio`.
    ``denoise``: None (default: on for the studio look where the colour transport allows it),
    True or False. ``zoning``: the :class:`~labcut.rendering.zoning.Zoning` used, for the record."""
    from .studio import resolve_look
    from ..backend import variant_name

    lobes = tuple(lobes)
    bad = [x for x in lobes if x not in LOBES]
    if bad or not lobes:
        raise ParameterError(f"lobes must be a non-empty subset of {', '.join(LOBES)}, got {list(lobes)}", parameter="lobes")
    polarized = polarizer_deg is not None
    if polarized and mode == "rgb":
        mode = "spectral"
    variant = variant_name(mode, polarized)
    convex = stone if isinstance(stone, bool) else Stone.of(stone).convex
    reasons = [f"{mode} colour{' with polarization (polarizer given)' if polarized else ''}"]
    studio = resolve_look(look)
    if max_depth is not None:
        integrator, depth = ("path", int(max_depth))
        reasons.append(f"path tracing to depth {depth} as requested")
    elif studio is not None and convex and studio.max_depth > 2:
        integrator, depth = ("path", studio.max_depth)
        reasons.append(f"studio look: path tracing to depth {depth}, so the polish mirrors the lamps, the tent and the table")
    elif convex:
        integrator, depth = ("direct", 2)
        reasons.append("convex stone: direct lighting is exact (no light path leaves and re-enters)")
    else:
        integrator, depth = ("path", 4)
        reasons.append("non-convex stone: path tracing, 3 bounces, for light reflected between parts")
    if lobes != LOBES:
        reasons.append(f"lobes: {', '.join(lobes)} only")
    if lighting is not None and studio is None:
        parts = [f"{lighting.n_lamps} lamp direction(s) as distant lights"] if lighting.n_lamps else []
        if lighting.environment is not None:
            parts.append(f"environment map {lighting.environment.name!r} (the map the optimiser samples)")
        reasons.append(f"lights ({lighting.name}): {' and '.join(parts)}")
    if studio is not None:
        if lighting is not None:
            from .studio import lamps_of

            lamps = lamps_of(lighting, studio.point_lamp_deg)
            sizes = ", ".join(f"{lamp.radius_deg:.1f}°{' (a point lamp, drawn this size)' if lamp.point else ''}" for lamp in lamps)
            parts = [f"{len(lamps)} lamp(s) as area lights {studio.lamp_distance:g} stone radii away, radius {sizes}"] if lamps else []
            if lighting.environment is not None:
                parts.append(f"environment map {lighting.environment.name!r}")
            parts.append(f"a light tent ({studio.tent_share:.0%} of the lamps' irradiance on a face-up card)")
            reasons.append(f"lights ({lighting.name}): {', '.join(parts)}")
        reasons.append(f"studio look: grey table (albedo {studio.backdrop_albedo:g}) with a contact shadow; dark grey-green body"
                       f"{f' with dark inclusions ({studio.inclusions:.0%}, seed {studio.seed})' if studio.inclusions > 0 else ''}; "
                       "perspective camera; AgX tone curve; exposure metered from the lights")
    can_denoise = not polarized and mode != "mono"
    if denoise is None:
        use_denoise = studio is not None and can_denoise
    else:
        use_denoise = bool(denoise)
        if use_denoise and not can_denoise:
            raise ParameterError("denoising needs rgb or spectral colour without a polarizer")
    if use_denoise:
        from .denoise import available

        if not available():  # before any work, not after the colour is traced
            from ..errors import BackendError

            raise BackendError("denoising needs the pyoidn package (pip install pyoidn), or render with denoise off")
        reasons.append("denoised with Intel Open Image Denoise, demodulated by a noise-free shading guide, with the normal")
    zone_name = None
    if zoning is not None:
        zone_name = getattr(zoning, "name", None) or "custom"
        reasons.append(f"colour zoning ({zone_name}): {len(zoning.materials)} parameter sets, {zoning.mode} transitions")
    return RenderPlan(variant, integrator, depth, lobes, convex, polarizer_deg, tuple(reasons),
                      "diagram" if studio is None else "studio", use_denoise, zone_name)
