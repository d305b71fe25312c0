// The phone page: DeviceMotion + Geolocation -> 20 Hz samples -> WebSocket batches (resent until acknowledged),
// and the same pipeline run locally so labels and warnings go on when the connection drops.
// One batch is in flight at a time and a batch holds at most MAX_BATCH_SECONDS of samples, so the backlog of a
// disconnect goes in order and in paced chunks; a batch refused for the rate (429) is sent again when the server
// says. A batch goes every BATCH_SECONDS of samples, or at once when the page's own classifier raises a warning
// (its labels equal the server's), so that the sample that warns does not wait for the rest of its batch. The page
// shows its own labels and warnings at once; the server's acknowledgement brings speed, distance and time to the
// destination. A batch a second, not four: the server's cost is mostly per message (benchmarks/serve_load.py).
"use strict";

const $ = (id) => document.getElementById(id);
const BATCH_SECONDS = 1, MAX_BATCH_SECONDS = 10;
const state = {
  spec: null, pipeline: null, warner: null, resampler: null, socket: null, rideId: null, token: null, origin: null,
  queue: [], seq: 0, inFlight: null, retryTimer: null, fix: null, lastSent: -Infinity, online: false, urgent: false,
  localLabels: [], serverLabels: [], times: [], warnings: [], localWarnings: [], batchEnds: [], previousRides: [],
};

class Warner {
  // the server's debouncing (spotfree.ride.assistant) for the warnings shown while offline: a dangerous label
  // warns once it has held minDuration s; its episode goes on while runs that hold come within refractory s
  constructor(rule) {
    this.rule = rule;
    this.run = {};
    this.episode = {};
  }

  update(t, label) {
    const tol = 1e-6;
    let warned = null;
    for (const kind of this.rule.dangerous) {
      if (label === kind) {
        if (this.run[kind] === undefined) this.run[kind] = t;
        if (t - this.run[kind] < this.rule.min_duration - tol) continue;
        if (this.episode[kind] !== undefined) { this.episode[kind] = t; continue; }
        this.episode[kind] = t;
        warned = warned || kind;
      } else {
        delete this.run[kind];
        if (this.episode[kind] !== undefined && t - this.episode[kind] > this.rule.refractory + tol) delete this.episode[kind];
      }
    }
    return warned;
  }
}

async function deviceToken() {
  // the device's token, kept by the browser; the first time, got with the operator's enrolment code
  let token = localStorage.getItem("spotfree-token");
  if (!token) {
    const r = await fetch("/api/devices", {
      method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ name: navigator.userAgent.slice(0, 90), code: $("code").value.trim() }),
    });
    const answer = await r.json();
    if (!r.ok) throw new Error(answer.detail || `enrolment refused (${r.status})`);
    token = answer.token;
    localStorage.setItem("spotfree-token", token);
    $("enrol").hidden = true;
  }
  return token;
}

function show(label, warning) {
  $("label").textContent = label || "–";
  $("label").style.color = labelColour(label);
  if (warning) {
    $("banner").textContent = warning.toUpperCase().replace("-", " ");
    $("banner").classList.add("on");
    clearTimeout(show.timer);
    show.timer = setTimeout(() => $("banner").classList.remove("on"), 4000);
  }
}

function showMount(mount) {
  // what the page's mount tracker has found (the server records the same: spotfree.signal.mount.MountTracker)
  if (mount.stage === showMount.stage) return;
  showMount.stage = mount.stage;
  const angle = (mount.angle * 180 / Math.PI).toFixed(0);
  const used = mount.angle > mount.p.usual_angle ? "unusual: features use it" : "usual: the nominal mount is used";
  $("mount").textContent = `mount: ${angle}° from flat with the top edge forward (${used})`
    + (mount.stage === "vertical" ? "; forward assumed (top edge or back) until the GPS speed tells" : "");
}

function setOnline(on) {
  state.online = on;
  $("link").textContent = on ? "online" : "offline: classifying on the phone";
  $("link").className = "badge " + (on ? "online" : "offline");
}

function sample(t, acc, gyr) {
  // one 20 Hz sample: classify locally, queue for the server
  const fix = state.fix;
  state.fix = null;
  const row = [t, ...acc, ...gyr, fix ? fix.lat : null, fix ? fix.lon : null, fix ? fix.speed : null];
  const out = state.pipeline.update(t, acc, gyr, fix && fix.speed !== null ? fix.speed : NaN);
  showMount(state.pipeline.mount);
  state.localLabels.push(out.label);
  state.times.push(t);
  const warn = state.warner.update(t, out.label);
  if (warn) {
    state.localWarnings.push({ kind: warn, time: t });
    state.urgent = true;
  }
  // the page's labels and warnings equal the server's: shown at once, not a batch later
  show(out.label, warn);
  if (!state.online && fix && fix.speed !== null) $("speed").textContent = kmh(fix.speed);
  state.queue.push(row);
  if (due()) flush();
}

function due() {
  return state.queue.length > 0
    && (state.urgent || state.queue[state.queue.length - 1][0] - state.lastSent >= BATCH_SECONDS);
}

function flush() {
  if (!state.online || state.inFlight !== null || state.retryTimer !== null || !state.queue.length) return;
  const t0 = state.queue[0][0];
  let n = 0;
  while (n < state.queue.length && state.queue[n][0] - t0 < MAX_BATCH_SECONDS) n++;
  const rows = state.queue.slice(0, n);
  const cols = ["time", "ax", "ay", "az", "gx", "gy", "gz", "lat", "lon", "speed"];
  const samples = {};
  cols.forEach((c, j) => { samples[c] = rows.map((r) => r[j]); });
  state.seq += 1;
  state.inFlight = { seq: state.seq, n };
  state.socket.send(JSON.stringify({ type: "batch", seq: state.seq, samples }));
  state.lastSent = rows[n - 1][0];
  state.batchEnds.push(state.lastSent);
  state.urgent = false;
}

