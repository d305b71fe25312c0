// Shared by the pages: label colours, number formats and a WebSocket that reconnects.
"use strict";

const LABEL_COLOURS = {
  "cruising": "#2e933c", "normal-braking": "#f49d37", "sudden-braking": "#d7263d",
  "straight": "#2e933c", "gentle-turn": "#3a86ff", "sharp-turn": "#d7263d", "slalom": "#8338ec",
  "unknown": "#9aa4ad", "mount": "#9aa4ad", "unusual-mount": "#f49d37", "uncertain-mount": "#f49d37",
};

function labelColour(label) {
  return label ? (LABEL_COLOURS[label] || "#8ecae6") : "#55606a";
}

function kmh(speed) { return speed === null || speed === undefined || !isFinite(speed) ? "–" : (speed * 3.6).toFixed(0); }
function km(metres) { return metres === null || metres === undefined ? "–" : (metres / 1000).toFixed(2); }
function minutes(seconds) {
  if (seconds === null || seconds === undefined || !isFinite(seconds)) return "–";
  const m = Math.floor(seconds / 60), s = Math.round(seconds % 60);
  return `${m}:${String(s).padStart(2, "0")}`;
}

function wsUrl(path) {
  return `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}${path}`;
}

function watch(path, token, onMessage, onState) {
  // a read-only subscription to the server's published messages, the credential sent as the first message
  // (never in the URL); reconnects after 1 s unless the server refused the credential (close code 1008)
  let socket = null;
  function open() {
    socket = new WebSocket(wsUrl(path));
    socket.onopen = () => { socket.send(JSON.stringify({ type: "auth", token })); onState && onState(true); };
    socket.onmessage = (ev) => onMessage(JSON.parse(ev.data));
    socket.onclose = (ev) => {
      onState && onState(false, ev.code === 1008 ? ev.reason : null);
      if (ev.code !== 1008) setTimeout(open, 1000);
    };
  }
  open();
  return () => socket;
}

async function getJson(path, token, options = {}) {
  // a call of the API with the credential in the Authorization header; an Error with the server's reason
  const headers = { Authorization: `Bearer ${token}`, ...(options.body ? { "Content-Type": "application/json" } : {}) };
  const r = await fetch(path, { ...options, headers });
  const answer = await r.json();
  if (!r.ok) throw new Error(answer.detail || `refused (${r.status})`);
  return answer;
}

function legend(element, classes) {
  element.innerHTML = classes.map((c) =>
    `<span><i class="swatch" style="background:${labelColour(c)}"></i>${c}</span>`).join("");
}
