// Operator view: live plot of pitch, pitch rate and longitudinal acceleration coloured by label; the track as
// an SVG polyline in local metres (equirectangular about the first fix) with a scale bar; events; past rides.
"use strict";

const $ = (id) => document.getElementById(id);
const WINDOW_S = 30, R_EARTH = 6371008.8, DEG = Math.PI / 180;
const PANELS = [["pitch", "pitch (deg)", 1 / DEG], ["pitch_rate", "pitch rate (deg/s)", 1 / DEG],
  ["acc_long", "acc long (m/s²)", 1]];
const view = { rideId: null, t: [], labels: [], pitch: [], pitch_rate: [], acc_long: [], track: [], events: [],
  origin: null, replaying: false, token: null };

function reset(rideId) {
  Object.assign(view, { rideId, t: [], labels: [], pitch: [], pitch_rate: [], acc_long: [], track: [], events: [],
    origin: null });
  $("ride").textContent = rideId ? `ride ${rideId.slice(0, 8)}` : "";
  $("events").innerHTML = "";
}

function append(msg) {
  for (let k = 0; k < msg.time.length; k++) {
    view.t.push(msg.time[k]);
    view.labels.push(msg.labels[k]);
    for (const [name] of PANELS) view[name].push(msg[name][k]);
    if (msg.lat[k] !== null && msg.lon[k] !== null) view.track.push([msg.lat[k], msg.lon[k], msg.labels[k]]);
  }
  const keep = view.t.length - WINDOW_S * 40;
  if (keep > 0) for (const key of ["t", "labels", "pitch", "pitch_rate", "acc_long"]) view[key].splice(0, keep);
  for (const w of msg.warnings || []) addEvent(w.kind, w.onset, null, `warned at ${w.time.toFixed(2)} s`);
  for (const e of msg.events || []) addEvent(e.kind, e.start, e.end, e.detail);
}

function addEvent(kind, start, end, detail) {
  // one line per episode (kind and onset): shown when the rider is warned, its duration added when it ends
  const key = `${kind}@${start.toFixed(3)}`;
  let li = [...$("events").children].find((item) => item.dataset.key === key);
  if (!li) {
    li = document.createElement("li");
    li.dataset.key = key;
    $("events").prepend(li);
  }
  const span = end === null ? "ongoing" : `${(end - start).toFixed(1)} s`;
  li.dataset.kind = kind;
  if (end === null) li.dataset.note = detail || "";
  const swatch = document.createElement("i"), name = document.createElement("b");
  swatch.className = "swatch";
  swatch.style.background = labelColour(kind);
  name.textContent = kind;
  li.replaceChildren(swatch, `${start.toFixed(1)} s `, name, ` ${span} ${detail || li.dataset.note || ""}`);
}

function drawPlot() {
  const canvas = $("plot"), ctx = canvas.getContext("2d"), W = canvas.width, H = canvas.height;
  ctx.clearRect(0, 0, W, H);
  if (!view.t.length) return;
  const t1 = view.t[view.t.length - 1], t0 = t1 - WINDOW_S, ph = H / PANELS.length, left = 60;
  ctx.font = "13px system-ui";
  PANELS.forEach(([name, title, factor], p) => {
    const top = p * ph + 6, h = ph - 18;
    const values = view[name].map((v) => (v === null ? null : v * factor));
    const finite = values.filter((v) => v !== null);
    let lo = Math.min(...finite, -0.1), hi = Math.max(...finite, 0.1);
    const pad = (hi - lo) * 0.1; lo -= pad; hi += pad;
    const y = (v) => top + h - ((v - lo) / (hi - lo)) * h;
    const x = (t) => left + ((t - t0) / WINDOW_S) * (W - left - 8);
    ctx.strokeStyle = "#2a323a"; ctx.beginPath(); ctx.moveTo(left, y(0)); ctx.lineTo(W - 8, y(0)); ctx.stroke();
    ctx.fillStyle = "#9aa4ad"; ctx.fillText(title, 4, top + 12);
    ctx.fillText(hi.toFixed(1), 4, top + 28); ctx.fillText(lo.toFixed(1), 4, top + h);
    ctx.lineWidth = 2;
    for (let k = 1; k < values.length; k++) {
      if (values[k] === null || values[k - 1] === null || view.t[k] < t0) continue;
      ctx.strokeStyle = labelColour(view.labels[k]);
      ctx.beginPath(); ctx.moveTo(x(view.t[k - 1]), y(values[k - 1])); ctx.lineTo(x(view.t[k]), y(values[k])); ctx.stroke();
    }
  });
}

function niceLength(metres) {
  const p = Math.pow(10, Math.floor(Math.log10(metres)));
  return [1, 2, 5, 10].map((m) => m * p).filter((v) => v <= metres).pop();
}

