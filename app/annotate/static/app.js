// seedtrack annotate: draws the clip and the tracks, turns clicks and keys into the server's edits.
// Image coordinates: x right, y down, pixels, pixel centres at integer coordinates.
"use strict";

const token = new URLSearchParams(location.search).get("token") || "";
const canvas = document.getElementById("view");
const context = canvas.getContext("2d");
const timeline = document.getElementById("timeline");
const timelineContext = timeline.getContext("2d");
const TRAIL = 8;            // past positions drawn behind each head, frames
const RING_PIXELS = 4;      // ring radius in image pixels, drawn at least MIN_RING on screen: the object inside stays visible
const MIN_RING = 7;
const SNAP = 10;            // a click this near a point (CSS pixels) means that point
const CACHED_FRAMES = 300;  // decoded pictures kept in the page
const LABEL_CELL = [34, 14];
const DOUBT_DELAY = 800;    // ms after the last edit before the doubtful places are asked for again

// tracks: id -> its points sorted by frame ({frame, x, y, interpolated} arrays); byFrame: frame ->
// (id -> index of its point there). An edit's answer replaces only the tracks it changed.
const state = {
  clip: null, frame: 0, selected: null, playing: false, autoAdvance: false,
  version: -1, tracks: new Map(), byFrame: new Map(), detectionsByFrame: new Map(),
  doubtful: [], doubtCount: 0, doubtPerFrame: [], doubtVersion: -1, doubtLoading: null, doubtTimer: null, timelineMarks: null,
  visited: new Set(), edits: [], view: { scale: 1, tx: 0, ty: 0 },
  images: new Map(), shownImage: null, drawnFrame: -1, stepStarted: null, lastStepMs: null, lastEditMs: null, ready: false,
};

// --- talking to the server -------------------------------------------------------------------

function api(path) { return `${path}${path.includes("?") ? "&" : "?"}token=${encodeURIComponent(token)}`; }

async function getJSON(path) {
  const response = await fetch(api(path));
  if (!response.ok) throw new Error((await response.json()).error);
  return response.json();
}

// One request at a time, so each answer is the change from the version the page then holds.
let posting = Promise.resolve();

function post(path, body = {}) {
  const result = posting.then(() => send(path, body));
  posting = result.catch(() => null);
  return result;
}

async function send(path, body) {
  const started = performance.now();
  const response = await fetch(api(path), { method: "POST", headers: { "Content-Type": "application/json", "X-Version": String(state.version) }, body: JSON.stringify(body) });
  const reply = await response.json();
  // A click on another track's point takes it only when the user says so: the server says what
  // it would do, and the click is sent again if the user agrees (shift-click agrees beforehand).
  if (response.status === 409 && reply.reassign) {
    // Sent at once, not queued: this request already holds the queue.
    if (window.confirm(`${reply.reassign}. Do it?`)) return send(path, { ...body, reassign: true });
    say("nothing changed (shift-click takes another track's point without asking)");
    return null;
  }
  if (!response.ok) { say(reply.error, true); return null; }
  if (reply.since !== null && reply.since !== state.version) takeState(await getJSON("/api/state"));
  else takeState(reply);
  if ("selected" in reply && reply.selected !== null) state.selected = reply.selected;
  if (state.selected !== null && !state.tracks.has(state.selected)) state.selected = null;
  showLists();
  draw();
  state.lastEditMs = performance.now() - started;
  say(reply.exported ? `wrote ${reply.exported.join(", ")}` : "saved");
  return reply;
}

function say(text, error = false) {
  const status = document.getElementById("status");
  status.textContent = text || "";
  status.className = error ? "error" : "";
}

// --- the tracks, indexed for drawing ---------------------------------------------------------

// The whole state (since null) or the tracks changed since the version the page holds.
function takeState(reply) {
  if (reply.since === null) { state.tracks = new Map(); state.byFrame = new Map(); }
  const rows = reply.tracks;
  const changed = new Map();
  for (let i = 0; i < rows.frame.length; i++) {
    const id = rows.track_id[i];
    let track = changed.get(id);
    if (!track) { track = { frame: [], x: [], y: [], interpolated: [] }; changed.set(id, track); }
    track.frame.push(rows.frame[i]); track.x.push(rows.x[i]); track.y.push(rows.y[i]); track.interpolated.push(rows.interpolated[i]);
  }
  for (const id of reply.removed) setTrack(id, null);
  for (const [id, track] of changed) setTrack(id, track);
  state.version = reply.version;
  state.edits = reply.edits;
  scheduleDoubt();
}