function onReply(msg) {
  if (msg.type === "started" || msg.type === "resumed") {
    state.rideId = msg.ride_id;
    sessionStorage.setItem("spotfree-ride", msg.ride_id);
    if (msg.type === "resumed" && msg.last_time !== null) {
      state.queue = state.queue.filter((r) => r[0] > msg.last_time);
    }
    state.inFlight = null;
    setOnline(true);
    $("status").textContent = `ride ${msg.ride_id.slice(0, 8)}: streaming`;
    flush();
  } else if (msg.type === "ack") {
    state.queue.splice(0, state.inFlight ? state.inFlight.n : msg.count);
    state.inFlight = null;
    state.serverLabels.push(...msg.labels);
    state.warnings.push(...msg.warnings);
    if (msg.warnings.length) show(msg.labels[msg.labels.length - 1], msg.warnings[msg.warnings.length - 1].kind);
    const s = msg.state || {};
    $("speed").textContent = kmh(s.speed);
    $("distance").textContent = km(s.distance);
    $("eta").textContent = minutes(s.eta);
    if (due()) flush();
  } else if (msg.type === "destination") {
    $("status").textContent = "destination set";
  } else if (msg.type === "error") {
    $("status").textContent = `server refused: ${msg.message}`;
    if (!state.online && state.rideId && (msg.status === 403 || msg.status === 404)) {
      // the ride cannot be resumed (it ended, or was closed while the phone was away): go on in a new ride
      // with every sample still held, linked to the old one (the server keeps the link: continues_from)
      state.previousRides.push(state.rideId);
      state.rideId = null;
      sessionStorage.removeItem("spotfree-ride");
      state.socket.send(JSON.stringify({ type: "start", token: state.token, ...rideMeta(),
        continues_from: state.previousRides[state.previousRides.length - 1] }));
      return;
    }
    if (msg.seq !== null && msg.seq !== undefined && state.inFlight && msg.seq === state.inFlight.seq) {
      const n = state.inFlight.n;
      state.inFlight = null;
      if (msg.status === 429 || msg.status === 503) {
        // too fast: the same rows again when the server can take them
        state.retryTimer = setTimeout(() => { state.retryTimer = null; flush(); }, 1000 * msg.retry_after + 10);
      } else {
        // a refused batch changed nothing on the server; drop it so the stream goes on
        state.queue.splice(0, n);
        flush();
      }
    }
  }
}

function rideMeta() {
  return { vehicle: $("vehicle").value, rider_id: $("rider").value, age_band: $("age_band").value || null,
    skill: $("skill").value || null };
}

function connect() {
  const socket = new WebSocket(wsUrl("/ws/ride"));
  state.socket = socket;
  state.inFlight = null;
  socket.onopen = () => {
    socket.send(JSON.stringify(state.rideId ? { type: "resume", token: state.token, ride_id: state.rideId }
      : { type: "start", token: state.token, ...rideMeta() }));
  };
  socket.onmessage = (ev) => onReply(JSON.parse(ev.data));
  socket.onclose = () => { setOnline(false); setTimeout(connect, 1000); };
}

function onMotion(ev) {
  const a = ev.accelerationIncludingGravity, r = ev.rotationRate;
  if (!a || !r || a.x === null) return;
  const now = ev.timeStamp / 1000;
  if (state.origin === null) state.origin = now;
  const deg = Math.PI / 180;
  // DeviceMotion: m/s^2 (gravity included) and deg/s about x (beta), y (gamma), z (alpha), device frame
  const values = [a.x, a.y, a.z, r.beta * deg, r.gamma * deg, r.alpha * deg];
  for (const row of state.resampler.add(now - state.origin, values)) sample(row[0], row.slice(1, 4), row.slice(4, 7));
}

function onPosition(p) {
  const speed = p.coords.speed === null || p.coords.speed < 0 ? null : p.coords.speed;
  state.fix = { lat: p.coords.latitude, lon: p.coords.longitude, speed };
}

async function start() {
  // iOS asks for motion permission only from a tap
  if (typeof DeviceMotionEvent !== "undefined" && typeof DeviceMotionEvent.requestPermission === "function") {
    const answer = await DeviceMotionEvent.requestPermission();
    if (answer !== "granted") { $("status").textContent = "motion permission refused"; return; }
  }
  try {
    state.token = await deviceToken();
  } catch (e) {
    $("status").textContent = e.message;
    return;
  }
  window.addEventListener("devicemotion", onMotion);
  if (navigator.geolocation) {
    navigator.geolocation.watchPosition(onPosition, (e) => { $("status").textContent = `location: ${e.message}`; },
      { enableHighAccuracy: true, maximumAge: 0 });
  }
  $("setup").hidden = true;
  connect();
}

function setDestination() {
  const parts = $("dest").value.split(",").map(Number);
  if (parts.length !== 2 || !parts.every(Number.isFinite)) { $("status").textContent = "destination: give lat, lon"; return; }
  if (state.online) state.socket.send(JSON.stringify({ type: "destination", lat: parts[0], lon: parts[1] }));
}

async function init() {
  if (!window.isSecureContext) $("secure").hidden = false;
  $("enrol").hidden = Boolean(localStorage.getItem("spotfree-token"));
  state.spec = await (await fetch("/api/model")).json();
  state.pipeline = new spotfreePipeline.Pipeline(state.spec);
  state.warner = new Warner(state.spec.warnings);
  state.resampler = new spotfreePipeline.Resampler(state.spec.rate);
  $("start").onclick = start;
  $("setdest").onclick = setDestination;
}

window.spotfree = { state, start, sample };
init();
