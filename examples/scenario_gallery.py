"""Write docs/scenarios.md: every wear scenario, what it means in the mesh frame, and its answer.

    .venv/bin/python examples/scenario_gallery.py              # docs/scenarios.md, docs/images/scenario-*.png
    .venv/bin/python examples/scenario_gallery.py --quick      # draft quality, small renders (for tests)

For each scenario of :data:`labcut.scene.SCENARIOS` it draws the lights and viewers
of its rest pose in the mesh frame (a polar diagram: +Z face-up at the centre, the
tilt from +Z as radius), recommends the lamella orientation of the bundled
16 x 12 mm low oval cabochon (blue labradorite) and renders it from the scenario's
main view under the scenario's own lights.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import labcut
from labcut.backend import device
from labcut.fileio import atomic_output
from labcut.scene import LIGHTING, SCENARIOS, VIEWING, Scenario

ROOT = Path(__file__).resolve().parents[1]


def polar(ax, directions: np.ndarray, **kwargs) -> None:
    d = np.asarray(directions, dtype=np.float64)
    tilt = np.degrees(np.arccos(np.clip(d[:, 2], -1.0, 1.0)))
    az = np.arctan2(d[:, 1], d[:, 0])
    ax.scatter(tilt * np.cos(az), tilt * np.sin(az), **kwargs)


def diagram(scenario: Scenario, path: Path) -> None:
    """Lights (size ~ irradiance) and viewers of every pose, in the mesh frame."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.2, 4.2), constrained_layout=True)
    for r in (30, 60, 90, 120, 150):
        ax.add_patch(plt.Circle((0, 0), r, fill=False, lw=0.5, color="0.8" if r != 90 else "0.4", ls="-" if r != 90 else "--"))
    for k, st in enumerate(scenario.settings()):
        rest = k == 0
        w = st.lights.weights / st.lights.weights.max()
        polar(ax, st.lights.directions, s=8 + 60 * w, c="#f2b705" if rest else "#f9e4a0", edgecolors="none", zorder=2 if rest else 1,
              label="lights (rest pose)" if rest else ("lights (rocked)" if k == 1 else None))
        polar(ax, st.views.directions, s=14, marker="^", c="#1f77b4" if rest else "#a6c8e8", zorder=3 if rest else 1,
              label="viewers (rest pose)" if rest else ("viewers (rocked)" if k == 1 else None))
    main = scenario.main_setting()
    polar(ax, main.views.main[None, :], s=90, marker="*", c="#d62728", zorder=4, label="main view (render)")
    up = main.up()
    ax.annotate("", xy=(40 * up[0], 40 * up[1]), xytext=(0, 0), arrowprops={"arrowstyle": "->", "color": "0.3"})
    ax.text(44 * up[0], 44 * up[1], "world up", fontsize=7, color="0.3", ha="center")
    ax.set_xlim(-160, 160)
    ax.set_ylim(-160, 160)
    ax.set_aspect("equal")
    ax.set_xlabel("towards +X (right), degrees from +Z")
    ax.set_ylabel("towards +Y (back / top), degrees from +Z")
    ax.set_title(f"{scenario.name}: mesh frame (dashed: the face's horizon)", fontsize=8)
    ax.legend(fontsize=6, loc="lower left")
    with atomic_output(path, (".png",)) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs"), help="docs folder (images go to its images/)")
    parser.add_argument("--quick", action="store_true", help="draft quality and small renders")
    args = parser.parse_args()
    out = Path(args.out)
    (out / "images").mkdir(parents=True, exist_ok=True)
    quality, spp, res = ("draft", 8, 96) if args.quick else ("standard", 128, 320)
    mesh = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    material = labcut.Labradorite.preset("blue")
    rows, sections = [], []
    for entry in SCENARIOS.entries():
        scenario = Scenario.preset(entry.name, quality)
        t = time.perf_counter()
        rec = labcut.recommend_orientation(mesh, material, scenario=scenario, quality=quality)
        seconds = time.perf_counter() - t
        img = out / "images" / f"scenario-{entry.name}.png"
        dia = out / "images" / f"scenario-{entry.name}-diagram.png"
        labcut.render(mesh, material, rec.normal, scenario=scenario, spp=spp, resolution=res, output=img)
        diagram(scenario, dia)
        m = rec.metrics
        rows.append(f"| `{entry.name}` | {rec.tilt_deg:.1f}° | {rec.azimuth_deg:.0f}° | ±{rec.tolerance_deg:.1f}° | "
                    f"{m.flash_energy:.4f} | {m.flash_area:.1%} | {m.coverage:.0%} | {len(scenario.poses())} | {seconds:.1f} s |")
        pose = scenario.pose
        sections.append(
            f"### `{entry.name}`\n\n{entry.summary}.\n\n"
            f"- lighting `{scenario.lights.name}` ({len(scenario.lights)} directions"
            f"{', environment map ' + repr(scenario.lights.environment.name) if scenario.lights.environment is not None else ''}), "
            f"viewing `{scenario.views.name}` ({len(scenario.views)} directions), "
            f"{len(scenario.poses())} pose(s){f' (rocked ±{scenario.rock_deg:g}° front-to-back, ±{scenario.sway_deg:g}° sideways)' if scenario.rock_deg or scenario.sway_deg else ''}.\n"
            f"- mesh frame: face (+Z) points to world {np.round(pose @ [0, 0, 1], 3).tolist()}, "
            f"the stone's +Y end to world {np.round(pose @ [0, 1, 0], 3).tolist()}; "
            f"main view in the mesh frame {np.round(scenario.main_setting().views.main, 3).tolist()}.\n"
            f"- recommendation for the oval: {rec.description}.\n\n"
            f"| lights and viewers in the mesh frame | the recommendation, as the main viewer sees it |\n|---|---|\n"
            f"| ![{entry.name} diagram](images/{dia.name}) | ![{entry.name} render](images/{img.name}) |\n"
        )
        print(f"{entry.name}: {rec.description} ({seconds:.1f} s)")
    text = TEMPLATE.format(
        table="\n".join(rows),
        scenario_table="\n".join(f"| `{e.name}` | {e.summary} |" for e in SCENARIOS.entries()),
        lighting_table="\n".join(f"| `{e.name}` | {e.summary} |" for e in LIGHTING.entries()),
        viewing_table="\n".join(f"| `{e.name}` | {e.summary} |" for e in VIEWING.entries()),
        sections="\n".join(sections),
        quality=quality,
        spp=spp,
        res=res,
        machine=f"{platform.machine()}, {os.cpu_count()} cores, Dr.Jit {device()} backend",
        command="examples/scenario_gallery.py" + (" --quick" if args.quick else ""),
    )
    with atomic_output(out / "scenarios.md", (".md",)) as tmp:
        tmp.write_text(text)
    print(f"wrote {out / 'scenarios.md'}")