function setTrack(id, track) {
  const old = state.tracks.get(id);
  if (old) for (const frame of old.frame) {
    const here = state.byFrame.get(frame);
    here.delete(id);
    if (!here.size) state.byFrame.delete(frame);
  }
  if (!track) { state.tracks.delete(id); return; }
  state.tracks.set(id, track);
  track.frame.forEach((frame, i) => {
    let here = state.byFrame.get(frame);
    if (!here) { here = new Map(); state.byFrame.set(frame, here); }
    here.set(id, i);
  });
}

// --- doubtful places: asked for apart from the tracks, as they take the server a while -------

function scheduleDoubt() {
  clearTimeout(state.doubtTimer);
  state.doubtTimer = setTimeout(loadDoubt, state.doubtVersion < 0 ? 0 : DOUBT_DELAY);
}

function loadDoubt() {
  clearTimeout(state.doubtTimer);
  if (state.doubtVersion === state.version) return Promise.resolve();
  if (!state.doubtLoading) {
    state.doubtLoading = getJSON("/api/doubtful").then((reply) => {
      state.doubtful = reply.places;
      state.doubtCount = reply.count;
      state.doubtPerFrame = reply.per_frame;
      state.doubtVersion = reply.version;
      state.timelineMarks = null;
      showLists();
      drawTimeline();
    }, (error) => say(error.message, true)).finally(() => { state.doubtLoading = null; });
  }
  return state.doubtLoading.then(() => { if (state.doubtVersion !== state.version) return loadDoubt(); });
}

function push(map, key, value) {
  const list = map.get(key);
  if (list) list.push(value); else map.set(key, [value]);
}

function pointOf(id, frame) {
  const i = state.byFrame.get(frame)?.get(id);
  if (i === undefined) return null;
  const track = state.tracks.get(id);
  return [track.x[i], track.y[i], track.interpolated[i]];
}

// Index of the first point of a track at or after frame.
function firstFrom(track, frame) {
  let low = 0, high = track.frame.length;
  while (low < high) { const middle = (low + high) >> 1; if (track.frame[middle] < frame) low = middle + 1; else high = middle; }
  return low;
}

function colour(track, lightness = 60) { return `hsl(${(track * 137.508) % 360}, 90%, ${lightness}%)`; }

// --- frames ----------------------------------------------------------------------------------

function loadFrame(index) {
  let entry = state.images.get(index);
  if (!entry) {
    const image = new Image();
    image.src = api(`/api/frame?i=${index}`);
    entry = { image, ready: image.decode().then(() => image) };
    entry.ready.catch(() => state.images.delete(index));
    state.images.set(index, entry);
    if (state.images.size > CACHED_FRAMES) state.images.delete(state.images.keys().next().value);
  }
  return entry.ready;
}

function goTo(index) {
  const last = state.clip.frame_count - 1;
  index = Math.max(0, Math.min(last, index));
  state.frame = index;
  document.getElementById("frame").value = index;
  loadFrame(index).then((image) => {
    if (state.frame !== index) return;
    state.shownImage = image;
    draw();
    state.drawnFrame = index;
    if (state.stepStarted !== null) { state.lastStepMs = performance.now() - state.stepStarted; state.stepStarted = null; }
    state.ready = true;
    for (const ahead of [index + 1, index + 2, index - 1]) if (ahead >= 0 && ahead <= last) loadFrame(ahead);
  }, () => say(`cannot show frame ${index}`, true));
  draw();
}

function step(by) { state.stepStarted = performance.now(); goTo(state.frame + by); }

// --- view: image <-> screen ------------------------------------------------------------------

function toScreen(x, y) { const v = state.view; return [x * v.scale + v.tx, y * v.scale + v.ty]; }
function toImage(sx, sy) { const v = state.view; return [(sx - v.tx) / v.scale, (sy - v.ty) / v.scale]; }

