// The page `glovepose view` serves: the hand drawn in 3D with WebGL (no library: a few shaders),
// the 25 angles, the trust flags, the calibration step with its target pose, what the glove's stream
// said (lines not understood, sensors the calibration reads as 0), and the latency.
// It asks the tool for the newest hand (GET /state, JSON) about 30 times a second.
#pragma once

namespace glovepose::cli {

inline constexpr const char* kViewPage = R"PAGE(<!doctype html>
<html><head><meta charset="utf-8"><title>glovepose view</title>
<style>
body { margin: 0; background: #15171c; color: #d8dde6; font: 13px/1.35 monospace; display: flex; }
#hand { width: 640px; height: 560px; display: block; }
#side { padding: 10px 14px; width: 360px; }
h1 { font-size: 15px; margin: 4px 0 8px; }
.bad { color: #ff7b6b; } .good { color: #8fd18f; }
table { border-collapse: collapse; } td { padding: 0 8px 0 0; }
#step { color: #7fb4ff; }
#notes { white-space: pre-wrap; }
</style></head>
<body>
<canvas id="hand" width="640" height="560"></canvas>
<div id="side">
<h1>glovepose: the hand, live</h1>
<div id="trust"></div>
<div id="step"></div>
<div id="notes" class="bad"></div>
<div id="latency"></div>
<table id="angles"></table>
<pre id="status">frames 0</pre>
</div>
<script>
"use strict";
// OpenXR joint parents (XrHandJointEXT order): bones run from each joint to its parent.
const PARENT = [1, -1, 1, 2, 3, 4, 1, 6, 7, 8, 9, 1, 11, 12, 13, 14, 1, 16, 17, 18, 19, 1, 21, 22, 23, 24];
const viewer = { frames: 0, seq: -1, joints: null, webgl: false, drawn: 0 };
window.viewer = viewer;
const canvas = document.getElementById("hand");
const gl = canvas.getContext("webgl", { preserveDrawingBuffer: true });
viewer.webgl = !!gl;
let program = null, buffer = null;
if (gl) {
  const shader = (type, source) => {
    const s = gl.createShader(type); gl.shaderSource(s, source); gl.compileShader(s); return s;
  };
  program = gl.createProgram();
  gl.attachShader(program, shader(gl.VERTEX_SHADER,
    "attribute vec3 p; uniform mat4 m; uniform float size;" +
    "void main() { gl_Position = m * vec4(p, 1.0); gl_PointSize = size; }"));
  gl.attachShader(program, shader(gl.FRAGMENT_SHADER,
    "precision mediump float; uniform vec4 color; void main() { gl_FragColor = color; }"));
  gl.linkProgram(program);
  buffer = gl.createBuffer();
}
// The wrist frame (fingers along -Z, back of the hand +Y) seen from above the back of the hand,
// fingers up the screen, turning slowly about the hand's long axis; projected here, in the page
// (26 points), so the shader only places them.
function project(p, time) {
  const a = 0.6 * Math.sin(time * 0.0004), c = Math.cos(a), s = Math.sin(a);
  const x = c * p[0] + s * p[1], depth = -s * p[0] + c * p[1], y = -p[2] - 0.09;
  const w = 0.45 - depth, focal = 4.0, aspect = canvas.width / canvas.height;
  return [focal * x / w, focal * y * aspect / w * 0.85, 0];
}
function draw(joints, target) {
  if (!gl || (!joints && !target)) return;
  gl.viewport(0, 0, canvas.width, canvas.height);
  gl.clearColor(0.08, 0.09, 0.11, 1); gl.clear(gl.COLOR_BUFFER_BIT);
  gl.useProgram(program);
  const now = performance.now();
  gl.uniformMatrix4fv(gl.getUniformLocation(program, "m"), false, new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]));
  if (joints) joints = joints.map(p => project(p, now));
  if (target) target = target.map(p => project(p, now));
  const at = gl.getAttribLocation(program, "p");
  const put = (points, mode, size, color) => {
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(points), gl.STREAM_DRAW);
    gl.enableVertexAttribArray(at);
    gl.vertexAttribPointer(at, 3, gl.FLOAT, false, 0, 0);
    gl.uniform1f(gl.getUniformLocation(program, "size"), size);
    gl.uniform4fv(gl.getUniformLocation(program, "color"), color);
    gl.drawArrays(mode, 0, points.length / 3);
  };
  const bones = (js) => {
    const out = [];
    for (let j = 0; j < js.length; ++j) if (PARENT[j] >= 0) out.push(...js[j], ...js[PARENT[j]]);
    return out;
  };
  // Thick bones: each drawn a few times, shifted by a pixel (WebGL lines are one pixel wide).
  const thick = (js, color) => {
    for (const dx of [-0.004, -0.002, 0, 0.002, 0.004]) put(bones(js.map(p => [p[0] + dx, p[1], p[2]])), gl.LINES, 1, color);
  };
  if (target) { thick(target, [0.35, 0.6, 1.0, 1]); put(target.flat(), gl.POINTS, 7, [0.35, 0.6, 1.0, 1]); }
  if (joints) {
    thick(joints, [1.0, 0.55, 0.1, 1]);
    put(joints.flat(), gl.POINTS, 11, [1.0, 0.55, 0.1, 1]);
  }
  viewer.drawn += 1;
}
function show(state) {
  viewer.frames += 1;
  if (!state.active) {
    document.getElementById("status").textContent = `frames ${viewer.frames} seq none webgl ${viewer.webgl}`;
    document.getElementById("trust").textContent = state.calibrating ? "calibrating: no pose yet" : "waiting for the glove";
  } else {
    viewer.seq = state.seq; viewer.joints = state.joints;
    const trust = document.getElementById("trust");
    trust.className = state.trusted ? "good" : "bad";
    trust.textContent = (state.trusted ? "trusted" : "not trusted") + (state.flag_names.length ? ": " + state.flag_names.join(", ") : "");
    document.getElementById("latency").textContent =
      `compute ${state.compute_us.toFixed(1)} us, oldest reading ${state.oldest_age_ms.toFixed(1)} ms, pose ${state.age_ms.toFixed(1)} ms old`;
    const rows = state.dof_names.map((n, i) => `<tr><td>${n}</td><td>${(state.angles[i] * 57.29578).toFixed(1)}</td></tr>`);
    document.getElementById("angles").innerHTML = "<tr><td>angle</td><td>deg</td></tr>" + rows.join("");
    document.getElementById("status").textContent =
      `frames ${viewer.frames} seq ${state.seq} webgl ${viewer.webgl} tip ${state.joints[10].map(v => v.toFixed(4)).join(",")}`;
  }
  document.getElementById("step").textContent = state.step_name ? `step ${state.step + 1}: ${state.step_name}: ${state.instruction}` : "";
  // What the glove's stream said: lines not understood, sensors the calibration reads as 0.
  const notes = [];
  if (state.skipped) notes.push(`${state.skipped} of ${state.lines} lines not understood (the first: ${state.first_skipped})`);
  if (state.zeroed) notes.push(`calibration: ${state.zeroed}`);
  document.getElementById("notes").textContent = notes.join("\n");
  draw(state.joints, state.target_joints);
}
async function poll() {
  try {
    const response = await fetch("/state", { cache: "no-store" });
    show(await response.json());
  } catch (e) {
    document.getElementById("trust").textContent = "the tool stopped";
  }
  setTimeout(poll, 33);
}
poll();
</script></body></html>
)PAGE";

}  // namespace glovepose::cli
