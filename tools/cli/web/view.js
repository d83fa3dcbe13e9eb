// glovepose view's page script: the hand as the hand model's spheres and capsules (three.js), the
// truth and the calibration target beside it, the maps, pinch state, traces and angles. The tool
// pushes the state (GET /events, Server-Sent Events): first a "meta" event (geometry, names, map
// layouts), then the newest hand about 30 times a second. The page derives no geometry: joint
// positions and radii (millimetres, the OpenXR wrist frame) come from the tool.
import * as THREE from "three";
import { OrbitControls } from "/OrbitControls.js";

const FINGERS = ["thumb", "index", "middle", "ring", "pinky"];
const PINCH_PAIRS = ["index", "middle", "ring", "little"];
const TRACE_SECONDS = 8;
const TRACE_COLOURS = ["#ffcf6b", "#ff8a7a", "#7df0a0", "#6cc3ff", "#d59bff"];
// Flags that do not make a pose untrusted, said as what they mean.
const FLAG_TEXT = {
  "input clamped": "some sensors read beyond the calibrated range (clamped)",
  "training calibration": "using the training set's calibration, not this user's",
  "calibrating": "calibration running: poses from the previous calibration",
};

// The page's own account, for tests: frames received, pose sequence, draws; `paused` holds the
// drawing at the current state and only(name) shows one of the hands (both for comparing screenshots).
const viewer = { frames: 0, seq: -1, webgl: false, drawn: 0, meta: null, state: null, mapSum: 0, paused: false };
viewer.only = (name) => {
  for (const [key, hand] of Object.entries(viewer.hands)) hand.group.visible = (name === null || key === name) && hand.shown;
  viewer.hands.truth.palmGroup.visible = name === "truth" || !viewer.hands.estimate.shown;
};
window.viewer = viewer;
const $ = (id) => document.getElementById(id);
// A pose map row's finger: the first word of its DoFs' names.
const rowName = (names) => (names.find((n) => n) || "").split("_")[0];
const readable = (name) => { const s = name.replace(/_/g, " "); return s.charAt(0).toUpperCase() + s.slice(1); };

// ---- the 3D hand -------------------------------------------------------------------------------
const canvas = $("hand");
let renderer = null;
try {
  renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  viewer.webgl = true;
} catch (e) {
  $("trust").textContent = "WebGL is not available in this browser: " + e.message;
}
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x15171c);
scene.add(new THREE.HemisphereLight(0xdde6ff, 0x2a2420, 0.9));
const sun = new THREE.DirectionalLight(0xffffff, 1.3);
sun.position.set(120, 260, 80);
scene.add(sun);
const fill = new THREE.DirectionalLight(0xa0b8ff, 0.5);
fill.position.set(-150, -120, -60);
scene.add(fill);
// The wrist frame: fingers along -Z, back of the hand +Y. Seen from above the back of the hand,
// fingers up the screen; the orbit turns about the hand's long axis.
const camera = new THREE.PerspectiveCamera(34, canvas.width / canvas.height, 5, 3000);
camera.up.set(0, 0, -1);
camera.position.set(115, 245, 25);
const controls = renderer ? new OrbitControls(camera, canvas) : null;
const centre = new THREE.Vector3(0, -10, -62);
if (controls) { controls.target.copy(centre); controls.enableDamping = true; controls.update(); }
camera.lookAt(centre);

const sphereGeometry = new THREE.SphereGeometry(1, 28, 18);
// The joints no angle moves (OpenXR order): palm, wrist, the four fingers' metacarpal and proximal joints.
const RIGID = new Set([0, 1, 6, 7, 11, 12, 16, 17, 21, 22]);
const yAxis = new THREE.Vector3(0, 1, 0);