function fit() {
  const { width, height } = state.clip;
  const scale = Math.min(canvas.clientWidth / width, canvas.clientHeight / height);
  state.view = { scale, tx: (canvas.clientWidth - width * scale) / 2 + 0.5 * scale, ty: (canvas.clientHeight - height * scale) / 2 + 0.5 * scale };
  draw();
}

function zoomAt(sx, sy, factor) {
  const v = state.view;
  const [x, y] = toImage(sx, sy);
  v.scale = Math.max(0.05, Math.min(64, v.scale * factor));
  v.tx = sx - x * v.scale;
  v.ty = sy - y * v.scale;
  draw();
}

function centreOn(x, y) {
  const [sx, sy] = toScreen(x, y);
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (sx < 0.15 * w || sx > 0.85 * w || sy < 0.15 * h || sy > 0.85 * h) {
    state.view.tx += w / 2 - sx;
    state.view.ty += h / 2 - sy;
  }
}

// --- drawing ---------------------------------------------------------------------------------

function resize() {
  const ratio = window.devicePixelRatio || 1;
  for (const c of [canvas, timeline]) {
    c.width = Math.round(c.clientWidth * ratio);
    c.height = Math.round(c.clientHeight * ratio);
  }
}

function draw() {
  if (!state.clip) return;
  const ratio = window.devicePixelRatio || 1;
  context.setTransform(ratio, 0, 0, ratio, 0, 0);
  context.fillStyle = "#111";
  context.fillRect(0, 0, canvas.clientWidth, canvas.clientHeight);
  const v = state.view;
  if (state.shownImage) {
    context.imageSmoothingEnabled = v.scale < 2;
    context.drawImage(state.shownImage, v.tx - 0.5 * v.scale, v.ty - 0.5 * v.scale, state.clip.width * v.scale, state.clip.height * v.scale);
  }
  if (state.version >= 0) drawTracks();
  drawTimeline();
}

let RING = MIN_RING;

// Only what is in view is drawn: the points of this frame (and their trails) on the canvas.
function drawTracks() {
  const frame = state.frame;
  RING = Math.max(MIN_RING, Math.min(30, RING_PIXELS * state.view.scale));
  const margin = RING + TRAIL * 4 * state.view.scale + 40, w = canvas.clientWidth, h = canvas.clientHeight;
  const inView = (sx, sy) => sx > -margin && sy > -margin && sx < w + margin && sy < h + margin;
  for (const [x, y] of state.detectionsByFrame.get(frame) || []) {
    const [sx, sy] = toScreen(x, y);
    if (!inView(sx, sy)) continue;
    context.strokeStyle = "rgba(0, 220, 255, 0.9)";
    context.lineWidth = 1;
    context.beginPath();
    context.moveTo(sx - 3, sy); context.lineTo(sx + 3, sy); context.moveTo(sx, sy - 3); context.lineTo(sx, sy + 3);
    context.stroke();
  }
  const labels = [];
  for (const [id, i] of state.byFrame.get(frame) || []) {
    if (id === state.selected) continue;
    const track = state.tracks.get(id);
    const [sx, sy] = toScreen(track.x[i], track.y[i]);
    if (!inView(sx, sy)) continue;
    drawTrail(id, frame - TRAIL, frame, colour(id), 1.5);
    ring(sx, sy, RING, colour(id), 2, track.interpolated[i]);
    labels.push([id, sx, sy]);
  }
  if (state.selected !== null && state.tracks.has(state.selected)) {
    const track = state.selected;
    drawTrail(track, -Infinity, Infinity, "rgba(255,255,255,0.85)", 1.5);
    const point = pointOf(track, frame);
    if (point) {
      const [sx, sy] = toScreen(point[0], point[1]);
      ring(sx, sy, RING + 3, "#fff", 3, point[2]);
      labels.unshift([track, sx, sy]);
    }
  }
  drawLabels(labels);
}

function drawTrail(id, from, to, style, width) {
  const track = state.tracks.get(id);
  context.strokeStyle = style;
  context.lineWidth = width;
  context.beginPath();
  let started = false, previous = null;
  for (let i = from === -Infinity ? 0 : firstFrom(track, from); i < track.frame.length; i++) {
    const f = track.frame[i];
    if (f > to) break;
    const [sx, sy] = toScreen(track.x[i], track.y[i]);
    if (!started || f !== previous + 1) context.moveTo(sx, sy); else context.lineTo(sx, sy);
    started = true;
    previous = f;
  }
  context.stroke();
}