function drawTrack() {
  const svg = $("track"), W = 600, H = 400, pad = 20;
  if (view.track.length < 2) { svg.innerHTML = ""; return; }
  const [lat0, lon0] = view.track[0];
  const pts = view.track.map(([lat, lon, label]) => [R_EARTH * (lon - lon0) * DEG * Math.cos(lat0 * DEG),
    R_EARTH * (lat - lat0) * DEG, label]);
  const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
  const minX = Math.min(...xs), maxX = Math.max(...xs), minY = Math.min(...ys), maxY = Math.max(...ys);
  const span = Math.max(maxX - minX, maxY - minY, 10);
  const s = Math.min(W - 2 * pad, H - 2 * pad - 30) / span;
  const px = (p) => [pad + (p[0] - minX) * s, H - pad - 30 - (p[1] - minY) * s];
  let out = "";
  for (let k = 1; k < pts.length; k++) {
    const [x0, y0] = px(pts[k - 1]), [x1, y1] = px(pts[k]);
    out += `<line x1="${x0.toFixed(1)}" y1="${y0.toFixed(1)}" x2="${x1.toFixed(1)}" y2="${y1.toFixed(1)}" stroke="${labelColour(pts[k][2])}" stroke-width="4" stroke-linecap="round"/>`;
  }
  const [sx, sy] = px(pts[0]), [ex, ey] = px(pts[pts.length - 1]);
  out += `<circle cx="${sx}" cy="${sy}" r="6" fill="#fff"/><circle cx="${ex}" cy="${ey}" r="7" fill="#3a86ff"/>`;
  const bar = niceLength(span / 3), barPx = bar * s;
  out += `<g id="scalebar"><line x1="${pad}" y1="${H - 12}" x2="${pad + barPx}" y2="${H - 12}" stroke="#fff" stroke-width="3"/>` +
    `<text x="${pad + barPx + 8}" y="${H - 7}" fill="#fff" font-size="14">${bar >= 1000 ? bar / 1000 + " km" : bar + " m"}</text></g>`;
  svg.innerHTML = out;
  svg.dataset.points = String(pts.length);
}

function draw() { drawPlot(); drawTrack(); requestAnimationFrame(draw); }

async function listRides() {
  const rides = await getJson("/api/rides", view.token);
  $("rides").innerHTML = "";
  for (const r of rides.slice(0, 50)) {
    // text from devices (vehicle, rider id) goes in as text, never as markup
    const li = document.createElement("li"), a = document.createElement("a");
    a.href = "#";
    a.dataset.ride = r.ride_id;
    a.textContent = new Date(r.started * 1000).toLocaleString();
    a.onclick = (ev) => { ev.preventDefault(); replay(r.ride_id); };
    li.append(a, ` ${r.vehicle} / ${r.rider_id}`);
    if (r.live) { const b = document.createElement("b"); b.textContent = " live"; li.append(b); }
    $("rides").append(li);
  }
}

async function replay(rideId) {
  // a recorded ride played back at 10x from the store
  const data = await getJson(`/api/rides/${encodeURIComponent(rideId)}`, view.token);
  view.replaying = true;
  reset(rideId);
  const s = data.samples, f = data.features, labels = data.labels[data.model] || [];
  const step = 20;
  for (let k = 0; k < s.time.length; k += step) {
    const idx = [...Array(Math.min(step, s.time.length - k)).keys()].map((i) => i + k);
    append({ time: idx.map((i) => s.time[i]), lat: idx.map((i) => s.lat[i]), lon: idx.map((i) => s.lon[i]),
      pitch: idx.map((i) => f.pitch[i]), pitch_rate: idx.map((i) => f.pitch_rate[i]),
      acc_long: idx.map((i) => f.acc_long[i]), labels: idx.map((i) => labels[i]), warnings: [] });
    for (const e of data.events) if (e.start >= s.time[k] && e.start < s.time[idx[idx.length - 1]] + 1e-9) addEvent(e.kind, e.start, e.end, e.detail);
    await new Promise((r) => setTimeout(r, 100));
  }
  view.replaying = false;
}

async function enrolmentCode() {
  // a code for the next device to enrol with (one device, valid for an hour)
  try {
    const answer = await getJson("/api/enrolments", view.token, { method: "POST", body: JSON.stringify({ uses: 1, ttl: 3600 }) });
    $("code").textContent = `${answer.code} (one device, until ${new Date(answer.expires * 1000).toLocaleTimeString()})`;
  } catch (e) {
    $("code").textContent = e.message;
  }
}

function signIn() {
  // the operator token is kept for this tab only
  const token = $("optoken").value.trim();
  if (!token) return;
  sessionStorage.setItem("spotfree-operator", token);
  $("signin").hidden = true;
  start(token);
}

async function init() {
  const spec = await (await fetch("/api/model")).json();
  legend($("legend"), spec.classes);
  $("signinbtn").onclick = signIn;
  $("enrolbtn").onclick = enrolmentCode;
  const token = sessionStorage.getItem("spotfree-operator");
  if (token) { $("signin").hidden = true; await start(token); }
}

async function start(token) {
  view.token = token;
  try {
    await listRides();
  } catch (e) {
    sessionStorage.removeItem("spotfree-operator");
    $("signin").hidden = false;
    $("signinmsg").textContent = e.message;
    return;
  }
  const wanted = new URLSearchParams(location.search).get("ride");
  if (wanted) await replay(wanted);
  watch("/ws/watch", token, (msg) => {
    if (view.replaying) return;
    if (msg.type === "ride") listRides();
    if (msg.type === "end" && msg.ride_id === view.rideId) for (const e of msg.events) addEvent(e.kind, e.start, e.end, e.detail);
    if (msg.type !== "samples") return;
    if (msg.ride_id !== view.rideId) reset(msg.ride_id);
    append(msg);
  }, (on) => { $("link").textContent = on ? "live" : "reconnecting"; $("link").className = "badge " + (on ? "online" : "offline"); });
  requestAnimationFrame(draw);
}

window.spotfreeOperator = { view, replay };
init();
