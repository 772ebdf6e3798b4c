"""The explorer's session and server (labcut.explorer), without a browser: the controls' checks,
what each control changes, that every number is the library's, the score map's picture and its
projection, the exports, and the server's guards. The page itself: tests/test_explore_browser.py."""

from __future__ import annotations

import io
import json
import math
import urllib.error
import urllib.request

import numpy as np
import pytest

import labcut
from labcut.explorer import ControlError, ExploreSession, ExploreState
from labcut.explorer.hemisphere import DiscRaster, disc_normals, pixel_of
from labcut.explorer.state import changed
from labcut.orientation.uncertainty import COVER, sampling_error
from labcut.scene.directions import direction, tilt_azimuth
from labcut.scene.sets import Lights

OVAL = "meshes/oval-16x12-low.ply"


@pytest.fixture(scope="module")
def session():
    return ExploreSession(OVAL, scenario="bench", quality="draft")


# ---------------------------------------------------------------------- the controls
@pytest.mark.parametrize("changes, control, words", [
    ({"lamp_elevation": 120}, "lamp_elevation", "outside 0-90"),
    ({"lamp_elevation": -0.5}, "lamp_elevation", "outside 0-90"),
    ({"lamp_size": 46}, "lamp_size", "outside 0-45"),
    ({"normal_tilt": float("nan")}, "normal_tilt", "finite"),
    ({"normal_tilt": "steep"}, "normal_tilt", "expected a number"),
    ({"normal_tilt": True}, "normal_tilt", "expected a number"),
    ({"peak_nm": 399}, "peak_nm", "outside 400-700"),
    ({"scenario": "moon"}, "scenario", "unknown choice"),
    ({"material": "opal"}, "material", "unknown choice"),
    ({"quality": "best"}, "quality", "unknown choice"),
    ({"outline": "heart"}, "outline", "unknown choice"),
    ({"colour": "red"}, "colour", "no such control"),
])
def test_a_value_a_control_does_not_take_is_refused_naming_the_control(changes, control, words):
    with pytest.raises(ControlError) as info:
        changed(ExploreState(), changes)
    assert info.value.control == control and words in str(info.value)
    assert isinstance(info.value, labcut.ParameterError)


def test_changes_apply_all_or_none_and_azimuths_wrap():
    s = ExploreState()
    with pytest.raises(ControlError):
        changed(s, {"normal_tilt": 10, "lamp_elevation": 91})
    assert changed(s, {"normal_azimuth": -90, "lamp_azimuth": 725}).normal_azimuth == 270
    assert changed(s, {"lamp_azimuth": 725}).lamp_azimuth == 5
    # a lamp control turns the lights to the lamp; other controls leave them
    assert changed(s, {"lamp_size": 3}).lights == "lamp"
    assert changed(s, {"normal_tilt": 3}).lights == "scenario"
    assert changed(s, {"lamp_size": 3, "lights": "scenario"}).lights == "scenario"


def test_the_lamp_is_the_lamp_the_controls_describe(session):
    session.reset()
    assert session.lights() is None  # the scenario's own lights
    session.set({"lamp_elevation": 35, "lamp_azimuth": 270, "lamp_size": 0})
    lamp = session.lights()
    assert len(lamp) == 1
    assert np.allclose(lamp.directions[0], direction(55.0, 270.0))  # 35° above the horizon, in front (-Y)
    assert lamp.directions[0][1] < 0 and math.degrees(math.asin(lamp.directions[0][2])) == pytest.approx(35.0)
    study = session.study()
    assert np.allclose(study.scenario.lights.directions, lamp.directions)
    assert study.scenario.views.name == labcut.Scenario.preset("bench", "draft").views.name  # the viewers kept
    session.set({"lamp_size": 8, "lamp_elevation": 90})
    overhead = Lights.preset("overhead", "draft")
    assert np.allclose(session.lights().directions, overhead.directions)
    assert np.allclose(session.lights().weights, overhead.weights)
    session.reset()