function ring(sx, sy, radius, style, width, dashed) {
  context.setLineDash(dashed ? [3, 3] : []);
  context.lineWidth = width + 2;
  context.strokeStyle = "rgba(0,0,0,0.6)";
  context.beginPath(); context.arc(sx, sy, radius, 0, 2 * Math.PI); context.stroke();
  context.lineWidth = width;
  context.strokeStyle = style;
  context.beginPath(); context.arc(sx, sy, radius, 0, 2 * Math.PI); context.stroke();
  context.setLineDash([]);
}

// Labels take the first free place of four around their ring; a label with no free place is left
// out, so that on dense footage the ids that are drawn can be read.
function drawLabels(labels) {
  const taken = new Set();
  const [cw, ch] = LABEL_CELL;
  context.font = "bold 12px 'DejaVu Sans Mono', monospace";
  context.textBaseline = "middle";
  for (const [track, sx, sy] of labels) {
    const text = String(track);
    const w = context.measureText(text).width;
    for (const [dx, dy] of [[RING + 2, -RING], [RING + 2, RING], [-RING - 2 - w, -RING], [-RING - 2 - w, RING]]) {
      const x = sx + dx, y = sy + dy;
      const cells = [];
      for (let cx = Math.floor(x / cw); cx <= Math.floor((x + w) / cw); cx++) cells.push(`${cx},${Math.floor(y / ch)}`);
      if (cells.some((cell) => taken.has(cell))) continue;
      cells.forEach((cell) => taken.add(cell));
      context.lineWidth = 3;
      context.strokeStyle = "rgba(0,0,0,0.8)";
      context.strokeText(text, x, y);
      context.fillStyle = track === state.selected ? "#fff" : colour(track, 70);
      context.fillText(text, x, y);
      break;
    }
  }
}

function drawTimeline() {
  const ratio = window.devicePixelRatio || 1;
  const w = timeline.clientWidth, h = timeline.clientHeight, n = state.clip.frame_count;
  timelineContext.setTransform(ratio, 0, 0, ratio, 0, 0);
  timelineContext.fillStyle = "#111";
  timelineContext.fillRect(0, 0, w, h);
  const at = (frame) => ((frame + 0.5) / n) * w;
  if (state.selected !== null && state.tracks.has(state.selected)) {
    const frames = state.tracks.get(state.selected).frame;
    timelineContext.fillStyle = "rgba(255,255,255,0.35)";
    timelineContext.fillRect(at(frames[0] - 0.5), 4, at(frames[frames.length - 1] + 0.5) - at(frames[0] - 0.5), 8);
  }
  if (!state.timelineMarks) state.timelineMarks = doubtMarks(w, h, ratio, at);
  timelineContext.drawImage(state.timelineMarks, 0, 0, w, h);
  timelineContext.fillStyle = "#f0c040";
  timelineContext.fillRect(at(state.frame) - 1.5, 0, 3, h);
}

// The frames with doubtful places, drawn once a version rather than at every step.
function doubtMarks(w, h, ratio, at) {
  const marks = document.createElement("canvas");
  marks.width = Math.max(1, Math.round(w * ratio)); marks.height = Math.max(1, Math.round(h * ratio));
  const c = marks.getContext("2d");
  c.setTransform(ratio, 0, 0, ratio, 0, 0);
  c.fillStyle = "#e0604a";
  state.doubtPerFrame.forEach((count, frame) => { if (count) c.fillRect(at(frame) - 1, 16, 2, 10); });
  return marks;
}

// --- side lists ------------------------------------------------------------------------------

function placeKey(place) { return `${place.kind} ${place.track} ${place.frame}`; }

