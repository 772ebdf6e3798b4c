"""The explorer served: a local web page over one :class:`~labcut.explorer.session.ExploreSession`.

Tornado (the web server Dask's dashboard and Bokeh already run on) serves three packaged files
(``static/``: the page, its script and its style; no file named by a request is ever read) and a
WebSocket. The page sends control changes; one worker thread answers them in order, coalescing
changes that queued while it was busy, and sends back the view (metrics, score map, words) as
soon as it has it; then it renders: a quick preview, then the refined picture pass by pass, each
sent when done. A new change stops the refinement between two passes, so a change is never kept
waiting behind a picture of a state already left. Exports (the state's JSON, the picture's PNG,
the HTML report of the current cut) are plain downloads.

Safe by default: it listens on 127.0.0.1 unless told otherwise; on a loopback address a request
whose ``Host`` is not that address is refused (DNS rebinding); WebSocket messages from another
origin are refused; every response carries a content policy that lets the page load nothing but
its own files and images embedded as ``data:`` URLs, and connect nowhere but back to this
server. A control value the session refuses comes back as an error naming the control, shown
beside it; nothing a page sends reaches the terminal as a traceback.
"""

from __future__ import annotations

import asyncio
import atexit
import base64
import contextlib
import ipaddress
import json
import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

from ..errors import LabcutError, ParameterError
from .session import ExploreSession, Superseded
from .state import CHOICES, LAMP_CONTROLS, RANGES, ControlError

log = logging.getLogger("labcut.explore")

#: the packaged files the page is made of: URL path -> (file, content type)
STATIC = {
    "/": ("index.html", "text/html; charset=utf-8"),
    "/static/app.js": ("app.js", "text/javascript; charset=utf-8"),
    "/static/app.css": ("app.css", "text/css; charset=utf-8"),
}
#: how long an export may take (seconds): a report runs a recommendation and renders
EXPORT_SECONDS = 600.0
#: how long a process that ends with the explorer still running waits for the worker's render to stop
EXIT_WAIT_SECONDS = 10.0
#: controls whose change takes more than a moment (a new stone, scenario or quality): the page shows
#: that the answer is coming
SLOW_CONTROLS = frozenset({"quality", "outline", "dome", "scenario"})


def _static(name: str) -> bytes:
    return resources.files("labcut.explorer").joinpath("static", name).read_bytes()


def _loopback(host: str) -> bool:
    if host in ("localhost", ""):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass
class _Job:
    op: str
    payload: Any = None
    reply: Callable[[dict[str, Any]], None] | None = None
    done: Any = None  # a concurrent.futures.Future for exports
    ids: list[Any] = field(default_factory=list)