def test_the_overhead_lamp_recommends_as_the_bench_does(session):
    """The lamp controls set back overhead (8° radius) are the bench scenario's lamp: "recommend
    here" answers as recommend_orientation under bench does."""
    session.reset()
    session.set({"lamp_elevation": 60})
    session.set({"lamp_elevation": 90, "lamp_azimuth": 270, "lamp_size": 8})
    assert session.state.lights == "lamp"
    rec = session.recommend()
    ref = labcut.recommend_orientation(labcut.load_mesh(OVAL), scenario="bench", quality="draft")
    assert rec.tilt_deg == pytest.approx(ref.tilt_deg, abs=1e-6)
    assert (session.state.normal_tilt, session.state.normal_azimuth) == pytest.approx((rec.tilt_deg, rec.azimuth_deg % 360))
    assert session.view()["recommendation"]["tilt_deg"] == pytest.approx(ref.tilt_deg, abs=1e-6)
    session.reset()


def test_the_view_runs_numpy_blas_on_one_thread(session, monkeypatch):
    """The view's bootstrap products run with numpy's BLAS on one thread (beside Dr.Jit's pool;
    under load on two cores OpenBLAS's own threads made them 10x slower), and the caller's thread
    count comes back after."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from labcut.explorer import session as module

    def blas_threads():
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    seen = []

    def spy(*args, **kwargs):
        seen.append(blas_threads())
        return sampling_error(*args, **kwargs)

    monkeypatch.setattr(module, "sampling_error", spy)
    with threadpool_limits(limits=2, user_api="blas"):
        if not blas_threads():
            pytest.skip("numpy has no BLAS that threadpoolctl controls")
        session.set({"normal_tilt": session.state.normal_tilt + 1.0})
        session.view()
        assert seen and set(seen[0]) == {1}
        assert set(blas_threads()) == {2}
    session.reset()


def test_each_number_is_the_librarys(session):
    session.reset()
    session.set({"lamp_elevation": 50, "lamp_azimuth": 300, "lamp_size": 4, "normal_tilt": 12, "normal_azimuth": 80,
                 "material": "peak", "peak_nm": 560})
    view = session.view()
    lab = labcut.Labradorite.from_peak_wavelength(560)
    lamp = Lights.lamp(direction(40.0, 300.0), 4.0, 1.0, labcut.Quality.coerce("draft").lamp_samples)
    ref = labcut.evaluate_orientation(labcut.load_mesh(OVAL), tilt=12, azimuth=80, material=lab, scenario="bench",
                                      lighting=lamp, quality="draft")
    for key in ("flash_energy", "flash_area", "flash_intensity", "coverage"):
        assert view["metrics"][key] == pytest.approx(getattr(ref, key), rel=1e-9, abs=1e-12), key
    normals, scores = session.study().score_map()
    best = tilt_azimuth(normals[int(np.argmax(scores))])
    assert (view["score_map"]["best_tilt"], view["score_map"]["best_azimuth"]) == pytest.approx(best)
    assert view["score_map"]["max"] == pytest.approx(float(scores.max()))
    assert "tilt the lamella plane 12°" in view["words"]["orientation"]
    assert "raised 12.0°" in view["words"]["workshop"]
    session.reset()


def test_a_normal_change_makes_nothing_new_and_a_lamp_seen_before_is_kept(session):
    session.reset()
    session.view()
    builds = dict(session.study().builds)
    session.set({"normal_tilt": 20})
    session.view()
    assert session.study().builds == builds
    first = session.study()
    session.set({"lamp_elevation": 70})
    session.view()
    assert session.study() is not first
    session.set({"lamp_elevation": 90, "lamp_size": 8, "lights": "scenario"})
    assert session.study() is first  # back to the scenario's own lights: the Study kept
    session.reset()


def test_a_carvings_live_view_renders_no_pilots_and_answers_from_the_surface_samples(monkeypatch):
    """A lamp move on a carving must not wait for pilot renders (light between its parts, about
    0.8 s a new lamp) nor for the volume estimator's problem (1-1.5 s): the live Study's plan leaves
    the pilots unrendered and its map and metrics come from the surface samples. "recommend here"
    plans as ``labcut recommend-orientation`` does, pilots included, and answers through the volume."""
    import labcut.planner as planner

    asked = []

    def pilots(mesh, material, scene, timing=None, max_seconds=None):  # as if never rendered for this lamp
        asked.append(max_seconds)
        if max_seconds == 0.0:
            timing["pilot_seconds_skipped"] = 0.8
            return None
        return 0.012

    monkeypatch.setattr(planner, "measured_interreflection", pilots)
    live = ExploreSession("meshes/carving-biplane.ply", scenario="bench", quality="draft")
    live.set({"lamp_elevation": 63.0})
    view = live.view()
    study = live.study()
    # the answer waited for no plan (no pilots asked, nor the material's depth and polarisation)
    assert asked == [] and study.planned() is None and study.builds == {"plan": 0, "problem": 1, "recommendation": 0}
    assert view["estimator"] == "samples (live); recommend: planned after the picture"
    assert live.planned_estimator() == {"state": live.state.to_dict(), "estimator":
                                        "samples (live); recommend: volume (light between the parts measured when asked)"}
    assert asked == [0.0] and study.plan().estimator == "volume"
    assert study.surface_scorer is not study.scorer and "volume" not in study.surface_scorer.problem.info
    ref = labcut.evaluate_orientation(live.stone, live.normal(), scenario="bench", lighting=live.lights(), quality="draft",
                                      estimator="samples")
    assert view["metrics"]["flash_energy"] == pytest.approx(ref.flash_energy, rel=1e-9)
    assert live.view()["estimator"] == "samples (live); recommend: volume (light between the parts measured when asked)"
    assert live.recommendation() is None
    rec = live.recommend()
    assert asked[0] == 0.0 and len(asked) > 1 and set(asked[1:]) == {None} and rec.estimator == "volume"
    assert live.view()["estimator"] == "samples (live); recommend: volume"
    assert live.view()["recommendation"]["tilt_deg"] == pytest.approx(rec.tilt_deg)


def test_a_new_material_or_lamp_answers_without_the_recommendations_plan(session):
    """The map and metrics of a new material or lamp come from the surface samples under the
    planner's occlusion rule alone (``planner.plan_surface_samples``): the plan's decisions of the
    material (the stack's depth law, its polarisation table, tenths of a second for a new one) are
    made after the picture (``planned_estimator``), and the plan then asks for the very problem the
    view built, which the recommendation reuses."""
    session.reset()
    for change in ({"material": "peak", "peak_nm": 497.25}, {"lamp_elevation": 71.5}):
        session.set(change)
        view = session.view()
        study = session.study()
        assert study.planned() is None and view["estimator"].endswith("planned after the picture")
        problems = study.builds["problem"]
        assert session.planned_estimator()["estimator"] == "samples (live); recommend: samples"
        assert study.planned() is not None and study.scorer is study.surface_scorer
        assert study.builds["problem"] == problems  # the oval's plan asks for the view's problem: not built again
        assert session.view()["estimator"] == "samples (live); recommend: samples"
    session.reset()


def test_the_material_control(session):
    session.reset()
    assert session.material() is session.given_material
    session.set({"material": "gold"})
    assert session.material().name == "gold"
    session.set({"material": "peak", "peak_nm": 610})
    assert session.material().peak_wavelength() == pytest.approx(610.0, abs=0.05)
    session.reset()


def test_the_outline_and_dome_build_a_cabochon_the_size_of_the_stone(session):
    session.reset()
    session.set({"outline": "oval", "dome": 4.0})
    stone = session.current_stone()
    assert stone.kind == "cabochon"
    assert np.ptp(stone.mesh.vertices, axis=0) == pytest.approx([16.0, 12.0, 4.0], abs=0.02)
    assert session.view()["stone"]["size_mm"] == pytest.approx([16.0, 12.0, 4.0], abs=0.02)
    with pytest.raises(ControlError) as info:
        session.set({"dome": 30.0})  # higher than an elliptic profile on a 12 mm stone allows
    assert info.value.control == "dome" and session.state.dome == 4.0
    session.set({"outline": "round"})
    assert np.ptp(session.current_stone().mesh.vertices, axis=0)[:2] == pytest.approx([12.0, 12.0], abs=0.02)
    session.reset()
    assert session.current_stone() is session.stone


# ---------------------------------------------------------------------- error bars
def test_the_sampling_error_is_the_spread_over_surface_samples():
    """The bootstrap's 2σ at a normal against the spread of the metric over independent surface
    samplings (eight seeds): the same within the noise of eight draws."""
    mesh = labcut.load_mesh(OVAL)
    m = direction(4.0, 270.0)
    energies = [labcut.Study(mesh, scenario="bench", quality="draft", seed=s).scorer.metrics(m).flash_energy
                for s in range(8)]
    spread = float(np.std(energies, ddof=1))
    err = sampling_error(labcut.Study(mesh, scenario="bench", quality="draft").scorer.problem, m)["flash_energy"]
    assert 0.55 * COVER * spread < err < 1.8 * COVER * spread


def test_the_sampling_error_bars_each_metric(session):
    session.reset()
    view = session.view()
    for key in ("flash_energy", "flash_area", "flash_intensity"):
        assert 0 < view["errors"][key] < 0.5 * view["metrics"][key], key
    with pytest.raises(labcut.ParameterError):
        sampling_error(session.study().scorer.problem, [0, 0, 0])


# ---------------------------------------------------------------------- the score map's picture
def test_the_projection_puts_each_normal_where_the_page_marks_it():
    normals, inside = disc_normals(200)
    for tilt, az in ((0.0, 0.0), (30.0, 90.0), (60.0, 270.0), (89.0, 135.0)):
        col, row = pixel_of(tilt, az, 200)
        k = int(row) * 200 + int(col)
        assert inside[k]
        t, a = tilt_azimuth(normals[k])
        assert t == pytest.approx(tilt, abs=0.7)
        if tilt > 5:
            assert (a - az + 180) % 360 - 180 == pytest.approx(0, abs=1.5)
    # the front of the stone (-Y) at the bottom of the picture, +X on the right
    assert pixel_of(45, 270, 200)[1] > 100 and pixel_of(45, 0, 200)[0] > 100


def test_each_pixel_shows_its_nearest_normal_and_the_colour_scale_tops_at_the_best():
    from PIL import Image

    grid = labcut.Study(labcut.load_mesh(OVAL), quality="draft").score_map()[0]
    raster = DiscRaster(grid, 64)
    normals, inside = disc_normals(64)
    k = np.flatnonzero(inside)[::97]
    expect = np.argmax(np.abs(normals[k] @ grid.T), axis=1)
    assert np.array_equal(raster.index[k], expect)
    scores = np.zeros(len(grid))
    scores[5] = 2.0
    scores[6] = 1.0
    rgba = raster.rgba(scores)
    img = Image.open(io.BytesIO(raster.png(scores)))
    assert img.size == (64, 64) and np.array_equal(np.asarray(img), rgba)
    flat = rgba.reshape(-1, 4)
    assert (flat[~inside, 3] == 0).all() and (flat[inside, 3] == 255).all()
    from matplotlib import colormaps

    top = (np.array(colormaps["viridis"](1.0)) * 255).astype(np.uint8)
    half = (np.array(colormaps["viridis"](128 / 255)) * 255).astype(np.uint8)
    assert (flat[raster.index == 5][:, :3] == top[:3]).all()  # the best: the top of the scale
    assert (flat[raster.index == 6][:, :3] == half[:3]).all()  # half the best: the middle
    with pytest.raises(ValueError):
        raster.rgba(np.zeros(3))


# ---------------------------------------------------------------------- pictures and exports
def test_the_preview_and_the_refinement(session):
    from PIL import Image

    session.reset()
    png = session.preview()
    img = Image.open(io.BytesIO(png))
    assert img.size == (128, 128)
    meta = json.loads(img.text["labcut:explore"])
    assert meta["stage"] == "preview" and meta["state"] == session.state.to_dict()
    assert meta["exposure_mode"] == "reference"  # labcut render's exposure rule
    steps = []
    for k, png in enumerate(session.refine()):
        steps.append(png)
        if k == 1:
            break
    assert Image.open(io.BytesIO(steps[-1])).size == (384, 384)
    # the passes are averaged: the refined picture is as bright as the preview (one exposure)
    preview = np.asarray(Image.open(io.BytesIO(session.preview())).convert("RGB"), dtype=np.float64).mean()
    refined = np.asarray(Image.open(io.BytesIO(steps[-1])).convert("RGB"), dtype=np.float64).mean()
    assert refined == pytest.approx(preview, rel=0.15)
    assert json.loads(Image.open(io.BytesIO(steps[-1])).text["labcut:explore"])["stage"] == "refined, 8 spp"
    from labcut.explorer.session import Superseded

    with pytest.raises(Superseded):
        for _ in session.refine(stop=lambda: True):
            pass


def test_the_state_export_reads_back(session):
    session.reset()
    session.set({"normal_tilt": 5, "normal_azimuth": 270, "material": "green"})
    data = json.loads(json.dumps(session.export_state(), allow_nan=False))
    assert data["state"]["normal_tilt"] == 5 and data["material"]["name"] == "green"
    assert data["stone"]["source"].endswith("oval-16x12-low.ply")
    assert data["normal"] == pytest.approx(list(direction(5, 270)))
    assert data["metrics"]["flash_energy"] == pytest.approx(session.view()["metrics"]["flash_energy"])
    session.reset()


# ---------------------------------------------------------------------- the server
@pytest.fixture(scope="module")
def explorer():
    ex = labcut.explore(OVAL, quality="draft")
    yield ex
    ex.stop()
    assert not ex.worker.is_alive() and not ex._thread.is_alive()  # nothing renders after stop()


@pytest.fixture(autouse=True)
def _explorer_idle_after(request):
    """After each test that used the module's explorer, wait for its worker to draw the pictures of
    the last state: the explorer lives on between tests, and with xdist the next test on this worker
    may be another module's, whose Mitsuba variant a picture drawn meanwhile would switch under it
    (tests/test_backend.py's variant test read rgb so, with this explorer's threads alive)."""
    yield
    if "explorer" in request.fixturenames:
        assert request.getfixturevalue("explorer").worker.wait_idle(120)


def _get(url, host=None):
    request = urllib.request.Request(url, headers={"Host": host} if host else {})
    try:
        with urllib.request.urlopen(request, timeout=120) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def test_the_notebook_object_is_the_page_in_a_frame(explorer):
    assert explorer.url.startswith("http://127.0.0.1:") and explorer.port > 0
    assert f'<iframe src="{explorer.url}"' in explorer._repr_html_()
    status, headers, body = _get(explorer.url)
    assert status == 200 and b'data-testid="score-map"' in body
    policy = headers["Content-Security-Policy"]
    assert "default-src 'none'" in policy and "script-src 'self'" in policy and "unsafe" not in policy
    assert f"connect-src 'self' ws://127.0.0.1:{explorer.port}" in policy
    explorer.set(normal_tilt=7)
    assert explorer.session.state.normal_tilt == 7
    with pytest.raises(ControlError):
        explorer.set(normal_tilt=95)


def test_the_server_reads_no_file_a_request_names_and_refuses_other_hosts(explorer):
    assert _get(explorer.url + "static/../../pyproject.toml")[0] == 404
    assert _get(explorer.url + "static/app.py")[0] == 404
    assert _get(explorer.url + "export/secret.txt")[0] == 404
    assert _get(explorer.url, host="attacker.example:80")[0] == 403  # DNS rebinding
    assert _get(explorer.url, host=f"localhost:{explorer.port}")[0] == 200


def test_the_exports(explorer):
    status, headers, body = _get(explorer.url + "export/state.json")
    assert status == 200 and headers["Content-Type"] == "application/json"
    assert json.loads(body)["state"] == explorer.session.state.to_dict()
    status, headers, body = _get(explorer.url + "export/view.png")
    assert status == 200 and body[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_socket_answers_a_bad_message_with_an_error_not_a_crash(explorer):
    import asyncio

    import tornado.websocket

    async def talk():
        ws = await tornado.websocket.websocket_connect(explorer.url.replace("http", "ws") + "ws")
        spec = json.loads(await ws.read_message())
        assert spec["type"] == "spec" and spec["spec"]["ranges"]["lamp_elevation"] == [0.0, 90.0]
        replies = []
        for message in ("not json", json.dumps([1]), json.dumps({"op": "launch"}),
                        json.dumps({"op": "set", "id": 9, "changes": {"lamp_elevation": 999}}),
                        json.dumps({"op": "set", "id": 10, "changes": {"normal_tilt": 3}})):
            ws.write_message(message)
        while len(replies) < 5:
            reply = json.loads(await asyncio.wait_for(ws.read_message(), 120))
            if reply["type"] in ("error", "view"):
                replies.append(reply)
        ws.close()
        return replies

    replies = asyncio.run(talk())
    assert [r["type"] for r in replies[:3]] == ["error"] * 3 and "bad message" in replies[0]["message"]
    assert replies[3]["control"] == "lamp_elevation" and replies[3]["ids"] == [9]
    assert replies[4]["type"] == "view" and replies[4]["view"]["state"]["normal_tilt"] == 3


def test_the_socket_sends_the_plan_after_the_first_picture(explorer):
    """A new lamp: the view (its estimator pending), the preview, then the plan's estimator for that
    view's generation, then the refined pictures (``ExploreSession.planned_estimator``)."""
    import asyncio

    import tornado.websocket

    async def talk():
        ws = await tornado.websocket.websocket_connect(explorer.url.replace("http", "ws") + "ws")
        await ws.read_message()  # the controls' spec
        ws.write_message(json.dumps({"op": "set", "id": 21, "changes": {"lamp_elevation": 57.25}}))
        seen, generation = [], None
        while True:
            m = json.loads(await asyncio.wait_for(ws.read_message(), 120))
            if m["type"] == "view" and 21 in m["ids"]:
                generation = m["generation"]
                seen.append(("view", m["view"]["estimator"]))
            elif generation is not None and m.get("generation") == generation and m["type"] in ("render", "plan", "render-done"):
                seen.append((m["type"], m.get("stage") or m.get("estimator")))
                if m["type"] == "render-done":
                    break
        ws.close()
        return seen

    seen = asyncio.run(talk())
    assert seen[0] == ("view", "samples (live); recommend: planned after the picture")
    assert seen[1] == ("render", "preview")
    assert seen[2] == ("plan", "samples (live); recommend: samples")
    assert seen[-1][0] == "render-done" and all(kind == "render" for kind, _ in seen[3:-1])


def test_the_socket_refuses_another_origin(explorer):
    import asyncio

    import tornado.httpclient
    import tornado.websocket

    async def talk():
        request = tornado.httpclient.HTTPRequest(explorer.url.replace("http", "ws") + "ws",
                                                 headers={"Origin": "http://attacker.example"})
        await tornado.websocket.websocket_connect(request)

    with pytest.raises(tornado.httpclient.HTTPClientError) as info:
        asyncio.run(talk())
    assert info.value.code == 403


def test_a_bad_port_or_host_is_a_parameter_error():
    session = ExploreSession(OVAL, quality="draft")
    with pytest.raises(labcut.ParameterError, match="port"):
        labcut.Explorer(session, port=70000)
    with pytest.raises(labcut.ParameterError, match="cannot listen"):
        labcut.Explorer(session, host="203.0.113.7").start()  # an address not of this machine


# ---------------------------------------------------------------------- the command line
def test_the_command_refuses_bad_input_in_one_line(capsys):
    """In process (tests/cli_run.py): each bad input one line on stderr and exit 2, before any
    server starts."""
    import socket

    from cli_run import in_process

    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen()
    busy = str(taken.getsockname()[1])
    try:
        for args, words in ((["missing.ply"], "missing.ply"), ([OVAL, "--port", "70000"], "--port"),
                            ([OVAL, "--port", busy, "--no-browser"], f"cannot listen on 127.0.0.1:{busy}"),
                            ([OVAL, "--scenario", "moon", "--no-browser"], "scenario"),
                            ([OVAL, "--peak", "-3", "--no-browser"], "peak")):
            done = in_process(["explore", *args], capsys)
            err = done.stderr
            assert done.returncode == 2, (args, err)
            assert words in err and "Traceback" not in err and len(err.strip().splitlines()) <= 3, err
    finally:
        taken.close()


def test_a_script_that_ends_with_the_explorer_running_exits_cleanly():
    """A notebook or script that starts the explorer and ends without stop(): the explorer stops itself
    before Dr.Jit shuts down under the worker's render (it aborted the process: "terminate called
    without an active exception", signal 6, in 1 of 2 runs before)."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    code = ("import labcut, time\nex = labcut.explore(labcut.load_mesh('meshes/oval-16x12-low.ply'), material='blue')\n"
            "time.sleep(0.5)\n")
    for _ in range(3):
        proc = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr[-800:]
        assert "terminate called" not in proc.stderr and "render failed" not in proc.stderr and "Traceback" not in proc.stderr
    # the exit hook is the explorer's own: registered when it starts, undone by stop()
    from types import SimpleNamespace

    from labcut.explorer import server

    hooks: list = []
    fake = SimpleNamespace(register=hooks.append, unregister=lambda f: hooks.remove(f) if f in hooks else None)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(server, "atexit", fake)
        ex = labcut.explore(labcut.load_mesh(root / "meshes" / "oval-16x12-low.ply"), material="blue")
        assert hooks == [ex._stop_at_exit]
        ex.stop()
        assert hooks == []
        # stop() returns when the worker is done: no picture under way switches Mitsuba's variant later
        assert not ex.worker.is_alive()