TEMPLATE = """# Wear scenarios

How a stone is lit, worn and seen decides which lamella orientation flashes. A
*scenario* says it in one word, the same on every command (`--scenario`) and in
the API (`scenario=`): `labcut.Scenario.preset("pendant")`,
`labcut.recommend_orientation(mesh, scenario="ring")`,
`labcut.render(mesh, lab, normal, scenario="bench")`. `labcut scenarios` lists
them with the lighting and viewing presets (the tables below are written from the
same registries).

| scenario | what it means |
|---|---|
{scenario_table}

## Frames

Scenarios live in a **world** with +Z up; the viewer usually stands at the
world's -Y ("in front"). The **mesh frame** is the stone's own: +Z face-up, the
base on z = 0, the front at -Y, and for stones worn upright (pendant, brooch) the
bail at the +Y end. A scenario's **pose** is the rotation taking mesh vectors to
world vectors:

- `face-up` (bench, ring, display, outdoor and their still versions): mesh +Z = world up, mesh -Y = the viewer's side;
- `face-front` (pendant): mesh +Z = world -Y (towards the viewer), mesh +Y = world up;
- brooch: `face-front` tilted back 15°, so the face looks slightly upward.

A **rocking motion** (bench: the cutter tilts the stone ±30° front-to-back and
±15° sideways under the lamp; the worn scenarios: below) turns the stone about the world X and Y axes with
the lights and viewers fixed in the world. Each pose pairs its own lights with its
own viewers; the flash metrics average over poses and viewers. Where many viewers stand
round a moving stone (ring, outdoor, pendant, brooch), each pose but the rest pose keeps a
share of them (`motion_view_share`: a stratified subset, a different one per pose, so the poses
together see every viewer): the metrics average over the poses and the viewers alike, and the
full product of both grids would cost their product (a ring at standard quality: 13 poses x 20
viewers) for the same mean. Everything
downstream works in the mesh frame: `Scenario.settings()` gives, per pose, the
lights and views rotated into it; `Scenario.main_setting()` the rest pose a render
shows, with world up as the image's up.

## Lit as rooms are

Rooms and streets are not lit by an even glow: an office has downlights or panels on a grid, a
window, and the light the ceiling and walls send back; a street has the sun and the sky. The
worn scenarios (`ring`, `pendant`, `brooch`) light the stone with `room`:

- **downlights** (55 % of the irradiance at the stone): recessed fixtures on a square grid
  1.8 m apart, 2.0 m above the stone (a 2.75 m ceiling over a hand at desk height, 0.75 m), the
  stone 0.5 and 0.3 of a spacing off the nearest fixture. Each fixture is a point (a 15 cm opening
  2 m away subtends 2°, well inside the lamella lobe's 9° outside the stone) with a Lambertian
  intensity `I0 cos θ`, so the irradiance across its ray at the stone is ∝ cos³ θ (θ from the
  vertical: inverse square over `h / cos θ`); the 18 fixtures giving at least a tenth of the
  nearest one's are kept. The spacing follows lighting-design practice for downlights, a
  spacing-to-mounting-height ratio near 1 for even illuminance on the working plane (the 500 lx
  and uniformity 0.6 EN 12464-1 asks of office tasks);
- **a window** in front (15 %): the `window` lamp, a disc of 20° radius 20° above the horizon;
- **the room's reflected light** (30 %): an even ceiling (`ceiling`, radiance ∝ cos θ, as many
  map directions as the quality gives a map: fewer miss the light a vertical face catches near the horizon). The share is the indirect part of the illuminance in a room with
  light ceiling and walls (reflectances about 0.7 / 0.5 / 0.2 for ceiling, walls and floor), of
  the order of a third in the utilisation-factor tables lighting designers use.

`outdoor` is `daylight`: the sun as a point 50° above the horizon front-right (70 %) and an
overcast sky (30 %).

These are assumptions a user can change: the constants sit at the top of
`labcut/scene/presets.py` (`DOWNLIGHT_SPACING_M`, `DOWNLIGHT_HEIGHT_M`, `DOWNLIGHT_OFFSET`,
`DOWNLIGHT_CUTOFF`, `ROOM_SHARES`), and a scenario JSON file mixes lights by share
(`{{"lighting": [{{"preset": "downlights", "share": 0.6}}, {{"preset": "ceiling", "share": 0.4}}]}}`).

## Moved as jewellery moves

A worn stone is never still, and its flash is what the wearer's movement shows; cutters check
schiller by rocking the stone under a lamp for this reason. The worn scenarios move:

| scenario | rock (about the world X axis) | sway (about the world Y axis) | why |
|---|---|---|---|
| `bench` | ±30° | ±15° | the cutter tips the stone front-to-back under the lamp, less sideways |
| `ring` | ±25° | ±25° | the hand turns with its gestures: the back of the hand tips and rolls by tens of degrees while it is looked at (the wrist alone flexes about ±70° and rolls about ±25°, the forearm turns about ±80°: the stone's tilt at the viewers is a fraction of that) |
| `pendant` | ±10° | ±10° | a pendant swings on its chain as the wearer walks (forward-back) and turns in its own plane (for a stone worn upright the world Y axis is its face's normal) |
| `brooch` | ±8° | ±8° | a brooch moves with the body: the torso sways and turns a few degrees with each step |
| `outdoor` | ±25° | ±25° | the ring's hand, outdoors |

The angles are spread evenly over each range (the quality's `rock_steps`: 9 and 4 at standard),
each pose weighted equally; `rock_deg`, `sway_deg` and `motion_view_share` in a scenario JSON
file set another motion. The still, evenly lit scenarios of earlier releases remain, under their
own names: `ring-diffuse`, `pendant-diffuse`, `brooch-diffuse`, `outdoor-still`.

How far the scene's own flash threshold and the motion move the bundled stones' flash figures, by
scenario: docs/orientation.md ("What counts as flash").

## Variants: the same wear, another room

A preset fixes numbers the world does not: how far apart the downlights hang, where the window
is, how much the hand turns, how high the onlookers' eyes are. `--variants N` (API
`recommend_orientation(..., variants=N)` or a `labcut.Variation` with its own ranges) answers the
question again under N plausible variants of the scenario and says how far the best orientation
moves across them (`rec.robustness`, the JSON's `robustness`: each variant's drawn values, its
best normal, how far it moved and how much of that variant's best the recommended cut keeps).
Each range is cut into N strata and every stratum is drawn once (a Latin hypercube), so a handful
of variants spans every range:

| free parameter | range drawn | why |
|---|---|---|
| downlight spacing (`room` lighting) | 1.4-2.4 m | office layouts space recessed downlights 1.2-2.4 m, at a spacing-to-height ratio near 1 |
| downlight height above the stone | 1.6-2.6 m | ceilings of 2.5-3.4 m over a hand or chest at 0.8-1.2 m |
| where the stone sits under the grid | anywhere in a cell | the wearer stands anywhere in the room |
| the window's azimuth / height | ±45° of the front / ±10° | the wearer faces the window only roughly |
| other lamps (the bench lamp, the sun, spots) | turned ±45° about the vertical, tilted up to 10° | the wearer faces another way; a lamp not quite overhead, the sun higher or lower |
| an environment map (the room's reflected light, a sky, a photographed room) | kept as given | turning its few sampled directions would move the answer by their discretisation error, not by anything in the world |
| rocking and swaying amplitudes | x0.6-1.4 | a calmer or livelier wearer (the ranges of "Moved as jewellery moves" are typical, not fixed) |
| the viewers | tilted up to 10° about a horizontal axis | taller or shorter onlookers, nearer or to one side |

Every variant is answered by the sample estimator with the same surface samples as the answer, so
the spread is the scenario's, not the sampling's. The verdict compares the typical (median) move
with the answer's error bar and tolerance: *inside* the error bar (the free parameters matter less
than the sampling), *beside* it (beyond the bar, within the tolerance), or *swings*: beyond the
tolerance, and then the output says so in words. The largest move is reported beside the median
(it grows with the number of variants drawn), and always the least share of a variant's best the
recommended cut keeps ("the answer swings by 5.7° typically (up to 10.7°) across 6 variants of the
scenario ..., more than its tolerance (±4.1°): it depends on how the stone will really be lit and
worn; cut as recommended it keeps at least 70% of each variant's best"). The figures for the bundled stones
under every scenario: docs/orientation.md ("Across variants of the scenario").

## Changing lights and viewers

`--lighting` and `--viewing` replace a scenario's lights or viewers (in its
world); given without `--scenario`, they describe a still, face-up stone, as in
labcut's first release. With nothing given, the scenario is `bench`.

## Lighting and viewing presets

| lighting | what it means |
|---|---|
{lighting_table}

| viewing | what it means |
|---|---|
{viewing_table}

Directions are given in the scenario's world (+Z up, the viewer's side at -Y).
Each lighting preset has total irradiance 1, so presets mix by share. Lamps of finite size are
discs sampled by equal-solid-angle directions; distributed light (`ceiling`,
`sky`, `studio`) is an environment map built in code, importance-sampled into
weighted directions for the optimiser, and the same map lights the render
(`labcut.Lights.from_envmap(path, n)` does this for any .exr/.hdr lat-long map in
Mitsuba's convention, placed with +Z up: the top row is straight up and the centre
column looks at the front, -Y). `labcut scenarios --studio-map studio.exr` writes
the procedural studio map, to light another tool the same way.

## Scenario JSON

```json
{{
  "name": "counter",
  "description": "a jeweller's counter",
  "pose": "face-up",
  "tilt_back_deg": 0,
  "lighting": [{{"preset": "ceiling", "share": 0.6}},
               {{"lamp": [0, -0.5, 1], "radius_deg": 5, "share": 0.4}},
               {{"envmap": "shop.exr", "n": 128, "share": 0.5}}],
  "viewing": {{"directions": [[0, -0.3, 1], [0.3, -0.3, 1]], "main": [0, -0.3, 1]}},
  "rock_deg": 10,
  "sway_deg": 0,
  "motion_view_share": 0.5
}}
```

`pose` is `face-up`, `face-front` or a 3 x 3 rotation matrix (rows; mesh to
world); `motion_view_share` (in (0, 1], default 1) the share of the viewers each moving pose keeps; `lighting` and `viewing` are preset names, files, direction lists or (for
lighting) a list of parts. A pose that is not a rotation, NaN, empty lights or
views, unknown keys: a one-line error (exit 2 on the command line), nothing
written.

## The scenarios on the bundled oval

Blue labradorite, `meshes/oval-16x12-low.ply`, quality `{quality}`, renders at
{res}² and {spp} spp; made by `.venv/bin/python {command}` ({machine}).

| scenario | tilt | azimuth | tolerance (90 %) | flash energy | flash area | coverage | poses | time |
|---|---|---|---|---|---|---|---|---|
{table}

Azimuth is measured in the mesh frame from +X toward +Y: 90° is the back of a
face-up stone and the top (bail end) of a pendant. Under `ring` the best tilts
form a shallow ring around face-up (viewers stand on every side, so tilting
towards some of them costs the others little): expect the azimuth to wander and
read the tolerance as the figure that matters.

{sections}
"""


if __name__ == "__main__":
    main()
