// The page's driver: loads sph_web.wasm, steps it, draws the particles.
"use strict";

const GAP = 1e-3, U = 1.25e-5;
const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
// A fixed run (?steps=N): exactly N steps, then the figures, for the test.
const fixedSteps = params.has("steps") ? Number(params.get("steps")) : null;

let sph = null;
let running = false;
let stepsPerFrame = 20;
let rate = { steps: 0, seconds: 0 };

function nu() {
  return 1e-6 * Math.pow(10, Number($("nu").value));
}

// u(y, t) with y from the plate at rest: the exact series (physics.md 6.a).
function exact(y, t, viscosity) {
  let u = U * y / GAP;
  for (let n = 1; n < 200; n++) {
    const decay = Math.exp(-n * n * Math.PI * Math.PI * viscosity * t / (GAP * GAP));
    const term = 2 * U / (n * Math.PI) * decay;
    if (term < 1e-12 * U) break;
    u += (n % 2 ? -term : term) * Math.sin(n * Math.PI * y / GAP);
  }
  return u;
}

function colour(s) {
  // Speed 0..1 of U: blue to red.
  const c = Math.max(0, Math.min(1, s));
  return `rgb(${Math.round(40 + 215 * c)},${Math.round(90 + 60 * Math.sin(Math.PI * c))},${Math.round(255 - 215 * c)})`;
}

function draw() {
  const n = sph.sph_fill_view();
  const view = new Float64Array(sph.memory.buffer, sph.sph_view(), 4 * n);
  const canvas = $("view"), g = canvas.getContext("2d");
  g.clearRect(0, 0, canvas.width, canvas.height);
  const top = 20, height = canvas.height - 50, left = 20, stripW = 300;
  const ypx = (y) => top + height * (1 - (y + GAP / 2) / GAP);
  // The strip, repeated across the panel (it is periodic along x, six
  // particles wide).
  const ppm = height / GAP;
  const dx = GAP / Math.round(n / 6);
  const strip = 6 * dx * ppm;
  const copies = Math.max(1, Math.floor(stripW / strip));
  const r = Math.max(1.5, 0.35 * dx * ppm);
  for (let k = 0; k < copies; k++) {
    for (let i = 0; i < n; i++) {
      const x = view[4 * i], y = view[4 * i + 1], u = view[4 * i + 2], v = view[4 * i + 3];
      g.fillStyle = colour(Math.hypot(u, v) / U);
      g.beginPath();
      g.arc(left + k * strip + x * ppm, ypx(y), r, 0, 2 * Math.PI);
      g.fill();
    }
  }
  g.fillStyle = "#444";
  g.fillRect(left, top - 4, copies * strip, 3);
  g.fillRect(left, top + height + 1, copies * strip, 3);
  // The profile.
  const px0 = 380, pw = 340;
  const upx = (u) => px0 + pw * u / U;
  g.strokeStyle = "#999";
  g.strokeRect(px0, top, pw, height);
  g.strokeStyle = "#222";
  g.beginPath();
  const t = sph.sph_time(), visc = nu();
  for (let k = 0; k <= 100; k++) {
    const y = GAP * k / 100;
    const X = upx(exact(y, t, visc)), Y = ypx(y - GAP / 2);
    if (k === 0) g.moveTo(X, Y); else g.lineTo(X, Y);
  }
  g.stroke();
  g.fillStyle = "#c33";
  for (let i = 0; i < n; i++) {
    g.beginPath();
    g.arc(upx(view[4 * i + 2]), ypx(view[4 * i + 1]), 2.2, 0, 2 * Math.PI);
    g.fill();
  }
  g.fillStyle = "#222";
  g.fillText("0", px0 - 3, top + height + 15);
  g.fillText("u / U = 1", px0 + pw - 45, top + height + 15);
  g.fillText("plate at rest", left, top + height + 18);
  g.fillText("plate moving at U", left, top - 8);
}

function figures() {
  const steps = sph.sph_steps();
  $("time").textContent = sph.sph_time().toExponential(4) + " s";
  $("tstar").textContent = (sph.sph_time() / sph.sph_diffusion_time()).toFixed(4);
  $("steps").textContent = String(steps);
  $("particles").textContent = String(sph.sph_fill_view());
  $("linf").textContent = sph.sph_linf().toPrecision(17);
  if (rate.seconds > 0) {
    $("rate").textContent = (rate.steps * sph.sph_fill_view() / rate.seconds).toExponential(2);
  }
}

function start() {
  $("across-value").textContent = $("across").value;
  $("nu-value").textContent = nu().toExponential(2) + " m\u00b2/s";
  if (sph.sph_start(Number($("across").value), nu()) !== 0) {
    $("status").textContent = "refused: particles across 4 to 200, viscosity positive";
    $("status").className = "error";
    running = false;
    return;
  }
  rate = { steps: 0, seconds: 0 };
  $("status").textContent = "running";
  $("status").className = "";
  running = true;
}

function frame() {
  if (running) {
    const t0 = performance.now();
    const status = sph.sph_step(stepsPerFrame);
    const seconds = (performance.now() - t0) / 1000;
    if (status !== 0) {
      $("status").textContent = "the run diverged";
      $("status").className = "error";
      running = false;
    } else {
      rate.steps += stepsPerFrame;
      rate.seconds += seconds;
      // Keep a frame near 10 ms of stepping.
      if (seconds < 0.005) stepsPerFrame = Math.min(2000, stepsPerFrame * 2);
      if (seconds > 0.02) stepsPerFrame = Math.max(1, Math.floor(stepsPerFrame / 2));
      if (sph.sph_time() > 2 * sph.sph_diffusion_time()) {
        running = false;
        $("status").textContent = "steady (t = 2 H\u00b2/\u03bd)";
      }
    }
    draw();
    figures();
  }
  requestAnimationFrame(frame);
}

function fixedRun() {
  // The test's run: N steps in pieces of 20, as the native reference.
  $("across").value = params.get("across") || "16";
  const wanted = Number(params.get("nu") || "1e-6");
  $("nu").value = String(Math.log10(wanted / 1e-6));
  $("across-value").textContent = $("across").value;
  $("nu-value").textContent = wanted.toExponential(2) + " m\u00b2/s";
  if (sph.sph_start(Number($("across").value), wanted) !== 0) {
    $("status").textContent = "refused";
    return;
  }
  const t0 = performance.now();
  let left = fixedSteps;
  while (left > 0) {
    const k = Math.min(20, left);
    if (sph.sph_step(k) !== 0) {
      $("status").textContent = "diverged";
      return;
    }
    left -= k;
  }
  rate = { steps: fixedSteps, seconds: (performance.now() - t0) / 1000 };
  draw();
  figures();
  $("status").textContent = "done";
}

WebAssembly.instantiateStreaming(fetch("sph_web.wasm"), {})
  .then(({ instance }) => {
    sph = instance.exports;
    if (fixedSteps !== null) {
      fixedRun();
      return;
    }
    $("restart").onclick = start;
    $("across").oninput = start;
    $("nu").oninput = start;
    start();
    requestAnimationFrame(frame);
  })
  .catch((e) => {
    $("status").textContent = "cannot load sph_web.wasm: " + e;
    $("status").className = "error";
  });
