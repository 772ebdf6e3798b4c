"""The ``labradorite`` BSDF: a Mitsuba 3 plugin written in Python (paper §3, DESIGN.md §2-3).

Three components, each importance-sampled by its own shape:

0. ``DeltaReflection`` — the polished surface: Fresnel mirror at ``eta`` (Mueller
   Fresnel in polarized variants).
1. ``GlossyReflection`` — the schiller: light refracted into the stone, mirrored
   by the lamella planes (normals spread around ``normal`` by an axial von
   Mises-Fisher lobe of angular width ``spread_deg``), refracted back out;
   weighted by both Fresnel transmissions and the stack reflectance
   R(λ, cos θ) at the internal angle. Depolarised (paper §3.3).
2. ``DiffuseReflection`` — the grey body: Lambertian with albedo ``body_albedo``
   times both Fresnel transmissions.

Frames. The lamella ``normal`` is given in the mesh (object) frame; labcut's
scenes place meshes in their render frame (moved and scaled, axes unchanged:
:class:`~labcut.rendering.scene.RenderFrame`), so it is also the world frame's
direction, and it is moved into the local shading frame per hit. It is axial: ``m`` and
``-m`` are the same orientation. All directions below are local, +Z the shading
normal, pointing away from the surface.

Schiller lobe (evaluated by :mod:`labcut.physics.schiller`, the one implementation the
flash estimators share). ``a`` and ``b`` are the internal directions (pointing up, into
the incident and exit half-spaces) that refract into ``wi`` and ``wo``: same
azimuth, ``sin θ_a = sin θ_i / η``. The lamella orientation that mirrors ``a``
into ``b`` is ``h = normalize(a + b)`` (DESIGN.md §4), and with ``q(h)`` the
axial vMF density of lamella orientations::

    f_s(wi, wo) = (1 - F(θ_i)) (1 - F(θ_o)) / η² · R(λ, |a·h|) q(h) / (4 |a·h| max(a_z, b_z))

The factor 1/η² with the two transmissions is radiance (étendue) conservation
through the interface; ``max(a_z, b_z)`` makes ``f_s`` reciprocal and keeps the
albedo <= T_i ∫ R q dω_h <= 1 (it equals the exact energy balance when the
lamellae lie parallel to the surface, a_z = b_z at the mirror direction).
Sampling draws ``h`` from ``q``, mirrors ``a`` and refracts out; the weight is
``T_i T_o R b_z / max(a_z, b_z)`` and the pdf
``q(h) cos θ_o / (4 |b·h| η² b_z)``.

Colour. Spectral variants evaluate R at ``si.wavelengths`` through
:func:`labcut.physics.stack_reflectance` (the same expression as the float64
API). RGB variants look R up in a table of linear sRGB over cos θ (R integrated
against the CIE curves under D65 once per material, :mod:`labcut.colour`); mono
variants in a table of luminance.

Studio body (optional, :mod:`labcut.rendering.studio`, presentation renders only): the
properties ``body_tint`` (an RGB colour of luminance 1) and ``body_grid`` / ``body_lo`` /
``body_hi`` (a baked grid of a body multiplier and a flash mask over the mesh's box) tint the
grey body and texture it with inclusions; the mask (1 outside inclusions) scales the schiller
where an inclusion sits at the surface. Without them the body is the grey Lambertian above and
the schiller is untouched. ``eval_diffuse_reflectance`` (Mitsuba's albedo AOV, the denoiser's
guide before it traced a shading guide of its own, kept for comparison) returns the body
reflectance plus the face-on flash colour R(λ, 1).

Colour zoning (optional, :mod:`labcut.rendering.zoning`, docs/zoning.md): the
properties ``zoning_grid``, ``zoning_path``, ``zoning_lo``, ``zoning_hi`` carry a
baked noise grid and a parameter path; R then varies with the hit point ``si.p``
and the BSDF is flagged ``SpatiallyVarying``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np

from ..colour import LUMINANCE_TABLE_SIZE
from ..errors import ParameterError
from ..physics import schiller as lobe
from ..physics.lamella import interface_amplitudes, phase_wavenumbers, stack_reflectance, stack_reflectance_sp
from ..physics.material import Labradorite
from ..physics.ops import drjit_ops
from ..validation import unit_vector
from .textures import texture_box, texture_data

PLUGIN_NAME = "labradorite"
TABLE_SIZE = LUMINANCE_TABLE_SIZE  # entries over cos θ in [0, 1] for the RGB / mono tables

# the plugin's material properties are the Labradorite fields themselves (no hand-kept list)
_MATERIAL_KEYS = tuple(f.name for f in dataclasses.fields(Labradorite) if f.name != "name")


def material_from_props(props: Any) -> Labradorite:
    """The :class:`Labradorite` described by a plugin's properties (validated)."""
    params: dict[str, Any] = {}
    for key in _MATERIAL_KEYS:
        if key in props:
            params[key] = props[key]
    return Labradorite(**params)


