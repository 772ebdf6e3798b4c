// labcut explore: the page's side. Controls send changes over the WebSocket; the server answers
// with the view (numbers, score map, words) and then the pictures. A value a control cannot take
// is refused here (and again by the server) with a message beside the control.
"use strict";
(() => {
  const MAP = 300;  // the score map's size on the page (CSS px); the projection is labcut.explorer.hemisphere's
  const $ = (id) => document.getElementById(id);
  let ws = null;
  let spec = null;
  let view = null;
  let generation = 0;
  let nextId = 1;
  let inFlight = null;      // the id of the change waiting for its answer
  let queued = {};          // changes made meanwhile, sent together when it is answered
  let typing = {};          // debounce timers of number fields
  const sent = new Map();   // id of a change sent -> the controls it set (their errors clear when it is answered)

  function setStatus(text, busy) {
    const s = $("status");
    s.textContent = text || "";
    s.classList.toggle("busy", !!busy);
  }

  function send(message) {
    message.id = nextId++;
    ws.send(JSON.stringify(message));
    return message.id;
  }

  function flush() {
    if (inFlight !== null || Object.keys(queued).length === 0 || !ws || ws.readyState !== 1) return;
    const changes = queued;
    queued = {};
    inFlight = send({ op: "set", changes });
    sent.set(inFlight, Object.keys(changes));
  }

  function change(values) {
    Object.assign(queued, values);
    flush();
  }

  // ---------------------------------------------------------------- checks on the page
  const label = (control) => control.replace(/_/g, " ");

  function check(control, raw) {
    if (spec && control in spec.ranges) {
      if (String(raw).trim() === "") return { error: `${label(control)}: enter a number` };
      const x = Number(raw);
      if (!Number.isFinite(x)) return { error: `${label(control)}: expected a number, got ${JSON.stringify(raw)}` };
      const [lo, hi] = spec.ranges[control];
      if (control.endsWith("azimuth")) return { value: ((x % 360) + 360) % 360 };
      if (x < lo || x > hi) return { error: `${label(control)}: ${x} lies outside ${lo}-${hi}` };
      return { value: x };
    }
    if (spec && control in spec.choices) {
      if (!spec.choices[control].includes(raw)) return { error: `${label(control)}: unknown choice ${JSON.stringify(raw)}` };
      return { value: raw };
    }
    return { error: `${label(control)}: no such control` };
  }

  function showControlError(control, message) {
    const slot = document.querySelector(`[data-error-for="${control}"]`);
    const input = document.querySelector(`[data-control="${control}"]`);
    if (slot) slot.textContent = message || "";
    else if (message) $("general-error").textContent = message;
    if (input) input.setAttribute("aria-invalid", message ? "true" : "false");
  }

  function submit(control, raw) {
    const checked = check(control, raw);
    if ("error" in checked) {
      showControlError(control, checked.error);
      return;
    }
    showControlError(control, "");
    if (view && view.state[control] === checked.value && !(control in queued) && inFlight === null) return;  // nothing new
    change({ [control]: checked.value });
  }

  // ---------------------------------------------------------------- the controls
  function buildChoices() {
    for (const [control, choices] of Object.entries(spec.choices)) {
      const select = document.querySelector(`select[data-control="${control}"]`);
      if (!select) continue;
      select.textContent = "";
      for (const c of choices) {
        const option = document.createElement("option");
        option.value = c;
        option.textContent = c;
        select.appendChild(option);
      }
    }
  }

  function wire() {
    for (const el of document.querySelectorAll("[data-control]")) {
      const control = el.dataset.control;
      if (el.tagName === "SELECT") {
        el.addEventListener("change", () => submit(control, el.value));
        continue;
      }
      el.addEventListener("input", () => {
        clearTimeout(typing[control]);
        const checked = check(control, el.value);
        if ("error" in checked) { showControlError(control, checked.error); return; }
        showControlError(control, "");
        typing[control] = setTimeout(() => submit(control, el.value), 250);
      });
      el.addEventListener("change", () => { clearTimeout(typing[control]); submit(control, el.value); });
      el.addEventListener("keydown", (ev) => { if (ev.key === "Enter") { clearTimeout(typing[control]); submit(control, el.value); } });
    }
    for (const slider of document.querySelectorAll("[data-slider-for]")) {
      const control = slider.dataset.sliderFor;
      slider.addEventListener("input", () => {
        const field = document.querySelector(`[data-control="${control}"]`);
        field.value = slider.value;
        submit(control, slider.value);
      });
    }
    $("recommend").addEventListener("click", () => {
      $("recommend").disabled = true;
      setStatus("recommending…", true);
      send({ op: "recommend" });
    });
    $("reset").addEventListener("click", () => send({ op: "reset" }));
    $("map-marks").addEventListener("click", (ev) => {
      const box = ev.currentTarget.getBoundingClientRect();
      const x = ((ev.clientX - box.left) / box.width) * 2 - 1;
      const y = 1 - ((ev.clientY - box.top) / box.height) * 2;
      const r = Math.hypot(x, y);
      if (r > 1) return;
      const tilt = Math.min(90, r * 90);
      const azimuth = ((Math.atan2(y, x) * 180) / Math.PI + 360) % 360;
      change({ normal_tilt: Number(tilt.toFixed(2)), normal_azimuth: Number(azimuth.toFixed(1)) });
    });
  }

  // ---------------------------------------------------------------- the answers
  const fmt = (x, digits = 4) => (x === null || x === undefined ? "–" : Number(x).toPrecision(digits));
  const pct = (x) => `${(100 * x).toFixed(1)} %`;

  function output(id, text, value) {
    const el = $(id);
    el.textContent = text;
    if (value !== undefined) el.dataset.value = String(value);
  }

  function showState(state) {
    for (const [control, value] of Object.entries(state)) {
      const el = document.querySelector(`[data-control="${control}"]`);
      if (el && el !== document.activeElement) el.value = typeof value === "number" ? String(Number(value.toFixed(3))) : value;
      const slider = document.querySelector(`[data-slider-for="${control}"]`);
      if (slider) slider.value = value;
    }
  }

  function point(tilt, azimuth) {
    const r = tilt / 90;
    const a = (azimuth * Math.PI) / 180;
    return [((r * Math.cos(a) + 1) / 2) * MAP, ((1 - r * Math.sin(a)) / 2) * MAP];
  }

  function drawMarks(v) {
    const canvas = $("map-marks");
    const g = canvas.getContext("2d");
    g.clearRect(0, 0, canvas.width, canvas.height);
    g.strokeStyle = "rgba(255,255,255,0.5)";
    for (const t of [30, 60, 90]) {
      g.beginPath();
      g.arc(MAP / 2, MAP / 2, (t / 90) * (MAP / 2) - 0.5, 0, 2 * Math.PI);
      g.stroke();
    }
    const mark = (tilt, az, draw) => { const [x, y] = point(tilt, az); draw(x, y); };
    mark(v.score_map.best_tilt, v.score_map.best_azimuth, (x, y) => {
      g.strokeStyle = "#ffb703"; g.lineWidth = 2; g.beginPath();
      g.moveTo(x, y - 7); g.lineTo(x + 7, y); g.lineTo(x, y + 7); g.lineTo(x - 7, y); g.closePath(); g.stroke();
    });
    if (v.recommendation) {
      mark(v.recommendation.tilt_deg, v.recommendation.azimuth_deg, (x, y) => {
        g.fillStyle = "#e63946"; g.font = "18px sans-serif"; g.textAlign = "center"; g.textBaseline = "middle"; g.fillText("★", x, y);
      });
    }
    mark(v.state.normal_tilt, v.state.normal_azimuth, (x, y) => {
      g.strokeStyle = "#fff"; g.lineWidth = 2.5; g.beginPath(); g.arc(x, y, 6, 0, 2 * Math.PI); g.stroke();
      g.strokeStyle = "#000"; g.lineWidth = 1; g.beginPath(); g.arc(x, y, 8, 0, 2 * Math.PI); g.stroke();
    });
  }

  function showTimings() {  // the answer's milliseconds, and the estimator a recommendation would use once planned
    const t = view.timings_ms;
    $("timings").textContent = `answered in ${t.total} ms (study ${t.study}, map ${t.score_map}, metrics ${t.metrics}); recommend: ${view.estimator.split(": ")[1]}`;
  }

  function showView(message) {
    const v = message.view;
    view = v;
    generation = message.generation;
    if (message.ids.includes(inFlight)) { inFlight = null; }
    showState(v.state);
    $("subject").textContent = `${v.stone.name} (${v.stone.kind}, ${v.stone.size_mm.join(" × ")} mm) · ${v.material} · ${v.lights}`;
    const m = v.metrics, e = v.errors;
    output("tilt-out", `${v.state.normal_tilt.toFixed(2)}°`, v.state.normal_tilt);
    output("azimuth-out", `${v.state.normal_azimuth.toFixed(1)}°`, v.state.normal_azimuth);
    output("energy-out", `${fmt(m.flash_energy)} ± ${fmt(e.flash_energy, 2)}`, m.flash_energy);
    output("area-out", `${pct(m.flash_area)} ± ${pct(e.flash_area)}`, m.flash_area);
    output("intensity-out", `${fmt(m.flash_intensity)} ± ${fmt(e.flash_intensity, 2)}`, m.flash_intensity);
    output("coverage-out", pct(m.coverage), m.coverage);
    $("words").textContent = v.words.orientation;
    $("workshop").textContent = v.words.workshop;
    $("objective").textContent = `(${v.objective}, highest ${fmt(v.score_map.max)})`;
    $("map-img").src = v.score_map.png;
    $("map-max").textContent = `the map's best: tilt ${v.score_map.best_tilt.toFixed(1)}°, azimuth ${v.score_map.best_azimuth.toFixed(0)}° (${v.score_map.normals} normals)`;
    drawMarks(v);
    const r = v.recommendation;
    const box = $("recommendation");
    if (r) {
      const bar = r.angle_error_deg === null ? "" : ` ± ${r.angle_error_deg.toFixed(1)}°`;
      const sbar = r.score_rel_error === null ? "" : ` ± ${(100 * r.score_rel_error).toFixed(0)} %`;
      box.textContent = "";
      for (const line of [
        `tilt ${r.tilt_deg.toFixed(2)}°${bar}, azimuth ${r.azimuth_deg.toFixed(0)}° (${r.estimator} estimator, ${r.seconds.toFixed(2)} s)`,
        `${r.objective} ${fmt(r.score)}${sbar}`,
        `tolerance ±${r.tolerance_deg.toFixed(1)}° keeps 90 % of the score`,
        r.description,
        r.workshop || "",
      ]) {
        const p = document.createElement("p");
        p.textContent = line;
        box.appendChild(p);
      }
    }
    showTimings();
    $("recommend").disabled = false;
    setStatus("", false);
    for (const id of message.ids) {  // the controls this answer took: their errors are gone
      for (const control of sent.get(id) || []) showControlError(control, "");
      sent.delete(id);
    }
    $("general-error").textContent = "";
    flush();
  }

  function showRender(message) {
    $("render").src = message.png;
    const step = message.stage === "refined" ? ` (pass ${message.step})` : "";
    $("render-stage").textContent = `${message.stage}${step}, ${message.ms} ms`;
    $("render").dataset.stage = message.stage;
  }

  function showError(message) {
    if (message.ids && message.ids.includes(inFlight)) inFlight = null;
    if (message.control) {
      showControlError(message.control, message.message);
      if (view) showState(view.state);  // the control shows the last value it took
    } else {
      $("general-error").textContent = message.message;
    }
    $("recommend").disabled = false;
    setStatus("", false);
    flush();
  }

  function handle(message) {
    switch (message.type) {
      case "spec": spec = message.spec; buildChoices(); if (view) showState(view.state); break;
      case "view": showView(message); break;
      case "plan": if (view && message.generation >= generation) { view.estimator = message.estimator; showTimings(); } break;
      case "render": if (message.generation >= generation) showRender(message); break;
      case "render-done": $("render").dataset.done = String(message.generation); break;
      case "error": showError(message); break;
      case "busy": setStatus(message.what ? `${message.what}…` : "", !!message.what); break;
      default: break;
    }
  }

  function connect() {
    ws = new WebSocket(`ws://${location.host}/ws`);
    ws.addEventListener("open", () => send({ op: "hello" }));
    ws.addEventListener("message", (ev) => handle(JSON.parse(ev.data)));
    ws.addEventListener("close", () => setStatus("disconnected: the explorer has stopped", false));
  }

  wire();
  connect();
})();