// A hand of one material: a sphere per joint (its radius), a tapered capsule per bone (the two
// joints' spheres joined by a truncated cone), and the palm filled between its joints' spheres.
class HandMesh {
  constructor(meta, material) {
    this.group = new THREE.Group();
    this.material = material;
    this.parents = meta.parents;
    this.radii = meta.radii_mm;
    // The palm's parts (no DoF moves them: the palm, wrist, metacarpal and knuckle joints) in a
    // group of their own: the truth's coincide with the estimate's, and are hidden when both are shown.
    this.palmGroup = new THREE.Group();
    this.group.add(this.palmGroup);
    const part = (j) => (RIGID.has(j) ? this.palmGroup : this.group);
    this.spheres = this.radii.map((r, j) => {
      const m = new THREE.Mesh(sphereGeometry, material);
      m.scale.setScalar(r);
      part(j).add(m);
      return m;
    });
    // Bones: each joint to its parent (not the palm joint, which sits inside the palm), and the palm's
    // links between neighbouring metacarpals and knuckles.
    this.links = [];
    this.parents.forEach((p, j) => { if (p >= 0 && j !== 0) this.links.push([j, p]); });
    for (const [a, b] of [[6, 11], [11, 16], [16, 21], [7, 12], [12, 17], [17, 22], [2, 6], [3, 7]]) this.links.push([a, b]);
    this.capsules = this.links.map(([a, b]) => {
      const m = new THREE.Mesh(new THREE.CylinderGeometry(this.radii[a], this.radii[b], 1, 28, 1, true), material);
      (RIGID.has(a) && RIGID.has(b) ? this.palmGroup : this.group).add(m);
      return m;
    });
    this.palm = null;
    scene.add(this.group);
  }
  // The palm's slab: the outline wrist - index metacarpal - knuckles - little metacarpal, as a top and
  // a bottom face half the palm joint's thickness off the palm plane, with its sides.
  makePalm(joints) {
    const ring = [1, 6, 7, 12, 17, 22, 21].map((j) => new THREE.Vector3(...joints[j]));
    const normal = new THREE.Vector3().subVectors(ring[1], ring[0]).cross(new THREE.Vector3().subVectors(ring[6], ring[0])).normalize();
    if (normal.y < 0) normal.negate();
    const half = this.radii[0];  // the palm joint's radius: the palm's half thickness there
    const points = [];
    for (const side of [1, -1]) for (const v of ring) points.push(v.clone().addScaledVector(normal, side * half));
    const n = ring.length, index = [];
    for (let i = 1; i + 1 < n; ++i) { index.push(0, i, i + 1); index.push(n, n + i + 1, n + i); }
    for (let i = 0; i < n; ++i) { const k = (i + 1) % n; index.push(i, k, n + k, i, n + k, n + i); }
    const geometry = new THREE.BufferGeometry().setFromPoints(points);
    geometry.setIndex(index);
    geometry.computeVertexNormals();
    const material = this.material.clone();
    material.side = THREE.DoubleSide;
    this.palm = new THREE.Mesh(geometry, material);
    this.palmGroup.add(this.palm);
  }
  set(joints) {
    this.shown = !!joints;
    this.group.visible = this.shown;
    if (!joints) return;
    if (!this.palm) this.makePalm(joints);  // the palm is rigid: no DoF moves its joints
    joints.forEach((p, j) => this.spheres[j].position.set(p[0], p[1], p[2]));
    const a = new THREE.Vector3(), b = new THREE.Vector3(), d = new THREE.Vector3();
    this.links.forEach(([i, k], n) => {
      a.set(...joints[i]); b.set(...joints[k]);
      d.subVectors(a, b);
      const m = this.capsules[n];
      m.position.addVectors(a, b).multiplyScalar(0.5);
      m.scale.set(1, Math.max(d.length(), 1e-3), 1);
      m.quaternion.setFromUnitVectors(yAxis, d.normalize());
    });
  }
}

const materials = {
  estimate: new THREE.MeshStandardMaterial({ color: 0xe3a07c, roughness: 0.55, metalness: 0.05 }),
  truth: new THREE.MeshStandardMaterial({ color: 0x4fc3f7, roughness: 0.4, transparent: true, opacity: 0.4, depthWrite: false }),
  target: new THREE.MeshStandardMaterial({ color: 0xa58bff, roughness: 0.5, transparent: true, opacity: 0.45, depthWrite: false }),
};
let hands = null;

