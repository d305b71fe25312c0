"use strict";
// The rider view: follows one ride (?ride=ID) or, without it, the ride that last sent samples; with this
// browser's device token (the phone page's) it sees that device's rides, with the operator token every ride.
const $ = (id) => document.getElementById(id);
const wanted = new URLSearchParams(location.search).get("ride");
let current = wanted, timer = null;
const token = localStorage.getItem("spotfree-token") || sessionStorage.getItem("spotfree-operator");
if (!token) $("nocredential").hidden = false;
else watch("/ws/watch" + (wanted ? `?ride=${encodeURIComponent(wanted)}` : ""), token, (msg) => {
  if (msg.type !== "samples") return;
  if (!current) current = msg.ride_id;
  if (msg.ride_id !== current) return;
  $("ride").textContent = `ride ${current.slice(0, 8)}`;
  const label = msg.labels[msg.labels.length - 1];
  $("label").textContent = label || "–";
  $("label").style.color = labelColour(label);
  const s = msg.state || {};
  $("speed").textContent = kmh(s.speed);
  $("distance").textContent = km(s.distance);
  $("eta").textContent = minutes(s.eta);
  if (msg.warnings.length) {
    $("banner").textContent = msg.warnings[msg.warnings.length - 1].kind.toUpperCase().replace("-", " ");
    $("banner").classList.add("on");
    clearTimeout(timer);
    timer = setTimeout(() => $("banner").classList.remove("on"), 4000);
  }
}, (on, refused) => {
  $("link").textContent = on ? "live" : (refused || "reconnecting");
  $("link").className = "badge " + (on ? "online" : "offline");
});
