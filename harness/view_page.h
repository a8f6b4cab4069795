// The page `lockroll view` writes: one self-contained HTML file (inline style, script and data;
// no network). The data replaces the line holding @DATA@ as a <script> element with id
// lockroll-data, either plain JSON or, when large, gzip + base64 (data-encoding="gzip+base64",
// unpacked with the browser's DecompressionStream).
//
// Data: {"clients": N, "frames": [F...], "time": [s...], "mean": [m...], "max": [m...],
//        "rollbacks": [n...], "bodies": [[player, shape, r, hx, hz]...] (dynamic, by index),
//        "statics": [[shape, x, z, r, hx, hz]...], "scale": 1e5,
//        "pos": [client][frame index * bodies * 2 + body * 2 + {0: x, 1: z}] (metres * scale),
//        "corrections": [[client, frame, jump m]...]}
// mean/max are frames.csv's values as written there, so the page reports exactly them.
//
// The URL hash sets the start: #frame=F&a=0&b=1. The element #frame-error carries the shown
// frame's figures in data-frame, data-mean and data-max (what the browser test reads).
#pragma once

namespace lockroll::harness {

inline constexpr const char* kViewPage = R"PAGE(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>lockroll view</title>
<style>
body { font: 13px sans-serif; margin: 12px; background: #fafafa; color: #222; }
#controls { display: flex; gap: 10px; align-items: center; flex-wrap: wrap; margin-bottom: 8px; }
#scrub { width: 480px; }
#views { display: flex; gap: 12px; }
figure { margin: 0; } figcaption { font-weight: bold; margin-bottom: 4px; }
canvas { background: #fff; border: 1px solid #bbb; }
#frame-error { font-family: monospace; }
.corr { color: #9467bd; font-weight: bold; }
</style></head><body>
<div id="controls">
  <button id="play">play</button>
  <input type="range" id="scrub" min="0" max="0" value="0">
  <span>frame <b id="frame-num">-</b> <span id="frame-time"></span></span>
  <label>client <select id="ca"></select></label> vs <label>client <select id="cb"></select></label>
</div>
<div id="frame-error" data-frame="" data-mean="" data-max="">loading…</div>
<div id="views">
  <figure><figcaption id="la">client</figcaption><canvas id="va" width="520" height="520"></canvas><div id="ja"></div></figure>
  <figure><figcaption id="lb">client</figcaption><canvas id="vb" width="520" height="520"></canvas><div id="jb"></div></figure>
</div>
<p>Top down (x right, z down), each client's view as it first showed the frame. Bodies whose
position differs between the two clients on this frame are red; player bodies are outlined.
Corrections (a rollback changing a shown frame) show as jumps between frames, listed under each view.
The plot is mean (blue) and max (red) error between all clients against run time (frames.csv);
click or drag it to move to a frame.</p>
<canvas id="plot" width="1056" height="230"></canvas><div id="plot-axes" data-xticks="" data-yticks=""></div>
@DATA@
<script>
"use strict";
const $ = (id) => document.getElementById(id);
async function loadData() {
  const el = $("lockroll-data");
  if (el.dataset.encoding === "gzip+base64") {
    const bin = Uint8Array.from(atob(el.textContent.trim()), (c) => c.charCodeAt(0));
    const stream = new Blob([bin]).stream().pipeThrough(new DecompressionStream("gzip"));
    return JSON.parse(await new Response(stream).text());
  }
  return JSON.parse(el.textContent);
}
loadData().then(start).catch((e) => { $("frame-error").textContent = "cannot read the data: " + e; });

function start(D) {
  const nb = D.bodies.length, nf = D.frames.length;
  let idx = 0, a = 0, b = Math.min(1, D.clients - 1), timer = null;
  const hash = new URLSearchParams(location.hash.slice(1));
  for (const s of ["ca", "cb"])
    for (let c = 0; c < D.clients; ++c) $(s).add(new Option("" + c, "" + c));
  if (hash.has("a")) a = Math.min(D.clients - 1, Math.max(0, +hash.get("a")));
  if (hash.has("b")) b = Math.min(D.clients - 1, Math.max(0, +hash.get("b")));
  $("ca").value = "" + a; $("cb").value = "" + b;
  if (hash.has("frame")) { const f = D.frames.indexOf(+hash.get("frame")); if (f >= 0) idx = f; }
  $("scrub").max = "" + (nf - 1);

  // World bounds from the static bodies and every shown position.
  let x0 = Infinity, x1 = -Infinity, z0 = Infinity, z1 = -Infinity;
  const grow = (x, z, rx, rz) => { x0 = Math.min(x0, x - rx); x1 = Math.max(x1, x + rx); z0 = Math.min(z0, z - rz); z1 = Math.max(z1, z + rz); };
  for (const s of D.statics) s[0] === "box" ? grow(s[1], s[2], s[4], s[5]) : grow(s[1], s[2], s[3], s[3]);
  for (const p of D.pos) for (let i = 0; i < p.length; i += 2) grow(p[i] / D.scale, p[i + 1] / D.scale, 0, 0);
  const span = Math.max(x1 - x0, z1 - z0) || 1;

  function drawView(canvas, client, other) {
    const g = canvas.getContext("2d"), W = canvas.width, k = (W - 20) / span;
    const X = (x) => 10 + (x - x0) * k, Z = (z) => 10 + (z - z0) * k;
    g.clearRect(0, 0, W, canvas.height);
    g.fillStyle = "rgba(120,120,120,0.25)"; g.strokeStyle = "#777"; g.lineWidth = 1;
    for (const s of D.statics) {
      g.beginPath();
      if (s[0] === "box") g.rect(X(s[1] - s[4]), Z(s[2] - s[5]), 2 * s[4] * k, 2 * s[5] * k);
      else g.arc(X(s[1]), Z(s[2]), s[3] * k, 0, 7);
      g.fill(); g.stroke();
    }
    const P = D.pos[client], Q = D.pos[other], base = idx * nb * 2;
    let wrong = 0;
    for (let i = 0; i < nb; ++i) {
      const [player, shape, r, hx, hz] = D.bodies[i];
      const x = P[base + 2 * i] / D.scale, z = P[base + 2 * i + 1] / D.scale;
      const differs = P[base + 2 * i] !== Q[base + 2 * i] || P[base + 2 * i + 1] !== Q[base + 2 * i + 1];
      wrong += differs;
      g.fillStyle = differs ? "#e0301e" : player >= 0 ? "#4a7fd4" : "#8fb3e8";
      g.strokeStyle = player >= 0 ? "#000" : "#456";
      g.lineWidth = player >= 0 ? 2 : 0.5;
      g.beginPath();
      if (shape === "box") g.rect(X(x - hx), Z(z - hz), 2 * hx * k, 2 * hz * k);
      else g.arc(X(x), Z(z), Math.max(r * k, 1.5), 0, 7);
      g.fill(); g.stroke();
    }
    return wrong;
  }

  function plot() {
    const c = $("plot"), g = c.getContext("2d"), W = c.width, H = c.height, L = 50, B = 30;
    g.clearRect(0, 0, W, H);
    const t0 = D.time[0], t1 = D.time[nf - 1] || 1, top = Math.max(...D.max, 1e-9);
    // Symmetric-log y: 0 at the bottom, 1e-6 .. top logarithmic above it.
    const lo = -6, hi = Math.log10(top);
    const Y = (v) => v <= 0 ? H - B : H - B - 8 - (Math.max(lo, Math.log10(v)) - lo) / Math.max(hi - lo, 1e-9) * (H - B - 16);
    const T = (t) => L + (t - t0) / Math.max(t1 - t0, 1e-9) * (W - L - 10);
    g.strokeStyle = "#999"; g.beginPath(); g.moveTo(L, 4); g.lineTo(L, H - B); g.lineTo(W, H - B); g.stroke();
    g.fillStyle = "#444"; g.fillText("0", L - 12, H - B + 3);
    g.fillText("error (m)", L + 6, 12); g.fillText("run time (s)", W - 70, 12);
    // Time ticks at the largest round step (5, 2 or 1 times a power of ten) that puts at least
    // 5 of them inside the run (so 5 to about 12); error ticks at each decade of the log scale.
    // Their values are also written to #plot-axes so a test can check them against frames.csv.
    const inside = (s) => Math.floor(t1 / s + 1e-9) - Math.ceil(t0 / s - 1e-9) + 1;
    let step = 1e-6;
    for (let k = Math.floor(Math.log10(Math.max(t1 - t0, 1e-6))); k >= -6 && step === 1e-6; --k)
      for (const m of [5, 2, 1]) if (inside(m * Math.pow(10, k)) >= 5) { step = m * Math.pow(10, k); break; }
    const digits = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
    const xt = [], yt = [];
    g.textAlign = "center";
    for (let t = Math.ceil(t0 / step - 1e-9) * step; t <= t1 + 1e-9; t += step) {
      g.beginPath(); g.moveTo(T(t), H - B + 8); g.lineTo(T(t), H - B + 13); g.stroke();  // below the rollback marks
      g.fillText(t.toFixed(digits), T(t), H - B + 24);
      xt.push(t.toFixed(digits));
    }
    g.textAlign = "right";
    for (let e = Math.ceil(lo) + 1; e <= Math.floor(hi); ++e) {  // 1e-6 is the floor, by "0"
      g.beginPath(); g.moveTo(L - 4, Y(Math.pow(10, e))); g.lineTo(L, Y(Math.pow(10, e))); g.stroke();
      g.fillText("1e" + e, L - 6, Y(Math.pow(10, e)) + 3);
      yt.push("1e" + e);
    }
    g.textAlign = "start";
    $("plot-axes").dataset.xticks = xt.join(","); $("plot-axes").dataset.yticks = yt.join(",");
    for (const [col, series] of [["#1f77b4", D.mean], ["#d62728", D.max]]) {
      g.strokeStyle = col; g.beginPath();
      for (let i = 0; i < nf; ++i) (i ? g.lineTo : g.moveTo).call(g, T(D.time[i]), Y(series[i]));
      g.stroke();
    }
    g.fillStyle = "#9467bd";
    for (let i = 0; i < nf; ++i) if (D.rollbacks[i] > 0) g.fillRect(T(D.time[i]) - 0.5, H - B + 2, 1, 5);
    g.strokeStyle = "#000"; g.beginPath(); g.moveTo(T(D.time[idx]), 4); g.lineTo(T(D.time[idx]), H - B); g.stroke();
    return (x) => { let best = 0; for (let i = 0; i < nf; ++i) if (Math.abs(T(D.time[i]) - x) < Math.abs(T(D.time[best]) - x)) best = i; return best; };
  }

  function corrections(client) {
    const f = D.frames[idx], out = [];
    for (const [c, frame, jump] of D.corrections) if (c === client && frame === f) out.push(jump);
    return out.length ? "<span class=corr>correction on this frame: jump " + out.map((j) => j.toPrecision(3) + " m").join(", ") + "</span>" : "";
  }

  let pick = null;
  function render() {
    const f = D.frames[idx];
    $("scrub").value = "" + idx;
    $("frame-num").textContent = "" + f;
    $("frame-time").textContent = "(" + D.time[idx].toFixed(3) + " s)";
    const wa = drawView($("va"), a, b), wb = drawView($("vb"), b, a);
    $("la").textContent = "client " + a + " (" + wa + " bodies differ from client " + b + ")";
    $("lb").textContent = "client " + b;
    $("ja").innerHTML = corrections(a); $("jb").innerHTML = corrections(b);
    const e = $("frame-error");
    e.dataset.frame = "" + f; e.dataset.mean = "" + D.mean[idx]; e.dataset.max = "" + D.max[idx];
    e.textContent = "frame " + f + ": mean error " + D.mean[idx] + " m, max error " + D.max[idx] + " m (all client pairs, frames.csv)";
    pick = plot();
  }
  $("scrub").addEventListener("input", () => { idx = +$("scrub").value; render(); });
  $("ca").addEventListener("change", () => { a = +$("ca").value; render(); });
  $("cb").addEventListener("change", () => { b = +$("cb").value; render(); });
  const seek = (ev) => { const r = $("plot").getBoundingClientRect(); idx = pick(ev.clientX - r.left); render(); };
  $("plot").addEventListener("mousedown", seek);
  $("plot").addEventListener("mousemove", (ev) => { if (ev.buttons & 1) seek(ev); });
  $("play").addEventListener("click", () => {
    if (timer) { clearInterval(timer); timer = null; $("play").textContent = "play"; return; }
    $("play").textContent = "pause";
    timer = setInterval(() => { idx = (idx + 1) % nf; render(); }, 1000 / 60);
  });
  window.addEventListener("hashchange", () => {
    const h = new URLSearchParams(location.hash.slice(1));
    const f = D.frames.indexOf(+h.get("frame")); if (f >= 0) { idx = f; render(); }
  });
  render();
}
</script>
</body></html>
)PAGE";

}  // namespace lockroll::harness