// Projected joints (canvas pixels) of a hand, for the page's own report (tests read it).
function project(joints) {
  if (!joints) return null;
  return joints.map((p) => {
    const v = new THREE.Vector3(...p).project(camera);
    return [Math.round((v.x + 1) * canvas.width / 2), Math.round((1 - v.y) * canvas.height / 2)];
  });
}

function render() {
  requestAnimationFrame(render);
  if (!renderer) return;
  if (controls) controls.update();
  renderer.render(scene, camera);
  viewer.drawn += 1;
}

// ---- heat maps ------------------------------------------------------------------------------------
// Diverging: -1 blue, 0 dark grey, +1 orange-red.
function heat(v) {
  const t = Math.max(-1, Math.min(1, v));
  const base = [48, 52, 60], hi = t >= 0 ? [255, 120, 60] : [70, 150, 255], a = Math.abs(t);
  return `rgb(${base.map((c, i) => Math.round(c + (hi[i] - c) * a)).join(",")})`;
}
function drawMap(id, values, names, rowLabels) {
  const c = $(id), g = c.getContext("2d");
  const left = rowLabels ? 42 : 0, size = Math.floor((c.width - left) / 5);
  g.fillStyle = "#15171c"; g.fillRect(0, 0, c.width, c.height);
  g.font = "10px system-ui"; g.textAlign = "center"; g.textBaseline = "middle";
  for (let r = 0; r < 5; ++r) {
    if (rowLabels) { g.fillStyle = "#8a93a3"; g.textAlign = "right"; g.fillText(rowLabels[r], left - 3, r * size + size / 2); g.textAlign = "center"; }
    for (let k = 0; k < 5; ++k) {
      const x = left + k * size, y = r * size;
      if (!names || names[r][k] === null) { g.fillStyle = "#1e2128"; g.fillRect(x + 1, y + 1, size - 2, size - 2); continue; }
      const v = values ? values[r][k] : 0;
      g.fillStyle = values ? heat(v) : "#30343c"; g.fillRect(x + 1, y + 1, size - 2, size - 2);
      if (values) { g.fillStyle = Math.abs(v) > 0.55 ? "#111" : "#d8dde6"; g.fillText(v.toFixed(2), x + size / 2, y + size / 2); }
    }
  }
}
function mapTitles(id, names) {
  $(id).onmousemove = (e) => {
    const c = $(id), left = id === "mapPose" ? 42 : 0, size = Math.floor((c.width - left) / 5);
    const k = Math.floor((e.offsetX - left) / size), r = Math.floor(e.offsetY / size);
    c.title = r >= 0 && r < 5 && k >= 0 && k < 5 && names[r][k] ? readable(names[r][k]) : "";
  };
}