function showLists() {
  const doubtful = document.getElementById("doubtful");
  doubtful.replaceChildren(...state.doubtful.slice(0, 200).map((place) => {
    const item = document.createElement("li");
    item.textContent = `frame ${place.frame}, track ${place.track}: ${place.kind} (${place.text})`;
    if (state.visited.has(placeKey(place))) item.className = "visited";
    item.onclick = () => visit(place);
    return item;
  }));
  const edits = document.getElementById("edits");
  edits.replaceChildren(...state.edits.slice(-50).reverse().map((text) => {
    const item = document.createElement("li");
    item.textContent = text;
    return item;
  }));
  edits.start = state.edits.length;
  showSelected();
}

function showSelected() {
  const box = document.getElementById("selected");
  if (state.selected === null || !state.tracks.has(state.selected)) { box.textContent = "none: click a track's point"; return; }
  const frames = state.tracks.get(state.selected).frame;
  box.textContent = `track ${state.selected}: frames ${frames[0]}-${frames[frames.length - 1]} (${frames.length} points)`;
}

function visit(place) {
  state.visited.add(placeKey(place));
  state.selected = place.track;
  const point = pointOf(place.track, place.frame);
  if (point) centreOn(point[0], point[1]);
  goTo(place.frame);
  showLists();
  say(`${place.kind}: ${place.text}`);
}

async function nextDoubtful(backwards) {
  if (state.doubtVersion !== state.version) { say("finding the doubtful places..."); await loadDoubt(); }
  const list = backwards ? [...state.doubtful].reverse() : state.doubtful;
  const place = list.find((p) => !state.visited.has(placeKey(p)));
  if (place) visit(place); else say("no doubtful place left unvisited");
}

// --- pointing --------------------------------------------------------------------------------

function target(sx, sy) {
  // The nearest point on screen within SNAP: a track's point or a detection.
  let best = null, bestDistance = SNAP;
  const consider = (x, y) => {
    const [px, py] = toScreen(x, y);
    const distance = Math.hypot(px - sx, py - sy);
    if (distance <= bestDistance) { best = [x, y]; bestDistance = distance; }
  };
  for (const [id, i] of state.byFrame.get(state.frame) || []) consider(state.tracks.get(id).x[i], state.tracks.get(id).y[i]);
  for (const [x, y] of state.detectionsByFrame.get(state.frame) || []) consider(x, y);
  return best;
}

function holderOf(x, y) {
  for (const [id, i] of state.byFrame.get(state.frame) || []) {
    const track = state.tracks.get(id);
    if (Math.hypot(track.x[i] - x, track.y[i] - y) <= 0.5) return id;
  }
  return null;
}

async function pointAt(sx, sy, reassign = false) {
  const snapped = target(sx, sy);
  const [x, y] = snapped || toImage(sx, sy);
  const holder = snapped ? holderOf(x, y) : null;
  if (holder !== null && (state.selected === null || holder === state.selected)) {
    state.selected = holder;
    showLists();
    draw();
    return;
  }
  const reply = await post("/api/click", { selected: state.selected, frame: state.frame, x, y, reassign });
  if (reply && state.autoAdvance && holder === null && state.frame < state.clip.frame_count - 1) step(1);
}

let pressed = null;
canvas.addEventListener("mousedown", (event) => { pressed = { x: event.offsetX, y: event.offsetY, tx: state.view.tx, ty: state.view.ty, moved: false }; canvas.focus(); });
canvas.addEventListener("mousemove", (event) => {
  if (!pressed) return;
  const dx = event.offsetX - pressed.x, dy = event.offsetY - pressed.y;
  if (Math.hypot(dx, dy) > 4) pressed.moved = true;
  if (pressed.moved) { state.view.tx = pressed.tx + dx; state.view.ty = pressed.ty + dy; draw(); }
});
canvas.addEventListener("mouseup", (event) => {
  const was = pressed;
  pressed = null;
  if (was && !was.moved && event.button === 0) pointAt(event.offsetX, event.offsetY, event.shiftKey);
});
canvas.addEventListener("wheel", (event) => { event.preventDefault(); zoomAt(event.offsetX, event.offsetY, Math.exp(-event.deltaY * 0.0015)); }, { passive: false });

timeline.addEventListener("mousedown", (event) => goTo(Math.floor((event.offsetX / timeline.clientWidth) * state.clip.frame_count)));

// --- keys ------------------------------------------------------------------------------------

function togglePlay() {
  state.playing = !state.playing;
  document.getElementById("play").innerHTML = state.playing ? "&#10073;&#10073;" : "&#9654;";
  if (state.playing) play();
}