def _normal_from_props(props: Any) -> tuple[float, float, float]:
    if "normal" not in props:
        return (0.0, 0.0, 1.0)
    value = props["normal"]
    try:
        m = [float(value[0]), float(value[1]), float(value[2])]
    except (TypeError, IndexError, ValueError):
        raise ParameterError("lamella normal must be three numbers") from None
    return tuple(float(x) for x in unit_vector(m, "lamella normal"))


#: The plugin's properties, Mitsuba's ``pluginparameters`` way: (name, type, default, meaning).
#: The module docstring's table and docs/plugin.md (``tools/plugin_docs.py``) are written from it.
PLUGIN_PARAMETERS: tuple[tuple[str, str, str, str], ...] = (
    ("normal", "vector", "(0, 0, 1)", "Lamella normal in the mesh (object) frame; axial (m and -m are the same). "
     "Differentiable: exposed by `traverse` as `normal`."),
    *(
        (f.name, "float" if f.name != "pairs" else "integer", f"{f.default!r}",
         f"`Labradorite.{f.name}` (validated as there; see docs/physics.md).")
        for f in dataclasses.fields(Labradorite) if f.name != "name"
    ),
    ("surface", "boolean", "true", "Simulate the polished surface's Fresnel mirror (component 0)."),
    ("schiller", "boolean", "true", "Simulate the schiller lobe (component 1)."),
    ("body", "boolean", "true", "Simulate the grey body (component 2); off when `body_albedo` is 0."),
    ("body_tint", "rgb", "(1, 1, 1)", "Studio look: linear sRGB tint of the body (luminance 1; `body_albedo` sets the brightness)."),
    ("body_grid", "tensor", "(none)", "Studio look: baked (nz, ny, nx, 2) grid of the body multiplier and the flash mask "
     "(dark inclusions) over the box `body_lo`..`body_hi` (scene coordinates; labcut renders: the stone's render frame)."),
    ("body_lo", "point", "(none)", "Studio look: the body grid's low corner, scene coordinates (labcut: the render frame)."),
    ("body_hi", "point", "(none)", "Studio look: the body grid's high corner, scene coordinates (labcut: the render frame)."),
    ("zoning_grid", "tensor", "(none)", "Colour zoning: baked noise values x in [0, 1], shape (nz, ny, nx, 1) "
     "(docs/zoning.md); needs the three below."),
    ("zoning_path", "tensor", "(none)", "Colour zoning: the parameter path, (N, 5) rows of d_a, d_b, sigma_a, "
     "sigma_b, pairs at x = i / (N - 1)."),
    ("zoning_lo", "point", "(none)", "Colour zoning: the grid box's low corner, scene coordinates (labcut: the render frame)."),
    ("zoning_hi", "point", "(none)", "Colour zoning: the grid box's high corner, scene coordinates (labcut: the render frame)."),
)