// ---- traces ---------------------------------------------------------------------------------------
const history = [];  // {t, est: [deg], truth: [deg] | null}
function drawTraces() {
  const c = $("traces"), g = c.getContext("2d"), meta = viewer.meta;
  g.fillStyle = "#1a1d23"; g.fillRect(0, 0, c.width, c.height);
  if (!meta || history.length < 2) return;
  const finger = Number($("traceFinger").value);
  const dofs = meta.dof_fingers.map((f, d) => (f === finger ? d : -1)).filter((d) => d >= 0);
  const now = history[history.length - 1].t, left = 34, w = c.width - left - 120, h = c.height - 16;
  let lo = -20, hi = 100;
  for (const s of history) for (const d of dofs) { lo = Math.min(lo, s.est[d]); hi = Math.max(hi, s.est[d]); }
  const x = (t) => left + w * (1 - (now - t) / TRACE_SECONDS), y = (v) => 6 + h * (hi - v) / (hi - lo);
  g.strokeStyle = "#2c313a"; g.fillStyle = "#8a93a3"; g.font = "10px system-ui"; g.textAlign = "right";
  for (let v = Math.ceil(lo / 30) * 30; v <= hi; v += 30) {
    g.beginPath(); g.moveTo(left, y(v)); g.lineTo(left + w, y(v)); g.stroke(); g.fillText(`${v}°`, left - 4, y(v) + 3);
  }
  g.textAlign = "left";
  dofs.forEach((d, i) => {
    g.strokeStyle = TRACE_COLOURS[i]; g.lineWidth = 1.6;
    for (const key of ["est", "truth"]) {
      g.setLineDash(key === "truth" ? [4, 3] : []);
      g.beginPath();
      let first = true;
      for (const s of history) {
        if (!s[key] || now - s.t > TRACE_SECONDS) continue;
        if (first) g.moveTo(x(s.t), y(s[key][d])); else g.lineTo(x(s.t), y(s[key][d]));
        first = false;
      }
      g.stroke();
    }
    g.setLineDash([]);
    g.fillStyle = TRACE_COLOURS[i];
    g.fillText(readable(meta.dof_names[d].replace(FINGERS[finger] + "_", "")), left + w + 8, 14 + 16 * i);
  });
}

// ---- the state ------------------------------------------------------------------------------------
function onMeta(meta) {
  viewer.meta = meta;
  // A reconnect (the tool restarted) sends the meta event again: the new hand replaces the old.
  if (hands) for (const hand of Object.values(hands)) scene.remove(hand.group);
  history.length = 0;
  hands = { estimate: new HandMesh(meta, materials.estimate), truth: new HandMesh(meta, materials.truth), target: new HandMesh(meta, materials.target) };
  hands.truth.group.renderOrder = 1; hands.target.group.renderOrder = 2;
  viewer.hands = hands;
  $("source").textContent = `${meta.source} · glove ${meta.glove} · ${meta.side} hand · events at ${Math.round(meta.event_hz)} Hz`;
  $("legendTruth").hidden = !meta.has_truth;
  $("truthNote").hidden = !meta.has_truth;
  const select = $("traceFinger");
  if (!select.options.length) {
    FINGERS.forEach((f, i) => select.add(new Option(readable(f), i)));
    select.value = 1;
  }
  mapTitles("mapAlong", meta.stretch_names[0]); mapTitles("mapAcross", meta.stretch_names[1]); mapTitles("mapPose", meta.pose_names);
  drawMap("mapAlong", null, meta.stretch_names[0]); drawMap("mapAcross", null, meta.stretch_names[1]);
  drawMap("mapPose", null, meta.pose_names, meta.pose_names.map(rowName));
}