class Worker(threading.Thread):
    """The one thread that answers the page (module docstring): control changes, "recommend",
    "reset" and exports from a queue, and between them the pictures of the current state."""

    def __init__(self, session: ExploreSession, publish: Callable[[dict[str, Any]], None]) -> None:
        super().__init__(name="labcut-explore-worker", daemon=True)
        self.session = session
        self.publish = publish
        self.jobs: queue.Queue[_Job | None] = queue.Queue()
        self._render_state: Any = None  # the state whose pictures are done or under way
        self.generation = 0
        self.stopped = threading.Event()
        #: set while the worker has nothing to do (no job queued, the pictures of the current state
        #: done): :meth:`wait_idle`
        self.idle = threading.Event()
        # held while a job is queued and while the loop decides it is idle: a job queued between that
        # decision and the flag could otherwise leave "idle" set with work waiting
        self._idle_lock = threading.Lock()

    def submit(self, job: _Job) -> None:
        with self._idle_lock:
            self.jobs.put(job)
            self.idle.clear()

    def wait_idle(self, timeout: float) -> bool:
        """Wait until the worker has answered every job and drawn the pictures of the current state
        (a caller about to use Mitsuba itself: the pictures switch its variant, the process's);
        False if ``timeout`` seconds passed first."""
        return self.idle.wait(timeout)

    #: how long :meth:`stop` waits for a picture under way (seconds)
    STOP_WAIT_SECONDS = 30.0

    def stop(self) -> None:
        """Stop answering, and wait for a picture under way to finish: once this returns the worker
        renders nothing more (a render switches Mitsuba's variant, which is the process's: one still
        running after the explorer stopped could switch it under the caller's next render)."""
        self.stopped.set()
        self.jobs.put(None)
        if self.is_alive() and threading.current_thread() is not self:
            self.join(timeout=self.STOP_WAIT_SECONDS)

    # ------------------------------------------------------------------ the loop
    def run(self) -> None:
        while not self.stopped.is_set():
            with self._idle_lock:
                if self._render_state == self.session.state and self.jobs.empty():
                    self.idle.set()
            try:
                job = self.jobs.get(timeout=0.05 if self._render_state != self.session.state else 1.0)
            except queue.Empty:
                job = None
            if job is None:
                if self.stopped.is_set():
                    return
                if self._render_state != self.session.state:
                    self._pictures()
                continue
            jobs = [job]
            while True:  # coalesce what queued meanwhile
                try:
                    more = self.jobs.get_nowait()
                except queue.Empty:
                    break
                if more is None:
                    return
                jobs.append(more)
            self._answer(jobs)

    def _answer(self, jobs: list[_Job]) -> None:
        changed_ids: list[Any] = []
        if any(j.op == "reset" or (j.op == "set" and SLOW_CONTROLS & set(j.payload or {})) for j in jobs):
            self.publish({"type": "busy", "what": "answering"})  # seconds, not milliseconds: the page says so
        for job in jobs:
            try:
                if job.op == "set":
                    self.session.set(job.payload)
                    changed_ids += job.ids
                    continue
                if job.op == "reset":
                    self.session.reset()
                    changed_ids += job.ids
                    continue
                if job.op == "hello":
                    changed_ids += job.ids
                    continue
                if job.op == "recommend":
                    self.publish({"type": "busy", "what": "recommending"})
                    t = time.perf_counter()
                    rec = self.session.recommend()
                    log.info("recommended in %.2f s: tilt %.2f, azimuth %.1f", time.perf_counter() - t, rec.tilt_deg,
                             rec.azimuth_deg)
                    changed_ids += job.ids
                    continue
                if job.op == "export":
                    self._export(job)
                    continue
                raise ParameterError(f"unknown request {job.op!r}")
            except ControlError as exc:
                self.publish({"type": "error", "ids": job.ids, "control": exc.control, "message": str(exc)})
            except LabcutError as exc:
                self.publish({"type": "error", "ids": job.ids, "control": None, "message": str(exc)})
            except Exception as exc:  # a bug: reported on the page and in the log, the server goes on
                log.exception("explore: %s failed", job.op)
                self.publish({"type": "error", "ids": job.ids, "control": None,
                              "message": f"internal error ({type(exc).__name__}): {exc}"})
        if changed_ids:
            self._view(changed_ids)

    def _view(self, ids: list[Any]) -> None:
        try:
            view = self.session.view()
        except LabcutError as exc:
            self.publish({"type": "error", "ids": ids, "control": None, "message": str(exc)})
            return
        self.generation += 1
        self.publish({"type": "view", "ids": ids, "generation": self.generation, "view": view})

    def _export(self, job: _Job) -> None:
        kind = job.payload
        try:
            if kind == "state.json":
                body = (json.dumps(self.session.export_state(), indent=2, allow_nan=False) + "\n").encode()
            elif kind == "view.png":
                body = self.session.view_png()
            elif kind == "report.html":
                self.publish({"type": "busy", "what": "building the report"})
                body = self.session.report_html()
                self.publish({"type": "busy", "what": None})
            else:
                raise ParameterError(f"unknown export {kind!r}")
        except BaseException as exc:
            job.done.set_exception(exc)
            raise
        job.done.set_result(body)

    # ------------------------------------------------------------------ pictures
    def _pictures(self) -> None:
        state = self.session.state
        self._render_state = state
        generation = self.generation
        try:
            t = time.perf_counter()
            png = self.session.preview()
            self._send_picture(png, generation, "preview", time.perf_counter() - t, final=False)
            if not self.jobs.empty():
                raise Superseded
            # the recommendation's estimator: the live Study's plan, which the answer did not wait for
            self.publish({"type": "plan", "generation": generation, **self.session.planned_estimator()})
            t = time.perf_counter()
            for k, png in enumerate(self.session.refine(stop=lambda: not self.jobs.empty() or self.stopped.is_set())):
                self._send_picture(png, generation, "refined", time.perf_counter() - t, final=False, step=k + 1)
                if not self.jobs.empty():
                    raise Superseded
            self.publish({"type": "render-done", "generation": generation})
        except Superseded:
            self._render_state = None  # the next state's pictures start after the queued job
        except LabcutError as exc:
            self.publish({"type": "error", "ids": [], "control": None, "message": f"render: {exc}"})
        except Exception as exc:
            log.exception("explore: render failed")
            self.publish({"type": "error", "ids": [], "control": None,
                          "message": f"render: internal error ({type(exc).__name__}): {exc}"})

    def _send_picture(self, png: bytes, generation: int, stage: str, seconds: float, *, final: bool, step: int = 0) -> None:
        self.publish({"type": "render", "generation": generation, "stage": stage, "step": step,
                      "ms": round(seconds * 1000.0, 1),
                      "png": "data:image/png;base64," + base64.b64encode(png).decode("ascii")})


