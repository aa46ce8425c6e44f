// The page's driver: loads sph_web.wasm, hands it a scene file's text,
// steps it, draws the particles.
"use strict";

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
// A fixed run (?run=end&case=...): to the end time, then the figures, for
// the headless test.
const fixedRun = params.get("run") === "end";

let sph = null;
let running = false;
let stepsPerFrame = 5;
let rate = { steps: 0, seconds: 0 };
// The selected case's defaults (resolution, Reynolds number).
let defaults = { resolution: 32, re: 100 };

function setText(text) {
  const bytes = new TextEncoder().encode(text);
  const at = sph.sph_input(bytes.length);
  new Uint8Array(sph.memory.buffer, at, bytes.length).set(bytes);
}

function moduleText() {
  return new TextDecoder().decode(
    new Uint8Array(sph.memory.buffer, sph.sph_text(), sph.sph_text_len()));
}

function fail(message) {
  $("status").textContent = message;
  $("status").className = "error";
  running = false;
}

// A number as TOML reads it back exactly (JavaScript's shortest form).
function tomlNumber(x) {
  return Number.isInteger(x) ? x.toFixed(1) : String(x);
}

// The scene file the page runs: the case with its defaults, the chosen
// resolution and Reynolds number, one thread.
function sceneText(name, resolution, re, tEnd) {
  let text = `case = "${name}"\nresolution = ${resolution}\nre = ${tomlNumber(re)}\n`;
  if (tEnd !== null) text += `t_end = ${tomlNumber(tEnd)}\n`;
  return text + "threads = 1\n";
}

// The case's default resolution and Reynolds number, read from its
// defaults (scene-file text from the module).
function loadDefaults(name) {
  setText(name);
  if (sph.sph_defaults() !== 0) {
    fail(moduleText());
    return false;
  }
  const text = moduleText();
  const key = (k) => Number((text.match(new RegExp(`^${k} = (.*)$`, "m")) || [])[1]);
  defaults = { resolution: key("resolution"), re: key("re") };
  return true;
}

function chosenRe() {
  const re = defaults.re * Math.pow(10, Number($("re").value));
  return Number(re.toPrecision(3));
}

function start(text) {
  $("scene").textContent = text;
  setText(text);
  rate = { steps: 0, seconds: 0 };
  stepsPerFrame = 5;
  if (sph.sph_start() !== 0) {
    fail(moduleText());
    return false;
  }
  $("status").textContent = "running";
  $("status").className = "";
  running = true;
  return true;
}

function startFromControls() {
  $("resolution-value").textContent = $("resolution").value;
  $("re-value").textContent = String(chosenRe());
  start(sceneText($("case").value, Number($("resolution").value), chosenRe(), null));
}

function selectCase() {
  if (!loadDefaults($("case").value)) return;
  const r = Math.max(8, Math.min(96, 4 * Math.round(defaults.resolution / 4)));
  $("resolution").value = String(Math.min(r, 48));
  $("re").value = "0";
  startFromControls();
}

function colour(s) {
  // 0..1: blue to red.
  const c = Math.max(0, Math.min(1, s));
  return `rgb(${Math.round(40 + 215 * c)},${Math.round(90 + 60 * Math.sin(Math.PI * c))},${Math.round(255 - 215 * c)})`;
}

// Draws the particles in the box; returns the largest speed.
function draw() {
  const n = sph.sph_fill_view();
  const view = new Float64Array(sph.memory.buffer, sph.sph_view(), 4 * n);
  const canvas = $("view"), g = canvas.getContext("2d");
  g.clearRect(0, 0, canvas.width, canvas.height);
  const [x0, y0, w, h] = [0, 1, 2, 3].map((k) => sph.sph_box(k));
  const margin = 10;
  const scale = Math.min((canvas.width - 2 * margin) / w, (canvas.height - 2 * margin) / h);
  const px = (x) => margin + (x - x0) * scale;
  const py = (y) => canvas.height - margin - (y - y0) * scale;
  g.strokeStyle = "#888";
  g.strokeRect(px(x0), py(y0 + h), w * scale, h * scale);
  let vmax = 0;
  for (let i = 0; i < n; i++) vmax = Math.max(vmax, Math.hypot(view[4 * i + 2], view[4 * i + 3]));
  const r = Math.max(1, 0.45 * sph.sph_dx() * scale);
  for (let i = 0; i < n; i++) {
    g.fillStyle = colour(vmax > 0 ? Math.hypot(view[4 * i + 2], view[4 * i + 3]) / vmax : 0);
    g.beginPath();
    g.arc(px(view[4 * i]), py(view[4 * i + 1]), r, 0, 2 * Math.PI);
    g.fill();
  }
  return vmax;
}

function figures(vmax) {
  $("time").textContent = sph.sph_time().toPrecision(6) + " s";
  $("end").textContent = sph.sph_end_time().toPrecision(6) + " s";
  $("steps").textContent = String(sph.sph_steps());
  $("particles").textContent = String(sph.sph_particles());
  $("vmax").textContent = vmax.toPrecision(4) + " m/s";
  const e = sph.sph_error();
  // The shortest text that reads back as the same double: the test
  // compares it with summary.json bit for bit.
  $("linf").textContent = Number.isNaN(e) ? "-" : String(e);
  $("linf-time").textContent = Number.isNaN(e) ? "-" : sph.sph_error_time().toPrecision(6) + " s";
  if (rate.seconds > 0) {
    $("rate").textContent = (rate.steps * sph.sph_particles() / rate.seconds).toExponential(2);
  }
}

function frame() {
  if (running) {
    const before = sph.sph_steps();
    const t0 = performance.now();
    const status = sph.sph_advance(stepsPerFrame);
    const seconds = (performance.now() - t0) / 1000;
    if (status !== 0) {
      fail(moduleText());
    } else {
      rate.steps += sph.sph_steps() - before;
      rate.seconds += seconds;
      // Keep a frame near 15 ms of stepping.
      if (seconds < 0.008) stepsPerFrame = Math.min(5000, stepsPerFrame * 2);
      if (seconds > 0.03) stepsPerFrame = Math.max(1, Math.floor(stepsPerFrame / 2));
      if (sph.sph_ended()) {
        running = false;
        $("status").textContent = "ended";
      }
    }
    figures(draw());
  }
  requestAnimationFrame(frame);
}

function runFixed() {
  const name = params.get("case") || "taylor-green";
  if (!loadDefaults(name)) return;
  const resolution = Number(params.get("resolution") || defaults.resolution);
  const re = Number(params.get("re") || defaults.re);
  const tEnd = params.has("t_end") ? Number(params.get("t_end")) : null;
  if (!start(sceneText(name, resolution, re, tEnd))) return;
  const t0 = performance.now();
  // Pieces of 50 steps: the result does not depend on the pieces.
  while (!sph.sph_ended()) {
    if (sph.sph_advance(50) !== 0) {
      fail(moduleText());
      return;
    }
  }
  rate = { steps: sph.sph_steps(), seconds: (performance.now() - t0) / 1000 };
  figures(draw());
  $("status").textContent = "done";
}

WebAssembly.instantiateStreaming(fetch("sph_web.wasm"), {})
  .then(({ instance }) => {
    sph = instance.exports;
    if (fixedRun) {
      runFixed();
      return;
    }
    $("case").onchange = selectCase;
    $("restart").onclick = startFromControls;
    $("resolution").oninput = startFromControls;
    $("re").oninput = startFromControls;
    selectCase();
    requestAnimationFrame(frame);
  })
  .catch((e) => fail("cannot load sph_web.wasm: " + e));