function show(state) {
  const meta = viewer.meta;
  viewer.frames += 1;
  if (!meta || !hands || viewer.paused) return;
  viewer.state = state;
  hands.estimate.set(state.active ? state.joints : null);
  hands.truth.set(state.truth_joints);
  hands.target.set(state.target_joints);
  hands.truth.palmGroup.visible = !hands.estimate.shown;
  $("legendTarget").hidden = !state.target_joints;
  const step = state.step >= 0 && state.step_name
    ? `Calibration, step ${state.step + 1} of ${meta.steps.length}: ${state.instruction} (shown in violet)`
    : (state.calibrating ? `Calibration: move through your hand's extreme poses (${state.calibration_frames} frames so far)` : "");
  $("step").textContent = step;
  const notes = [];
  if (state.skipped) notes.push(`${state.skipped} of ${state.lines} lines not understood (the first: ${state.first_skipped})`);
  if (state.zeroed) notes.push(`calibration: ${state.zeroed}`);
  if (!state.active) {
    $("trust").textContent = state.preparing ? "simulating a new user of the glove (a few seconds)…"
      : state.calibrating ? "calibrating: no pose yet" : "waiting for the glove";
    $("trust").className = "dim";
    $("notes").textContent = notes.join("\n");
    report(state);
    return;
  }
  viewer.seq = state.seq;
  const faults = [], info = [];
  state.flag_names.forEach((name) => (FLAG_TEXT[name] ? info.push(FLAG_TEXT[name]) : faults.push(name)));
  $("trust").className = state.trusted ? "good" : "bad";
  $("trust").textContent = state.trusted ? "Pose trusted" : `Pose not trusted: ${faults.join(", ")}`;
  notes.push(...info);
  $("notes").textContent = notes.join("\n");
  $("latency").textContent =
    `pose #${state.seq} · computed in ${state.compute_us.toFixed(0)} µs · oldest reading ${state.oldest_age_ms.toFixed(1)} ms · shown ${state.age_ms.toFixed(0)} ms after`;
  if (state.stretch) {
    drawMap("mapAlong", state.stretch[0], meta.stretch_names[0]);
    drawMap("mapAcross", state.stretch[1], meta.stretch_names[1]);
    drawMap("mapPose", state.pose_map, meta.pose_names, meta.pose_names.map(rowName));
    viewer.mapSum = state.stretch.flat(2).reduce((a, b) => a + b, 0);
  }
  $("pinch").innerHTML = state.pinch.map((p, i) =>
    `<span>thumb–${PINCH_PAIRS[i]}</span><div class="bar"><div style="width:${(100 * p.strength).toFixed(0)}%"></div></div>` +
    `<span>${p.distance_mm === null ? "–" : p.distance_mm.toFixed(1) + " mm"}</span><span class="${p.pinching ? "pinching" : "dim"}">${p.pinching ? "pinching" : "open"}</span>`).join("");
  // The table laid out as the pose map: a finger per row, a motion per column.
  const rows = meta.pose_names.map((names, r) => {
    const cells = names.map((name) => {
      const d = meta.dof_names.indexOf(name);
      if (d < 0) return "<td></td>";
      const truth = state.truth_deg ? `<br><span class="truth">${state.truth_deg[d].toFixed(1)}°</span>` : "";
      // Shaded by how little the estimator trusts the angle: the chance it is off by more than 10°.
      const doubt = 1 - state.confidence[d];
      return `<td style="background:rgba(229,115,115,${(0.7 * doubt).toFixed(2)})" title="confidence ${(100 * state.confidence[d]).toFixed(0)}%">` +
        `${state.angles_deg[d].toFixed(1)}°${truth}</td>`;
    });
    return `<tr><td>${readable(rowName(names))}</td>${cells.join("")}</tr>`;
  });
  const motions = meta.pose_names[0].map((name) => (name ? name.replace(/^[a-z]+_/, "").replace(/_/g, " ") : ""));
  $("angles").innerHTML = `<tr><th></th>${motions.map((m) => `<th>${m}</th>`).join("")}</tr>` + rows.join("");
  history.push({ t: state.t, est: state.angles_deg, truth: state.truth_deg });
  while (history.length && state.t - history[0].t > TRACE_SECONDS + 0.5) history.shift();
  if (history.length && state.t < history[history.length - 1].t - 1) history.length = 0;  // the stream started over
  drawTraces();
  report(state);
}

// What the page shows, as numbers, for tests (Chromium's --dump-dom): frames received, the pose
// sequence, the projected joints of the estimate and of the truth (canvas pixels).
function report(state) {
  $("status").textContent = JSON.stringify({
    frames: viewer.frames, seq: viewer.seq, webgl: viewer.webgl, drawn: viewer.drawn, map_sum: viewer.mapSum,
    estimate_px: project(state.active ? state.joints : null), truth_px: project(state.truth_joints), target_px: project(state.target_joints),
  });
}

const events = new EventSource("/events");
events.addEventListener("meta", (e) => onMeta(JSON.parse(e.data)));
events.onmessage = (e) => show(JSON.parse(e.data));
events.onerror = () => { if (viewer.frames) { $("trust").textContent = "the tool stopped (the page reconnects when it is back)"; $("trust").className = "bad"; } };
render();