def _plain(value: Any) -> Any:
    """``value`` as strict JSON takes it: numpy numbers as Python's, a number that is not finite
    as None (the page shows a dash), containers walked."""
    import math

    import numpy as np

    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def spec() -> dict[str, Any]:
    """The controls the page builds: choices and ranges (the session checks them again)."""
    return {"choices": {k: list(v) for k, v in CHOICES.items()}, "ranges": {k: list(v) for k, v in RANGES.items()},
            "lamp_controls": list(LAMP_CONTROLS)}


def make_app(worker: Worker, host: str, port_of: Callable[[], int]) -> Any:
    """The tornado application of one worker (module docstring)."""
    import tornado.web
    import tornado.websocket

    sockets: set[Any] = set()
    guard_host = _loopback(host)

    def allowed_host(request: Any) -> bool:
        if not guard_host:
            return True
        name = request.host_name.strip("[]").lower()
        return _loopback(name)

    class Base(tornado.web.RequestHandler):
        def set_default_headers(self) -> None:
            netloc = self.request.host or f"127.0.0.1:{port_of()}"
            self.set_header("Content-Security-Policy",
                            "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
                            f"connect-src 'self' ws://{netloc}; base-uri 'none'; form-action 'none'")
            self.set_header("X-Content-Type-Options", "nosniff")
            self.set_header("Referrer-Policy", "no-referrer")
            self.set_header("Cache-Control", "no-store")

        def prepare(self) -> None:
            if not allowed_host(self.request):
                raise tornado.web.HTTPError(403, reason="unknown host")

        def write_error(self, status_code: int, **kwargs: Any) -> None:  # no traceback in a page
            self.set_header("Content-Type", "text/plain; charset=utf-8")
            message = self._reason
            if "exc_info" in kwargs and isinstance(kwargs["exc_info"][1], LabcutError):
                message = str(kwargs["exc_info"][1])
            self.finish(f"{status_code}: {message}\n")

    class Static(Base):
        def get(self) -> None:
            name, kind = STATIC[self.request.path]
            self.set_header("Content-Type", kind)
            self.finish(_static(name))

    class Export(Base):
        async def get(self, kind: str) -> None:
            import concurrent.futures

            done: concurrent.futures.Future[bytes] = concurrent.futures.Future()
            worker.submit(_Job("export", kind, done=done))
            try:
                body = await asyncio.wait_for(asyncio.wrap_future(done), EXPORT_SECONDS)
            except LabcutError as exc:
                raise tornado.web.HTTPError(400, reason=str(exc).splitlines()[0][:200]) from None
            except Exception:
                raise tornado.web.HTTPError(500, reason="export failed") from None
            types = {"state.json": "application/json", "view.png": "image/png", "report.html": "text/html; charset=utf-8"}
            self.set_header("Content-Type", types[kind])
            self.set_header("Content-Disposition", f'attachment; filename="labcut-explore-{kind}"')
            self.finish(body)

    class Socket(tornado.websocket.WebSocketHandler):
        def prepare(self) -> None:
            if not allowed_host(self.request):
                raise tornado.web.HTTPError(403, reason="unknown host")

        def open(self) -> None:
            sockets.add(self)
            self.write_message(json.dumps({"type": "spec", "spec": spec()}))

        def on_close(self) -> None:
            sockets.discard(self)

        def on_message(self, message: Any) -> None:
            try:
                data = json.loads(message)
                if not isinstance(data, dict):
                    raise ValueError("not an object")
                op = data.get("op")
                ident = data.get("id")
                if op not in ("hello", "set", "recommend", "reset"):
                    raise ValueError(f"unknown op {op!r}")
                changes = data.get("changes", {})
                if op == "set" and not isinstance(changes, dict):
                    raise ValueError("changes must be an object")
            except (ValueError, TypeError) as exc:
                self.write_message(json.dumps({"type": "error", "ids": [], "control": None, "message": f"bad message: {exc}"}))
                return
            worker.submit(_Job(op, changes if op == "set" else None, ids=[ident]))

    def broadcast(message: dict[str, Any]) -> None:
        text = json.dumps(_plain(message), allow_nan=False)
        for s in list(sockets):
            with contextlib.suppress(tornado.websocket.WebSocketClosedError):
                s.write_message(text)

    routes = [(path, Static) for path in STATIC] + [
        (r"/export/(state\.json|view\.png|report\.html)", Export),
        (r"/ws", Socket),
    ]
    app = tornado.web.Application(routes, websocket_max_message_size=1 << 16, compress_response=False)
    app.broadcast = broadcast  # type: ignore[attr-defined]
    return app