def plugin_parameter_table() -> str:
    """The plugin's properties as a markdown table (docs/plugin.md, the module docstring)."""
    rows = ["| property | type | default | meaning |", "|---|---|---|---|"]
    rows += [f"| `{n}` | {t} | {d} | {m} |" for n, t, d, m in PLUGIN_PARAMETERS]
    return "\n".join(rows)


__doc__ = (__doc__ or "") + "\nPlugin parameters\n-----------------\n\n" + plugin_parameter_table() + "\n"

_CLASSES: dict[str, type] = {}


def bsdf_class() -> type:
    """The plugin class for the current Mitsuba variant (``mi.BSDF`` differs per variant)."""
    variant = mi.variant()
    if variant is None or variant.startswith("scalar"):
        raise ParameterError("the labradorite BSDF needs a JIT variant (llvm_ad_* or cuda_ad_*)")
    if variant not in _CLASSES:
        _CLASSES[variant] = _define_class()
    return _CLASSES[variant]


def _define_class() -> type:
    class LabradoriteBSDF(mi.BSDF):
        """Mitsuba BSDF plugin ``labradorite``: its properties are the table
        :data:`PLUGIN_PARAMETERS` (the module docstring, docs/plugin.md). A switched-off
        lobe keeps its component so indices stay 0/1/2. Differentiable parameter exposed
        by ``traverse``: ``normal``.
        """

        def __init__(self, props: Any) -> None:
            mi.BSDF.__init__(self, props)
            self.material = material_from_props(props)
            self.stack = self.material.stack
            self.normal = mi.Vector3f(*_normal_from_props(props))
            dr.make_opaque(self.normal)  # a value, not a literal: a new normal must not recompile the kernel
            self.eta = float(self.material.n_surface)
            self.kappa = self.material.lobe_kappa
            # density normalisation of the axial vMF over the hemisphere around m
            self.one_minus_exp_k = -math.expm1(-self.kappa)
            self.q_norm = self.material.lobe_norm
            self.use_surface = bool(props.get("surface", True))
            self.use_schiller = bool(props.get("schiller", True))
            self.use_body = bool(props.get("body", True)) and self.material.body_albedo > 0.0
            self._spectral = bool(mi.is_spectral)
            self.zoning = None
            if "zoning_grid" in props:
                from .zoning import SHARED_KEYS
                from .zoning_kernel import ZoningKernel

                self.zoning = ZoningKernel(props, {k: getattr(self.material, k) for k in SHARED_KEYS})
            self._build_tables()
            self._init_body(props)

            front = mi.BSDFFlags.FrontSide
            self.m_components = [
                mi.BSDFFlags.DeltaReflection | front,
                mi.BSDFFlags.GlossyReflection | front,
                mi.BSDFFlags.DiffuseReflection | front,
            ]
            self.m_flags = self.m_components[0] | self.m_components[1] | self.m_components[2]
            if self.zoning is not None or self.body_grid is not None:
                self.m_flags = self.m_flags | mi.BSDFFlags.SpatiallyVarying
            # Kernel constants as opaque values: another material (or spread) reuses the
            # compiled kernel instead of baking new literals into a new one.
            self._eta = dr.opaque(mi.Float, self.eta)
            self._kappa = dr.opaque(mi.Float, self.kappa)
            self._q_norm = dr.opaque(mi.Float, self.q_norm)
            self._one_minus_exp_k = dr.opaque(mi.Float, self.one_minus_exp_k)
            self._schiller_weight = dr.opaque(mi.Float, float(self.schiller_weight))
            self._albedo = dr.opaque(mi.Float, float(self.material.body_albedo))
            self._stack = self.stack.opaque(mi.Float)  # the spectral and polarised lobes' stack

        # ------------------------------------------------------------------ set-up
        def _build_tables(self) -> None:
            """Per-material lookup tables (RGB / mono) and the lobe-selection weight."""
            from ..colour import luminance_table, rgb_table

            if self.zoning is not None:  # the zoning's own tables; sampling weight averaged over x
                self.schiller_weight = self.zoning.weight
                self.table = None
                return
            c, lum = luminance_table(self.material)
            # schiller sampling weight: mean luminance reflectance over the angles light meets
            self.schiller_weight = float(max(np.mean(lum[TABLE_SIZE // 2 :]), 0.02))
            self.table = None
            self.table_sp = None
            if not self._spectral:
                if mi.is_rgb:
                    data = rgb_table(self.material)
                else:
                    data = lum[:, None].astype(np.float32)
                self.table = mi.Texture1f(texture_data(data))
                if mi.is_polarized:  # mono polarized: luminance of R_s and R_p
                    from ..colour import reflectance_luminance

                    sp = np.stack([reflectance_luminance(self.material, c, polarization=pol) for pol in ("s", "p")], axis=1)
                    self.table_sp = mi.Texture1f(texture_data(np.clip(sp, 0.0, None)))

        def _init_body(self, props: Any) -> None:
            """The studio body: tint and the baked (body multiplier, flash mask) grid (optional)."""
            self.body_tint = None
            self.body_grid = None
            if "body_tint" in props:
                t = props["body_tint"]
                tint = np.array([float(t[k]) for k in range(3)])
                if not np.all(np.isfinite(tint)) or np.any(tint < 0.0):
                    raise ParameterError("body_tint must be three finite numbers >= 0")
                if mi.is_rgb:
                    self.body_tint = mi.Color3f(*tint.tolist())
            if "body_grid" in props:
                if "body_lo" not in props or "body_hi" not in props:
                    raise ParameterError("body_grid needs body_lo and body_hi")
                g = np.array(props["body_grid"], dtype=np.float32)
                if g.ndim != 4 or g.shape[3] != 2 or min(g.shape[:3]) < 2 or not np.all(np.isfinite(g)) or np.any(g < 0):
                    raise ParameterError(f"body_grid must be a finite (nz, ny, nx, 2) tensor >= 0, got shape {g.shape}")
                lo = np.array([float(props["body_lo"][k]) for k in range(3)])
                hi = np.array([float(props["body_hi"][k]) for k in range(3)])
                if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
                    raise ParameterError("body_lo must lie below body_hi on every axis")
                self.body_lo, self.body_inv_ext = texture_box(lo, hi)
                self.body_grid = mi.Texture3f(texture_data(g), use_accel=False, filter_mode=dr.FilterMode.Linear,
                                              wrap_mode=dr.WrapMode.Clamp)

        def _body_at(self, si: Any) -> tuple[Any, Any]:
            """(body multiplier, flash mask) at the hit (1, 1 without a studio body grid)."""
            if self.body_grid is None:
                return mi.Float(1.0), mi.Float(1.0)
            u = (mi.Point3f(si.p) - self.body_lo) * self.body_inv_ext
            v = self.body_grid.eval(u)
            return v[0], dr.clip(v[1], 0.0, 1.0)

        def _body_colour(self, si: Any) -> Any:
            """Body reflectance (albedo x tint x multiplier) as an UnpolarizedSpectrum."""
            mult, _ = self._body_at(si)
            value = self._albedo * mult
            if self.body_tint is not None:
                return mi.UnpolarizedSpectrum(self.body_tint * value)
            return mi.UnpolarizedSpectrum(value)

        # ------------------------------------------------------------------ helpers
        def _lamella_reflectance(self, si: Any, cos_l: Any) -> Any:
            """R(λ, cos θ_l) as an UnpolarizedSpectrum."""
            if self.zoning is not None:
                return self.zoning.reflectance(si, cos_l)
            if self._spectral:
                r = stack_reflectance(si.wavelengths, cos_l, self._stack)
                return mi.UnpolarizedSpectrum(r)
            # texel i sits at (i + 0.5)/N: map cos θ in [0, 1] onto the texel centres
            coord = (dr.clip(cos_l, 0.0, 1.0) * (TABLE_SIZE - 1) + 0.5) * (1.0 / TABLE_SIZE)
            values = self.table.eval(mi.Point1f(coord))
            if len(values) == 1:
                return mi.UnpolarizedSpectrum(values[0])
            return mi.UnpolarizedSpectrum(values[0], values[1], values[2])

        def _internal(self, w: Any) -> Any:
            """Internal direction (pointing up) that refracts into the external direction ``w``."""
            return lobe.internal_direction(w, mi.Vector3f(0.0, 0.0, 1.0), self._eta, drjit_ops())

        def _external(self, b: Any) -> tuple[Any, Any]:
            """External direction of the internal direction ``b``, and whether it escapes (no TIR)."""
            tx, ty = b.x * self._eta, b.y * self._eta
            s2 = tx * tx + ty * ty
            return mi.Vector3f(tx, ty, dr.safe_sqrt(1.0 - s2)), (s2 < 1.0) & (b.z > 0.0)

        def _lamella_local(self, si: Any) -> Any:
            return si.to_local(dr.normalize(self.normal))

        def _q(self, cos_hm: Any) -> Any:
            """Axial vMF density of lamella orientation at |h·m| = ``cos_hm`` (per steradian)."""
            return lobe.lobe_density(cos_hm, self._kappa, self._q_norm, drjit_ops())

        def _weights(self, ctx: Any, cos_i: Any) -> tuple[Any, Any, Any, Any]:
            """Selection probabilities of (surface, schiller, body) and the Fresnel term."""
            f_i = lobe.fresnel_reflectance(cos_i, self._eta, drjit_ops())
            w_spec = f_i if (self.use_surface and ctx.is_enabled(mi.BSDFFlags.DeltaReflection, 0)) else mi.Float(0.0)
            w_sch = (1.0 - f_i) * self._schiller_weight if (self.use_schiller and ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1)) else mi.Float(0.0)
            w_body = (1.0 - f_i) * self._albedo if (self.use_body and ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 2)) else mi.Float(0.0)
            total = w_spec + w_sch + w_body
            inv = dr.select(total > 0.0, dr.rcp(total), 0.0)
            return w_spec * inv, w_sch * inv, w_body * inv, f_i

        def _schiller_parts(self, si: Any, wo: Any) -> tuple[Any, Any, Any]:
            """(unpolarised value, pdf, (geometric weight without R, cos θ_l, h)) of the schiller lobe."""
            ops = drjit_ops()
            n = mi.Vector3f(0.0, 0.0, 1.0)
            cos_i, cos_o = mi.Frame3f.cos_theta(si.wi), mi.Frame3f.cos_theta(wo)
            a, b, h, cos_l, max_ab = lobe.schiller_geometry(si.wi, wo, n, self._eta, ops)
            q = self._q(dr.dot(h, self._lamella_local(si)))
            t_i = lobe.transmission(cos_i, self._eta, ops)
            t_o = lobe.transmission(cos_o, self._eta, ops)
            factor = lobe.schiller_factor(t_i, t_o, cos_l, max_ab, self._eta, ops)
            r = self._lamella_reflectance(si, cos_l)
            if self.body_grid is not None:
                r = r * self._body_at(si)[1]  # an inclusion at the surface blocks the flash
            geom = factor * q * cos_o
            pdf = lobe.schiller_pdf(q, cos_l, b.z, cos_o, self._eta, ops)
            return r * geom, pdf, (geom, cos_l, h)

        def _schiller_mueller(self, ctx: Any, si: Any, wo: Any, geom: Any, cos_l: Any, h: Any) -> Any:
            """The schiller as a Mueller matrix (polarized variants): the stack's R_s and R_p in the
            plane of incidence on the lamellae (a diattenuator; the handedness flips like a mirror's
            where r_s r_p < 0), rotated into the Stokes bases of the two directions as Mitsuba's
            microfacet conductors do with the microfacet normal, here the lamella orientation h.
            The small rotation of the plane of polarisation by the two refractions at the polished
            surface, and the polarisation of its transmissions, are left out."""
            m = self.material
            if self._spectral:
                r_s, r_p, sign = stack_reflectance_sp(si.wavelengths, cos_l, self._stack)
                r_s, r_p = mi.UnpolarizedSpectrum(r_s), mi.UnpolarizedSpectrum(r_p)
            else:  # mono polarized: luminance tables of R_s and R_p
                coord = (dr.clip(cos_l, 0.0, 1.0) * (TABLE_SIZE - 1) + 0.5) * (1.0 / TABLE_SIZE)
                values = self.table_sp.eval(mi.Point1f(coord))
                r_s, r_p = mi.UnpolarizedSpectrum(values[0]), mi.UnpolarizedSpectrum(values[1])
                q_a, q_b = phase_wavenumbers(cos_l, m.n_a, m.n_b, m.n_surface, drjit_ops())
                rs_amp, rp_amp = interface_amplitudes(mi.Float(q_a), mi.Float(q_b), m.n_a, m.n_b)
                sign = dr.select(rs_amp * rp_amp < 0.0, -1.0, 1.0)
            retard = mi.mueller.linear_retarder(mi.UnpolarizedSpectrum(dr.select(sign < 0.0, dr.pi, 0.0)))
            mueller = retard @ mi.mueller.diattenuator(r_s, r_p)
            wi_hat = wo if ctx.mode == mi.TransportMode.Radiance else si.wi
            wo_hat = si.wi if ctx.mode == mi.TransportMode.Radiance else wo
            s_in = dr.cross(h, -wo_hat)
            s_out = dr.cross(h, wi_hat)
            degenerate = (dr.squared_norm(s_in) < 1e-12) | (dr.squared_norm(s_out) < 1e-12)
            s_in = dr.select(degenerate, mi.Frame3f(-wo_hat).s, dr.normalize(s_in))
            s_out = dr.select(degenerate, mi.Frame3f(wi_hat).s, dr.normalize(s_out))
            mueller = mi.mueller.rotate_mueller_basis(
                mueller, -wo_hat, s_in, mi.mueller.stokes_basis(-wo_hat), wi_hat, s_out, mi.mueller.stokes_basis(wi_hat)
            )
            return mueller * geom

        def _lobe_sum(self, ctx: Any, si: Any, wo: Any, sch: Any, body_value: Any, use_sch: Any, use_body: Any) -> Any:
            """Schiller plus body as a ``mi.Spectrum``: in polarized variants the schiller is its
            Mueller matrix (a zoned stone's schiller, and the body, are depolarised)."""
            value, _, (geom, cos_l, h) = sch
            if not mi.is_polarized or self.zoning is not None:
                return self._to_spectrum(value * use_sch + body_value * use_body)
            return self._schiller_mueller(ctx, si, wo, geom * use_sch, cos_l, h) + self._to_spectrum(body_value * use_body)

        def _body_terms(self, si: Any, wo: Any) -> tuple[Any, Any]:
            ops = drjit_ops()
            cos_i = mi.Frame3f.cos_theta(si.wi)
            cos_o = mi.Frame3f.cos_theta(wo)
            t = lobe.transmission(cos_i, self._eta, ops) * lobe.transmission(cos_o, self._eta, ops)
            if self.body_tint is None and self.body_grid is None:
                value = self._albedo * dr.inv_pi * t * cos_o
            else:
                value = self._body_colour(si) * (dr.inv_pi * t * cos_o)
            return value, mi.warp.square_to_cosine_hemisphere_pdf(wo)

        def eval_diffuse_reflectance(self, si: Any, active: Any = True) -> Any:
            """Albedo for the denoiser's AOV: body reflectance plus the face-on flash colour R(λ, 1)."""
            body = self._body_colour(si) if self.use_body else mi.UnpolarizedSpectrum(0.0)
            flash = mi.UnpolarizedSpectrum(0.0)
            if self.use_schiller:
                flash = self._lamella_reflectance(si, mi.Float(1.0)) * self._body_at(si)[1]
            return self._to_spectrum(dr.clip(body + flash, 0.0, 1.0))

        def _to_spectrum(self, value: Any) -> Any:
            if mi.is_polarized:
                return mi.Spectrum(mi.mueller.depolarizer(mi.UnpolarizedSpectrum(value)))
            return mi.Spectrum(value)

        def _surface_weight(self, ctx: Any, si: Any, wo: Any, f_i: Any) -> Any:
            """Weight of the delta surface reflection (Mueller matrix in polarized variants)."""
            if not mi.is_polarized:
                return mi.Spectrum(f_i)
            wi_hat = wo if ctx.mode == mi.TransportMode.Radiance else si.wi
            wo_hat = si.wi if ctx.mode == mi.TransportMode.Radiance else wo
            eta = mi.Complex2f(self._eta, 0.0)
            value = mi.Spectrum(mi.mueller.specular_reflection(mi.Frame3f.cos_theta(wo_hat), eta))
            n = mi.Vector3f(0.0, 0.0, 1.0)
            s_in = dr.normalize(dr.cross(n, -wo_hat))
            s_out = dr.normalize(dr.cross(n, wi_hat))
            collinear = dr.all(s_in == 0.0) | dr.any(dr.isnan(s_in))
            s_in = dr.select(collinear, mi.Vector3f(1.0, 0.0, 0.0), s_in)
            s_out = dr.select(collinear, mi.Vector3f(1.0, 0.0, 0.0), s_out)
            return mi.mueller.rotate_mueller_basis(
                value, -wo_hat, s_in, mi.mueller.stokes_basis(-wo_hat), wi_hat, s_out, mi.mueller.stokes_basis(wi_hat)
            )

        # ------------------------------------------------------------------ BSDF interface
        def sample(self, ctx: Any, si: Any, sample1: Any, sample2: Any, active: Any = True) -> tuple[Any, Any]:
            cos_i = mi.Frame3f.cos_theta(si.wi)
            active = mi.Bool(active) & (cos_i > 0.0)
            p_spec, p_sch, p_body, f_i = self._weights(ctx, cos_i)

            pick_spec = sample1 < p_spec
            pick_sch = (~pick_spec) & (sample1 < p_spec + p_sch)
            pick_body = (~pick_spec) & (~pick_sch) & (p_body > 0.0)

            # schiller: h from the axial vMF around m, mirror a, refract out
            m = self._lamella_local(si)
            m = dr.select(dr.dot(m, self._internal(si.wi)) < 0.0, -m, m)
            k = self._kappa
            w = dr.clip(1.0 + dr.log(1.0 - sample2.x * self._one_minus_exp_k) / k, 0.0, 1.0)
            sin_w = dr.safe_sqrt(1.0 - w * w)
            phi = dr.two_pi * sample2.y
            sp, cp = dr.sincos(phi)
            h = mi.Frame3f(m).to_world(mi.Vector3f(sin_w * cp, sin_w * sp, w))
            a = self._internal(si.wi)
            h = dr.select(dr.dot(a, h) < 0.0, -h, h)
            b = 2.0 * dr.dot(a, h) * h - a
            wo_sch, escapes = self._external(b)

            wo_body = mi.warp.square_to_cosine_hemisphere(sample2)
            wo_spec = mi.reflect(si.wi)

            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = dr.select(pick_spec, wo_spec, dr.select(pick_sch, wo_sch, wo_body))
            bs.eta = 1.0
            bs.sampled_component = dr.select(pick_spec, mi.UInt32(0), dr.select(pick_sch, mi.UInt32(1), mi.UInt32(2)))
            bs.sampled_type = dr.select(
                pick_spec,
                mi.UInt32(+mi.BSDFFlags.DeltaReflection),
                dr.select(pick_sch, mi.UInt32(+mi.BSDFFlags.GlossyReflection), mi.UInt32(+mi.BSDFFlags.DiffuseReflection)),
            )
            active &= pick_spec | (pick_sch & escapes) | pick_body
            active &= mi.Frame3f.cos_theta(bs.wo) > 0.0

            # non-delta: value / pdf of the mixture (as plastic.cpp does)
            sch = self._schiller_parts(si, bs.wo)
            body_val, body_pdf = self._body_terms(si, bs.wo)
            pdf_mix = p_sch * sch[1] + p_body * body_pdf
            bs.pdf = dr.select(pick_spec, p_spec, pdf_mix)
            value_mix = self._lobe_sum(ctx, si, bs.wo, sch, body_val, dr.select(p_sch > 0.0, 1.0, 0.0), dr.select(p_body > 0.0, 1.0, 0.0))
            weight_mix = value_mix * dr.select(pdf_mix > 0.0, dr.rcp(pdf_mix), 0.0)
            weight_spec = self._surface_weight(ctx, si, bs.wo, f_i) * dr.select(p_spec > 0.0, dr.rcp(p_spec), 0.0)
            weight = dr.select(pick_spec, weight_spec, weight_mix)
            active &= bs.pdf > 0.0
            return bs, dr.select(active, weight, 0.0)

        def eval(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            value, _ = self._eval_pdf(ctx, si, wo, active)
            return value

        def pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            _, pdf = self._eval_pdf(ctx, si, wo, active)
            return pdf

        def eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> tuple[Any, Any]:
            return self._eval_pdf(ctx, si, wo, active)

        def _eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any) -> tuple[Any, Any]:
            cos_i = mi.Frame3f.cos_theta(si.wi)
            cos_o = mi.Frame3f.cos_theta(wo)
            active = mi.Bool(active) & (cos_i > 0.0) & (cos_o > 0.0)
            p_spec, p_sch, p_body, _ = self._weights(ctx, cos_i)
            use_sch = self.use_schiller and ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1)
            use_body = self.use_body and ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 2)
            pdf = mi.Float(0.0)
            sch = None
            body_value = mi.UnpolarizedSpectrum(0.0)
            if use_sch:
                sch = self._schiller_parts(si, wo)
                pdf += p_sch * sch[1]
            if use_body:
                body_value, p = self._body_terms(si, wo)
                pdf += p_body * p
            if sch is None:
                value = self._to_spectrum(body_value)
            else:
                value = self._lobe_sum(ctx, si, wo, sch, body_value, 1.0, 1.0)
            return (
                dr.select(active, value, 0.0),
                dr.select(active, pdf, 0.0),
            )

        def traverse(self, callback: Any) -> None:
            callback.put("normal", self.normal, mi.ParamFlags.Differentiable)

        def parameters_changed(self, keys: list[str]) -> None:
            pass  # the normal is normalised where it is used; nothing is cached from it

        def to_string(self) -> str:
            m = self.material
            return (
                f"LabradoriteBSDF[normal={self.normal}, d=({m.d_a:g}, {m.d_b:g}) nm, "
                f"sigma=({m.sigma_a:g}, {m.sigma_b:g}) nm, pairs={m.pairs}, spread={m.spread_deg:g} deg, "
                f"body_albedo={m.body_albedo:g}, eta={self.eta:g}{', zoned' if self.zoning is not None else ''}]"
            )

    return LabradoriteBSDF


def register() -> None:
    """Register the plugin for the current variant (idempotent)."""
    cls = bsdf_class()
    mi.register_bsdf(PLUGIN_NAME, lambda props: cls(props))


def _on_variant_change(old: str | None, new: str | None) -> None:
    if new is not None and not new.startswith("scalar"):
        register()


if mi.variant() is not None and not mi.variant().startswith("scalar"):
    register()
mi.detail.add_variant_callback(_on_variant_change)