function play() {
  if (!state.playing) return;
  if (state.frame >= state.clip.frame_count - 1) { togglePlay(); return; }
  const next = state.frame + 1;
  const started = performance.now();
  loadFrame(next).then(() => {
    goTo(next);
    setTimeout(play, Math.max(0, 1000 / Math.min(state.clip.fps, 30) - (performance.now() - started)));
  }, () => togglePlay());
}

document.addEventListener("keydown", (event) => {
  if (event.target instanceof HTMLInputElement && event.target.type === "number") {
    if (event.key === "Enter") { goTo(parseInt(event.target.value, 10) || 0); canvas.focus(); }
    return;
  }
  const key = event.key, selected = state.selected;
  const by = event.shiftKey ? 10 : 1;
  const control = event.ctrlKey || event.metaKey;
  let handled = true;
  if (key === "ArrowRight") step(by);
  else if (key === "ArrowLeft") step(-by);
  else if (key === "Home") goTo(0);
  else if (key === "End") goTo(state.clip.frame_count - 1);
  else if (key === " ") togglePlay();
  else if (key === "n" || key === "N") nextDoubtful(event.shiftKey);
  else if (key === "Escape") { state.selected = null; showLists(); draw(); }
  else if ((key === "z" && !event.shiftKey) || (control && key === "z" && !event.shiftKey)) post("/api/undo");
  else if (key === "y" || key === "Z" || (control && key === "Z")) post("/api/redo");
  else if (key === "s" && selected !== null) post("/api/split", { track: selected, frame: state.frame });
  else if ((key === "Delete" || key === "Backspace") && selected !== null) post("/api/delete", event.shiftKey ? { track: selected } : { track: selected, frame: state.frame });
  else if (key === "f") fit();
  else if (key === "+" || key === "=") zoomAt(canvas.clientWidth / 2, canvas.clientHeight / 2, 1.25);
  else if (key === "-") zoomAt(canvas.clientWidth / 2, canvas.clientHeight / 2, 0.8);
  else if (key === "g") { const box = document.getElementById("frame"); box.focus(); box.select(); }
  else if (key === "e") post("/api/export");
  else if (key === "m") { state.autoAdvance = !state.autoAdvance; document.getElementById("advance").checked = state.autoAdvance; }
  else if ((key === "[" || key === "]") && selected !== null && state.tracks.has(selected)) {
    const frames = state.tracks.get(selected).frame;
    goTo(key === "[" ? frames[0] : frames[frames.length - 1]);
  } else handled = false;
  if (handled) event.preventDefault();
});

document.getElementById("play").onclick = togglePlay;
document.getElementById("export").onclick = () => post("/api/export");
document.getElementById("advance").onchange = (event) => { state.autoAdvance = event.target.checked; };
document.getElementById("frame").onchange = (event) => goTo(parseInt(event.target.value, 10) || 0);
window.addEventListener("resize", () => { resize(); state.timelineMarks = null; draw(); });

// --- start -----------------------------------------------------------------------------------

async function start() {
  try {
    state.clip = await getJSON("/api/clip");
  } catch (error) { say(error.message, true); return; }
  const clip = state.clip;
  document.getElementById("clip").textContent = `${clip.name} (${clip.width}x${clip.height})`;
  document.getElementById("count").textContent = `of ${clip.frame_count - 1}`;
  document.getElementById("frame").max = clip.frame_count - 1;
  state.autoAdvance = !clip.has_tracks;
  document.getElementById("advance").checked = state.autoAdvance;
  if (clip.detections) {
    const d = clip.detections;
    for (let i = 0; i < d.frame.length; i++) push(state.detectionsByFrame, d.frame[i], [d.x[i], d.y[i]]);
  }
  resize();
  fit();
  say("loading the tracks...");
  const [reply] = await Promise.all([getJSON("/api/state"), loadFrame(0)]);
  takeState(reply);
  showLists();
  say(`${state.tracks.size} tracks`);
  goTo(0);
  canvas.focus();
}

// For tests and benchmarks: the page's state and its image <-> screen mapping.
window.annotate = { state, toScreen, toImage, goTo };
start();