class Explorer:
    """A running explorer: its :attr:`url`, its :attr:`session` (the state, :meth:`set`,
    :meth:`~ExploreSession.recommend` ...), :meth:`stop`. In a notebook it displays as the page in
    a frame (:meth:`_repr_html_`). Made by :func:`explore` (a server on its own thread) or by
    :func:`serve` (the server on the calling thread, as ``labcut explore`` runs it)."""

    def __init__(self, session: ExploreSession, host: str = "127.0.0.1", port: int = 0) -> None:
        if not isinstance(port, int) or isinstance(port, bool) or not 0 <= port <= 65535:
            raise ParameterError(f"port must be a whole number in 0-65535 (0: any free port), got {port!r}")
        if not isinstance(host, str) or not host:
            raise ParameterError(f"host must be an address or host name, got {host!r}")
        self.session = session
        self.host = host
        self._port = port
        self._loop: Any = None
        self._server: Any = None
        self._thread: threading.Thread | None = None
        self.worker = Worker(session, self._publish)
        self._app: Any = None

    # ------------------------------------------------------------------ running
    @property
    def port(self) -> int:
        return self._port

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self._port}/"

    def _publish(self, message: dict[str, Any]) -> None:
        loop = self._loop
        if loop is not None and self._app is not None:
            with contextlib.suppress(RuntimeError):  # the loop closed: nobody listens any more
                loop.add_callback(self._app.broadcast, message)

    def _listen(self) -> None:
        import tornado.httpserver
        import tornado.ioloop
        import tornado.netutil

        self._loop = tornado.ioloop.IOLoop.current()
        self._app = make_app(self.worker, self.host, lambda: self._port)
        self._server = tornado.httpserver.HTTPServer(self._app, xheaders=False)
        try:
            sockets = tornado.netutil.bind_sockets(self._port, address=self.host)
        except OSError as exc:  # the port taken, an address not of this machine, a name that does not resolve
            raise ParameterError(f"cannot listen on {self.host}:{self._port}: {exc.strerror or exc}") from None
        self._server.add_sockets(sockets)
        self._port = sockets[0].getsockname()[1]
        if not self.worker.is_alive():
            self.worker.start()

    def run(self, on_ready: Callable[[Explorer], None] | None = None) -> None:
        """Serve on the calling thread until :meth:`stop` (or Ctrl-C on the main thread, which stops
        it cleanly: the page's socket closes, the worker stops between two steps)."""
        import signal

        import tornado.ioloop

        asyncio.set_event_loop(asyncio.new_event_loop())
        self._listen()
        loop = tornado.ioloop.IOLoop.current()
        handled = False
        if threading.current_thread() is threading.main_thread():
            loop.asyncio_loop.add_signal_handler(signal.SIGINT, self._halt)
            handled = True
        try:
            if on_ready is not None:
                loop.add_callback(on_ready, self)
            loop.start()
        finally:
            if handled:
                loop.asyncio_loop.remove_signal_handler(signal.SIGINT)
            self._close()

    def start(self) -> Explorer:
        """Serve on a thread of its own (a notebook's way); returns once it listens."""
        import tornado.ioloop

        ready = threading.Event()
        failure: list[BaseException] = []

        def main() -> None:
            asyncio.set_event_loop(asyncio.new_event_loop())
            try:
                self._listen()
            except BaseException as exc:  # reported to start()'s caller
                failure.append(exc)
                ready.set()
                return
            ready.set()
            try:
                tornado.ioloop.IOLoop.current().start()
            finally:
                self._close()

        self._thread = threading.Thread(target=main, name="labcut-explore-server", daemon=True)
        self._thread.start()
        ready.wait()
        if failure:
            raise failure[0]
        # a notebook or script that ends without stop(): stop here, before Dr.Jit and Mitsuba shut down
        # under a render the worker is still running (registered now, not at import; undone by stop())
        atexit.register(self._stop_at_exit)
        return self

    def _stop_at_exit(self) -> None:
        self.stop()
        if self.worker.is_alive():
            self.worker.join(timeout=EXIT_WAIT_SECONDS)

    def _halt(self) -> None:
        import tornado.ioloop

        tornado.ioloop.IOLoop.current().stop()

    def _close(self) -> None:
        self.worker.stop()
        if self._server is not None:
            self._server.stop()
        self._app = None

    def stop(self) -> None:
        """Stop serving (the page's socket closes) and the worker."""
        atexit.unregister(self._stop_at_exit)
        loop = self._loop
        if loop is not None:
            with contextlib.suppress(RuntimeError):
                loop.add_callback(self._halt)
        if self._thread is not None:
            self._thread.join(timeout=10)
        self.worker.stop()

    # ------------------------------------------------------------------ notebooks
    def set(self, **changes: Any) -> Any:
        """Set controls from Python (``explorer.set(lamp_elevation=60)``): the session's state,
        checked; an open page shows it after its next answer."""
        state = self.session.set(changes)
        self.worker.submit(_Job("hello", ids=[None]))
        return state

    def __repr__(self) -> str:
        return f"Explorer({self.url}, {self.session.view_name()})"

    def _repr_html_(self) -> str:
        """The page in a frame (Jupyter, VS Code): the server runs on this machine, as the notebook does."""
        import html

        return (f'<iframe src="{html.escape(self.url)}" title="labcut explore" width="100%" height="860" '
                f'style="border:1px solid #ccc"></iframe><div>labcut explore: <a href="{html.escape(self.url)}" '
                f'target="_blank">{html.escape(self.url)}</a></div>')


def explore(stone: Any, material: Any = None, scenario: str = "bench", quality: str = "standard", *,
            host: str = "127.0.0.1", port: int = 0, seed: int = 0) -> Explorer:
    """Explore a stone live in a notebook: starts the explorer's server on a thread of its own
    (127.0.0.1, a free port unless ``port`` is given) and returns the :class:`Explorer`, which a
    notebook displays as the page. ``stone``: a :class:`~labcut.Stone`, a trimesh or a mesh path;
    ``material``, ``scenario``, ``quality``: where the controls start (``material`` is what the
    ``given`` choice means). ``explorer.stop()`` ends it."""
    session = ExploreSession(stone, material, scenario, quality, seed=seed)
    return Explorer(session, host, port).start()


def serve(session: ExploreSession, host: str = "127.0.0.1", port: int = 0,
          on_ready: Callable[[Explorer], None] | None = None) -> Explorer:
    """Serve ``session`` on the calling thread until Ctrl-C (``labcut explore``'s way); returns the
    stopped :class:`Explorer`. ``on_ready(explorer)`` runs once it listens (the CLI prints the URL
    and opens the browser there)."""
    explorer = Explorer(session, host, port)
    explorer.run(on_ready)
    return explorer
