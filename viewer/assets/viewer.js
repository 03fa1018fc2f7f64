// swarm view: the page. Plain JavaScript, no build step; served by the `swarm` binary.
//
// Data comes from the server in pieces: /api/meta once (map, robots, roles), /api/live as
// server-sent status (how many whole ticks exist, whether the run is live), trajectory
// frames as binary chunks (/api/frames, 20 bytes per robot per tick), timeline markers,
// consensus lanes and radio traffic incrementally. Nothing is loaded as one big document.
'use strict';

const STATE_NAMES = ['active', 'down', 'dead', 'frozen', 'restarting'];
const STATE_FILL = ['#1f6feb', '#9a9a9a', '#222222', '#9ecbff', '#f0a020'];
const ACTIVE = 0, DOWN = 1, DEAD = 2;
const MARKER_ROWS = ['collision', 'died', 'fault', 'radio', 'rejected', 'reached', 'notes'];
const MARKER_COLOUR = {
  collision: '#d73a49', died: '#222', fault: '#e36209', radio: '#8250df',
  rejected: '#8a4600', reached: '#2da44e', notes: '#1f6feb',
};
const LANE_COLOUR = { follower: '#e8e8e8', pre_candidate: '#f6e27a', candidate: '#f0a020', leader: '#d73a49', dead: '#555' };
const OUTCOME_DELIVERED = 0;
const CACHE_LIMIT = 256 << 20; // bytes of frame chunks kept in memory

const V = {
  meta: null, status: null, ready: false, error: null,
  chunks: new Map(), loading: new Map(), cacheBytes: 0,
  frame: 0, pos: 0, playing: false, speed: 1, following: false,
  trails: true, radio: true,
  markers: [], lanes: [], strip: null, links: new Map(), linkChunks: new Map(),
  selected: null, inspect: null, highlight: null,
  drawn: 0, fps: 0, fpsFrames: 0, fpsSince: 0, lastNow: 0, dirty: true,
  view: null, staticMap: null, drawnFrame: null,
  markerBoxes: [], rolesSeen: new Set(),
};
const $ = (id) => document.getElementById(id);
const mapCanvas = $('map'), sideCanvas = $('side');
const eventsCanvas = $('events-canvas'), lanesCanvas = $('lanes-canvas');

function fail(msg) {
  V.error = msg;
  const e = $('error');
  e.textContent = msg;
  e.hidden = false;
}

async function getJson(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: ${r.status} ${await r.text()}`);
  return r.json();
}

// ---------------------------------------------------------------- frames

function chunkOf(frame) { return Math.floor(frame / V.meta.chunk_frames); }

// A chunk is the frames [c * chunk_frames, (c + 1) * chunk_frames), held as pieces: a finished
// run's chunk arrives in one piece; a live run's newest chunk grows by a piece per update, each
// holding only the frames that are new, and is fetched whole once it is full.
function parsePiece(buf) {
  const h = new Uint32Array(buf, 0, 4);
  if (h[0] !== 0x46565753) throw new Error('not a frames chunk');
  const robots = h[1], from = h[2], count = h[3];
  const dataAt = 16 + 4 * count;
  return {
    robots, from, count, bytes: buf.byteLength,
    ticks: new Uint32Array(buf, 16, count),
    f: new Float32Array(buf, dataAt, (buf.byteLength - dataAt) / 4),
    b: new Uint8Array(buf, dataAt),
  };
}

function loadChunk(c) {
  if (V.loading.has(c)) return V.loading.get(c);
  const cf = V.meta.chunk_frames, full = (c + 1) * cf;
  const have = V.chunks.get(c);
  const whole = have && have.end === full && have.pieces.length > 1;
  const from = have && !whole ? have.end : c * cf;
  if (from >= Math.min(full, V.status.frames) && !whole) return null;
  const url = `/api/frames?from=${from}&to=${full}`;
  const p = fetch(url)
    .then((r) => { if (!r.ok) throw new Error(`${url}: ${r.status}`); return r.arrayBuffer(); })
    .then((buf) => {
      const piece = parsePiece(buf);
      let chunk = V.chunks.get(c);
      if (!chunk || piece.from === c * cf) {
        if (chunk) V.cacheBytes -= chunk.bytes;
        chunk = { pieces: [], end: c * cf, bytes: 0 };
        V.chunks.set(c, chunk);
      }
      if (piece.count && piece.from === chunk.end) {
        chunk.pieces.push(piece);
        chunk.end = piece.from + piece.count;
        chunk.bytes += piece.bytes;
        V.cacheBytes += piece.bytes;
      }
      evict();
      V.dirty = true;
      return chunk;
    })
    .catch((e) => fail(String(e)))
    .finally(() => V.loading.delete(c));
  V.loading.set(c, p);
  return p;
}

function evict() {
  if (V.cacheBytes <= CACHE_LIMIT) return;
  const here = chunkOf(V.frame), cf = V.meta.chunk_frames;
  const far = [...V.chunks.keys()].sort((a, b) => Math.abs(b - here) - Math.abs(a - here));
  for (const c of far) {
    if (V.cacheBytes <= CACHE_LIMIT * 0.8 || Math.abs(c - here) <= 2) break;
    V.cacheBytes -= V.chunks.get(c).bytes;
    V.chunks.delete(c);
    // the radio links of those ticks go with them
    for (let f = c * cf; f < (c + 1) * cf; f++) V.links.delete(tickOf(f));
    V.linkChunks.delete(c);
  }
}

// The piece holding `frame`, if loaded.
function chunkFor(frame) {
  const c = V.chunks.get(chunkOf(frame));
  if (!c || frame >= c.end) return null;
  const ps = c.pieces;
  let lo = 0, hi = ps.length - 1;
  while (lo < hi) { const mid = (lo + hi + 1) >> 1; if (ps[mid].from <= frame) lo = mid; else hi = mid - 1; }
  const p = ps[lo];
  return p && frame >= p.from && frame < p.from + p.count ? p : null;
}

function ensure(frame) {
  if (!V.status || !(frame >= 0) || frame >= V.status.frames) return;
  const c = V.chunks.get(chunkOf(frame));
  const full = (chunkOf(frame) + 1) * V.meta.chunk_frames;
  if (!chunkFor(frame) || (c && c.end === full && c.pieces.length > 1)) loadChunk(chunkOf(frame));
}

function robotAt(frame, k) {
  const c = chunkFor(frame);
  if (!c || k >= c.robots) return null;
  const rec = (frame - c.from) * c.robots + k;
  const o = rec * 5, b = rec * 20 + 16;
  return {
    x: c.f[o], y: c.f[o + 1], z: c.f[o + 2], theta: c.f[o + 3],
    state: c.b[b], role: c.b[b + 1], lidar: (c.b[b + 2] & 1) === 1,
  };
}

function tickOf(frame) {
  const c = chunkFor(frame);
  if (c) return c.ticks[frame - c.from];
  return (V.status ? V.status.first_tick : 0) + frame;
}

function frameOfTick(tick) {
  const first = V.status ? V.status.first_tick : 0;
  return Math.max(0, Math.min(lastFrame(), tick - first));
}

function lastFrame() { return V.status ? Math.max(0, V.status.frames - 1) : 0; }

// ---------------------------------------------------------------- view transform

function layout() {
  const m = V.meta;
  const [x0, y0, x1, y1] = m.map.bounds;
  for (const c of [mapCanvas, sideCanvas, eventsCanvas, lanesCanvas]) {
    if (c.hidden) continue;
    const r = c.getBoundingClientRect();
    const dpr = window.devicePixelRatio || 1;
    c.width = Math.max(1, Math.round(r.width * dpr));
    c.height = Math.max(1, Math.round(r.height * dpr));
  }
  const dpr = window.devicePixelRatio || 1;
  const w = mapCanvas.width, h = mapCanvas.height, pad = 16 * dpr;
  const fit = Math.min((w - 2 * pad) / (x1 - x0), (h - 2 * pad) / (y1 - y0));
  const zoom = V.zoom || 1;
  const s = fit * zoom;
  const cx = V.centre ? V.centre[0] : (x0 + x1) / 2, cy = V.centre ? V.centre[1] : (y0 + y1) / 2;
  V.view = { s, ox: w / 2 - cx * s, oy: h / 2 + cy * s, dpr };
  V.staticMap = null;
  V.dirty = true;
}

function sx(x) { return V.view.ox + x * V.view.s; }
function sy(y) { return V.view.oy - y * V.view.s; }
function wx(px) { return (px - V.view.ox) / V.view.s; }
function wy(py) { return (V.view.oy - py) / V.view.s; }

// ---------------------------------------------------------------- drawing the map

function obstacleFill(height, top) {
  if (height == null || !top) return '#c9ced6';
  const t = Math.max(0, Math.min(1, height / top));
  const g = Math.round(215 - 110 * t);
  return `rgb(${g},${g + 4},${g + 12})`;
}

function drawStatic() {
  const c = document.createElement('canvas');
  c.width = mapCanvas.width; c.height = mapCanvas.height;
  const g = c.getContext('2d');
  const m = V.meta, map = m.map, s = V.view.s;
  const [x0, y0, x1, y1] = map.bounds;
  g.fillStyle = '#fff';
  g.fillRect(0, 0, c.width, c.height);
  // a 1 m grid, faint
  const step = s > 30 ? 1 : s > 6 ? 5 : s > 1.5 ? 20 : 100;
  g.strokeStyle = '#f1f1f1';
  g.lineWidth = 1;
  g.beginPath();
  for (let x = Math.ceil(x0 / step) * step; x <= x1; x += step) { g.moveTo(sx(x), sy(y0)); g.lineTo(sx(x), sy(y1)); }
  for (let y = Math.ceil(y0 / step) * step; y <= y1; y += step) { g.moveTo(sx(x0), sy(y)); g.lineTo(sx(x1), sy(y)); }
  g.stroke();
  const top = map.height || Math.max(1, ...[...(map.circles || []), ...(map.rectangles || []), ...(map.polygons || [])]
    .map((o) => o.height || 0));
  for (const o of map.circles || []) {
    g.fillStyle = obstacleFill(o.height, top);
    g.beginPath(); g.arc(sx(o.x), sy(o.y), o.r * s, 0, 2 * Math.PI); g.fill();
  }
  for (const o of map.rectangles || []) {
    g.fillStyle = obstacleFill(o.height, top);
    g.fillRect(sx(o.x_min), sy(o.y_max), (o.x_max - o.x_min) * s, (o.y_max - o.y_min) * s);
  }
  for (const o of map.polygons || []) {
    g.fillStyle = obstacleFill(o.height, top);
    g.beginPath();
    o.points.forEach(([x, y], i) => (i ? g.lineTo(sx(x), sy(y)) : g.moveTo(sx(x), sy(y))));
    g.closePath(); g.fill();
  }
  g.strokeStyle = '#555';
  g.lineWidth = 2 * V.view.dpr;
  g.strokeRect(sx(x0), sy(y1), (x1 - x0) * s, (y1 - y0) * s);
  for (const goal of m.goals) {
    g.strokeStyle = '#2da44e'; g.fillStyle = 'rgba(45,164,78,0.12)';
    g.lineWidth = 1.5 * V.view.dpr;
    g.beginPath(); g.arc(sx(goal.x), sy(goal.y), Math.max(3, goal.radius * s), 0, 2 * Math.PI);
    g.fill(); g.stroke();
    g.beginPath();
    const r = 5 * V.view.dpr;
    g.moveTo(sx(goal.x) - r, sy(goal.y)); g.lineTo(sx(goal.x) + r, sy(goal.y));
    g.moveTo(sx(goal.x), sy(goal.y) - r); g.lineTo(sx(goal.x), sy(goal.y) + r);
    g.stroke();
  }
  V.staticMap = c;
}

function fillOfBytes(state, roleByte) {
  if (state !== ACTIVE) return STATE_FILL[state] || '#999';
  const role = V.meta.roles[roleByte];
  return role ? role.colour : STATE_FILL[ACTIVE];
}
function fillOf(r) { return fillOfBytes(r.state, r.role); }

// Trails: the last 150 ticks, sampled so that the whole swarm's trails stay within a budget
// of segments (software-rendered canvas: 40 points for 100 robots, 6 for 1,000, none past
// 6,000 robots). Positions are read straight from the frames' arrays.
const TRAIL_TICKS = 150, TRAIL_SEGMENTS = 6000;
function drawTrails(g, frame) {
  const n = V.meta.robots;
  const points = Math.min(40, Math.floor(TRAIL_SEGMENTS / n));
  if (points < 2) return;
  const stride = Math.max(1, Math.floor(TRAIL_TICKS / points));
  const from = Math.max(0, frame - TRAIL_TICKS);
  const samples = [];
  for (let f = from + ((frame - from) % stride); f <= frame; f += stride) {
    const p = chunkFor(f);
    if (p) samples.push([p.f, (f - p.from) * p.robots * 5]);
  }
  const now = chunkFor(frame);
  if (!now || samples.length < 2) return;
  const nowBase = (frame - now.from) * now.robots;
  const byColour = new Map();
  for (let k = 0; k < n; k++) {
    const b = (nowBase + k) * 20 + 16;
    const colour = fillOfBytes(now.b[b], now.b[b + 1]);
    let path = byColour.get(colour);
    if (!path) { path = new Path2D(); byColour.set(colour, path); }
    for (let i = 0; i < samples.length; i++) {
      const [f32, base] = samples[i];
      const o = base + k * 5;
      const x = sx(f32[o]), y = sy(f32[o + 1]);
      if (i) path.lineTo(x, y); else path.moveTo(x, y);
    }
  }
  g.lineWidth = 1.2 * V.view.dpr;
  g.globalAlpha = 0.45;
  for (const [colour, path] of byColour) { g.strokeStyle = colour; g.stroke(path); }
  g.globalAlpha = 1;
}

function drawRadio(g, frame) {
  const tick = tickOf(frame);
  const links = V.links.get(tick);
  if (!links) return;
  const ok = new Path2D(), lost = new Path2D();
  for (let i = 0; i < links.length; i += 3) {
    const a = robotAt(frame, links[i]), b = robotAt(frame, links[i + 1]);
    if (!a || !b) continue;
    const p = links[i + 2] === OUTCOME_DELIVERED ? ok : lost;
    p.moveTo(sx(a.x), sy(a.y)); p.lineTo(sx(b.x), sy(b.y));
  }
  g.lineWidth = 1 * V.view.dpr;
  g.globalAlpha = 0.5;
  g.strokeStyle = '#2da44e'; g.stroke(ok);
  g.setLineDash([4 * V.view.dpr, 3 * V.view.dpr]);
  g.strokeStyle = '#d73a49'; g.stroke(lost);
  g.setLineDash([]);
  g.globalAlpha = 1;
}

function drawRobots(g, frame) {
  const n = V.meta.robots, s = V.view.s, dpr = V.view.dpr;
  const rad = Math.max(2 * dpr, V.meta.radius * s);
  const bodies = new Map();
  const heads = new Path2D(), rings = new Path2D(), crosses = new Path2D();
  const drawn = new Array(n);
  // Robots a few pixels across are drawn as squares without outline or lidar ring: the same
  // picture at that size, and several times cheaper for a software-rendered canvas.
  const small = rad < 4 * dpr;
  for (let k = 0; k < n; k++) {
    const r = robotAt(frame, k);
    if (!r) return null;
    drawn[k] = r;
    if (r.role !== 255 && !V.rolesSeen.has(r.role)) { V.rolesSeen.add(r.role); V.legendStale = true; }
    const x = sx(r.x), y = sy(r.y);
    const colour = fillOf(r);
    let p = bodies.get(colour);
    if (!p) { p = new Path2D(); bodies.set(colour, p); }
    if (small) p.rect(x - rad, y - rad, 2 * rad, 2 * rad);
    else { p.moveTo(x + rad, y); p.arc(x, y, rad, 0, 2 * Math.PI); }
    heads.moveTo(x, y); heads.lineTo(x + Math.cos(r.theta) * rad * 1.6, y - Math.sin(r.theta) * rad * 1.6);
    if (r.lidar && !small) { rings.moveTo(x + rad * 1.5, y); rings.arc(x, y, rad * 1.5, 0, 2 * Math.PI); }
    if (r.state === DOWN || r.state === DEAD) {
      const d = rad * 0.7;
      crosses.moveTo(x - d, y - d); crosses.lineTo(x + d, y + d);
      crosses.moveTo(x + d, y - d); crosses.lineTo(x - d, y + d);
    }
  }
  for (const [colour, p] of bodies) { g.fillStyle = colour; g.fill(p); }
  g.lineWidth = 1 * dpr;
  g.strokeStyle = '#0006';
  if (!small) for (const p of bodies.values()) g.stroke(p);
  g.strokeStyle = '#000'; g.lineWidth = 1.4 * dpr; g.stroke(heads);
  g.strokeStyle = '#8250df'; g.lineWidth = 1 * dpr; g.stroke(rings);
  g.strokeStyle = '#fff'; g.lineWidth = 1.5 * dpr; g.stroke(crosses);
  const mark = (k, colour, width) => {
    const r = drawn[k];
    if (!r) return;
    g.strokeStyle = colour; g.lineWidth = width * dpr;
    g.beginPath(); g.arc(sx(r.x), sy(r.y), rad + 5 * dpr, 0, 2 * Math.PI); g.stroke();
  };
  if (V.highlight) for (const k of V.highlight.robots) mark(k, '#ff00aa', 3);
  if (V.selected != null) {
    mark(V.selected, '#000', 2);
    const r = drawn[V.selected];
    if (r && V.meta.radio_range > 0 && V.meta.radio_range * s < mapCanvas.width * 2) {
      g.setLineDash([3 * dpr, 4 * dpr]); g.strokeStyle = '#0005'; g.lineWidth = 1 * dpr;
      g.beginPath(); g.arc(sx(r.x), sy(r.y), V.meta.radio_range * s, 0, 2 * Math.PI); g.stroke();
      g.setLineDash([]);
    }
  }
  return drawn;
}

function drawSide(frame) {
  if (sideCanvas.hidden) return;
  const g = sideCanvas.getContext('2d');
  const w = sideCanvas.width, h = sideCanvas.height, dpr = V.view.dpr;
  g.fillStyle = '#fff'; g.fillRect(0, 0, w, h);
  const [, y0, , y1] = V.meta.map.bounds;
  const top = V.meta.map.height || 5;
  const pad = 20 * dpr;
  const s = Math.min((w - 2 * pad) / top, (h - 2 * pad) / (y1 - y0));
  const X = (z) => pad + z * s, Y = (y) => h - pad - (y - y0) * s;
  g.strokeStyle = '#555'; g.lineWidth = 1 * dpr;
  g.strokeRect(X(0), Y(y1), top * s, (y1 - y0) * s);
  g.fillStyle = '#777'; g.font = `${11 * dpr}px system-ui`;
  g.fillText('side view: height (→) against y (↑)', pad, 14 * dpr);
  const map = V.meta.map;
  for (const o of map.circles || []) {
    g.fillStyle = '#c9ced6';
    g.fillRect(X(0), Y(o.y + o.r), (o.height || top) * s, 2 * o.r * s);
  }
  for (const o of map.rectangles || []) {
    g.fillStyle = '#c9ced6';
    g.fillRect(X(0), Y(o.y_max), (o.height || top) * s, (o.y_max - o.y_min) * s);
  }
  for (const goal of V.meta.goals) {
    if (goal.z == null) continue;
    g.strokeStyle = '#2da44e';
    g.beginPath(); g.arc(X(goal.z), Y(goal.y), Math.max(3, goal.radius * s), 0, 2 * Math.PI); g.stroke();
  }
  const rad = Math.max(2 * dpr, V.meta.radius * s);
  for (let k = 0; k < V.meta.robots; k++) {
    const r = robotAt(frame, k);
    if (!r) return;
    g.fillStyle = fillOf(r);
    g.beginPath(); g.arc(X(r.z), Y(r.y), rad, 0, 2 * Math.PI); g.fill();
  }
}

function drawMap() {
  const frame = V.frame;
  ensure(frame);
  if (!chunkFor(frame)) return false;
  if (!V.staticMap) drawStatic();
  const g = mapCanvas.getContext('2d');
  g.drawImage(V.staticMap, 0, 0);
  if (V.radio && V.strip) drawRadio(g, frame);
  if (V.trails) drawTrails(g, frame);
  V.drawnFrame = drawRobots(g, frame);
  V.drawnAt = frame;
  if (V.legendStale) { V.legendStale = false; legend(); }
  drawSide(frame);
  return true;
}

// ---------------------------------------------------------------- timeline and lanes

function tickSpan() {
  const first = V.status ? V.status.first_tick : 0;
  const last = Math.max(V.meta.ticks_planned, V.status ? V.status.last_tick : 0);
  return [first, Math.max(first + 1, last)];
}

function markerRow(kind) {
  const i = MARKER_ROWS.indexOf(kind);
  return i < 0 ? MARKER_ROWS.length - 1 : i;
}

function drawTimeline() {
  const g = eventsCanvas.getContext('2d');
  const w = eventsCanvas.width, h = eventsCanvas.height, dpr = V.view.dpr;
  g.fillStyle = '#fff'; g.fillRect(0, 0, w, h);
  const left = 70 * dpr, right = w - 8 * dpr;
  const stripH = V.strip ? 26 * dpr : 0;
  const rows = MARKER_ROWS.length, rowH = (h - stripH - 4 * dpr) / rows;
  const [t0, t1] = tickSpan();
  const X = (t) => left + (t - t0) / (t1 - t0) * (right - left);
  g.font = `${10 * dpr}px system-ui`;
  g.textBaseline = 'middle';
  MARKER_ROWS.forEach((k, i) => {
    g.fillStyle = '#888'; g.fillText(k, 4 * dpr, (i + 0.5) * rowH);
    g.fillStyle = i % 2 ? '#fafafa' : '#fff'; g.fillRect(left, i * rowH, right - left, rowH);
  });
  // partitions and blackouts as shaded spans
  const open = {};
  for (const m of V.markers) {
    if (m.kind !== 'radio') continue;
    const what = m.text.split(':')[0];
    const base = what.replace(/ (start|end)$/, '');
    if (/ start$/.test(what)) open[base] = m.tick;
    else if (/ end$/.test(what) && open[base] != null) {
      g.fillStyle = 'rgba(130,80,223,0.12)';
      g.fillRect(X(open[base]), 0, Math.max(1, X(m.tick) - X(open[base])), h - stripH);
      delete open[base];
    }
  }
  for (const base in open) {
    g.fillStyle = 'rgba(130,80,223,0.12)';
    g.fillRect(X(open[base]), 0, Math.max(1, X(t1) - X(open[base])), h - stripH);
  }
  V.markerBoxes = [];
  for (let i = 0; i < V.markers.length; i++) {
    const m = V.markers[i];
    const kind = MARKER_ROWS.includes(m.kind) ? m.kind : 'notes';
    const row = markerRow(kind);
    const x = X(m.tick), y = (row + 0.5) * rowH;
    g.fillStyle = MARKER_COLOUR[kind];
    g.fillRect(x - 1.5 * dpr, y - rowH * 0.35, 3 * dpr, rowH * 0.7);
    V.markerBoxes.push([x, y, i]);
  }
  if (V.strip) {
    const y0 = h - stripH, mid = y0 + stripH / 2;
    let max = 1;
    for (let i = 0; i < V.strip.ticks.length; i++) max = Math.max(max, V.strip.delivered[i], V.strip.dropped[i]);
    g.fillStyle = '#888'; g.fillText('radio', 4 * dpr, mid);
    for (let i = 0; i < V.strip.ticks.length; i++) {
      const x = X(V.strip.ticks[i]);
      const up = V.strip.delivered[i] / max * (stripH / 2 - 1), down = V.strip.dropped[i] / max * (stripH / 2 - 1);
      g.fillStyle = '#2da44e'; g.fillRect(x, mid - up, Math.max(1, dpr), up);
      g.fillStyle = '#d73a49'; g.fillRect(x, mid, Math.max(1, dpr), down);
    }
  }
  const cur = X(tickOf(V.frame));
  g.strokeStyle = '#000'; g.lineWidth = 1.5 * dpr;
  g.beginPath(); g.moveTo(cur, 0); g.lineTo(cur, h); g.stroke();
  if (V.status) {
    g.fillStyle = 'rgba(0,0,0,0.05)';
    g.fillRect(X(V.status.last_tick), 0, right - X(V.status.last_tick), h);
  }
}

function drawLanes() {
  if (lanesCanvas.hidden) return;
  const g = lanesCanvas.getContext('2d');
  const w = lanesCanvas.width, h = lanesCanvas.height, dpr = V.view.dpr;
  g.fillStyle = '#fff'; g.fillRect(0, 0, w, h);
  const n = V.meta.robots;
  const left = 70 * dpr, right = w - 8 * dpr;
  const commitH = 22 * dpr;
  const rowH = Math.max(2 * dpr, (h - commitH) / n);
  const [t0, t1] = tickSpan();
  const X = (t) => left + (t - t0) / (t1 - t0) * (right - left);
  const end = V.status ? V.status.last_tick : t1;
  const state = Array.from({ length: n }, () => ({ tick: t0, role: 'follower', term: 0 }));
  g.font = `${Math.min(10 * dpr, rowH)}px system-ui`;
  g.textBaseline = 'middle';
  const seg = (k, until) => {
    const s = state[k];
    g.fillStyle = LANE_COLOUR[s.role] || '#ccc';
    g.fillRect(X(s.tick), k * rowH + 0.5, Math.max(1, X(until) - X(s.tick)), rowH - 1);
    if (s.role === 'leader' && rowH >= 8 * dpr && X(until) - X(s.tick) > 24 * dpr) {
      g.fillStyle = '#fff'; g.fillText(`t${s.term}`, X(s.tick) + 2 * dpr, (k + 0.5) * rowH);
    }
  };
  let commit = 0, commitPath = [[t0, 0]];
  // A robot's lane ends at its death: a dead leader is no leader (deaths merged in tick order).
  const deaths = V.markers.filter((m) => m.kind === 'died')
    .flatMap((m) => m.robots.map((robot) => ({ tick: m.tick, robot, role: 'dead' })));
  const points = V.lanes.concat(deaths).sort((a, b) => a.tick - b.tick);
  for (const p of points) {
    if (p.robot >= n) continue;
    const s = state[p.robot];
    if (p.role != null || p.term != null) {
      seg(p.robot, p.tick);
      if (p.role != null) s.role = p.role;
      if (p.term != null) s.term = p.term;
      s.tick = p.tick;
    }
    if (p.commit != null && p.commit > commit) { commit = p.commit; commitPath.push([p.tick, commit]); }
  }
  for (let k = 0; k < n; k++) seg(k, end);
  if (rowH >= 7 * dpr) {
    g.fillStyle = '#888';
    for (let k = 0; k < n; k++) g.fillText(`robot ${k}`, 4 * dpr, (k + 0.5) * rowH);
  } else {
    g.fillStyle = '#888'; g.fillText(`${n} robots`, 4 * dpr, 8 * dpr);
  }
  const y0 = h - commitH;
  g.fillStyle = '#888'; g.fillText(`commit ${commit}`, 4 * dpr, y0 + commitH / 2);
  g.strokeStyle = '#1f6feb'; g.lineWidth = 1.5 * dpr;
  g.beginPath();
  const Y = (c) => h - 3 * dpr - (commit ? c / commit : 0) * (commitH - 6 * dpr);
  commitPath.forEach(([t, c], i) => {
    if (i) g.lineTo(X(t), Y(commitPath[i - 1][1]));
    i ? g.lineTo(X(t), Y(c)) : g.moveTo(X(t), Y(c));
  });
  g.lineTo(X(end), Y(commit));
  g.stroke();
  const cur = X(tickOf(V.frame));
  g.strokeStyle = '#000'; g.lineWidth = 1.5 * dpr;
  g.beginPath(); g.moveTo(cur, 0); g.lineTo(cur, h); g.stroke();
}

// ---------------------------------------------------------------- panel

function legend() {
  const parts = [];
  const add = (colour, name) => parts.push(`<span><i style="background:${colour}"></i>${name}</span>`);
  const seen = [...V.rolesSeen].sort((a, b) => a - b).filter((i) => V.meta.roles[i]);
  if (seen.length) seen.forEach((i) => add(V.meta.roles[i].colour, V.meta.roles[i].name));
  else add(STATE_FILL[ACTIVE], 'active');
  add(STATE_FILL[DOWN], 'down'); add(STATE_FILL[DEAD], 'dead');
  add(STATE_FILL[3], 'frozen'); add(STATE_FILL[4], 'restarting');
  parts.push('<span><i style="background:#fff;border:2px solid #8250df"></i>lidar on</span>');
  if (V.meta.consensus) {
    for (const [name, colour] of Object.entries(LANE_COLOUR)) add(colour, `lane: ${name.replace('_', '-')}`);
  }
  if (V.strip) parts.push('<span><i style="background:#2da44e"></i>frame delivered</span><span><i style="background:#d73a49"></i>dropped</span>');
  $('legend').innerHTML = parts.join('');
}

function esc(s) { return String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c])); }

let inspectSeq = 0, inspectAt = 0;
async function inspect(force) {
  if (V.selected == null) return;
  const now = performance.now();
  if (!force && V.inspect && V.inspect.frame === V.frame) return;
  if (!force && now - inspectAt < 250) {
    // at most four requests a second while playing, and always one for where it stops
    clearTimeout(V.inspectLater);
    V.inspectLater = setTimeout(() => inspect(false), 260);
    return;
  }
  inspectAt = now;
  const seq = ++inspectSeq, frame = V.frame, id = V.selected;
  try {
    const info = await getJson(`/api/robot?id=${id}&frame=${frame}`);
    if (seq !== inspectSeq) return;
    V.inspect = { frame, ...info };
    const r = info.row;
    const deg = (r.theta * 180 / Math.PI).toFixed(1);
    const speed = r.vz != null ? `${r.v.toFixed(3)} m/s, vertical ${r.vz.toFixed(3)} m/s` : `${r.v.toFixed(3)} m/s`;
    const rows = [
      ['robot', r.id], ['tick', r.tick],
      ['pose', `x ${r.x.toFixed(3)}, y ${r.y.toFixed(3)}${r.z != null ? `, z ${r.z.toFixed(3)}` : ''}, θ ${deg}°`],
      ['speed', speed], ['turn', `${r.omega.toFixed(3)} rad/s`], ['state', r.state],
      ['lidar', r.lidar ? 'on' : 'off'],
    ];
    if (info.role) rows.push(['role', info.role]);
    const notes = info.notes.length
      ? info.notes.map((n) => `<pre>${n.tick}: ${esc(JSON.stringify(n.note))}</pre>`).join('')
      : '<span class="hint">none yet</span>';
    rows.push(['notes', notes]);
    $('inspector').innerHTML = `<table>${rows.map(([k, v]) => `<tr><td>${k}</td><td>${k === 'notes' ? v : esc(v)}</td></tr>`).join('')}</table>`;
  } catch (e) {
    if (seq === inspectSeq) $('inspector').innerHTML = `<p class="hint">${esc(e)}</p>`;
  }
}

let listedUpTo = -1, listedCurrent = -1;
function eventList(force) {
  // The 200 markers nearest the current tick: enough to click through, cheap for big runs.
  const tick = tickOf(V.frame);
  let k = 0, lo = 0, hi = V.markers.length;
  while (lo < hi) { const mid = (lo + hi) >> 1; if (V.markers[mid].tick < tick) lo = mid + 1; else hi = mid; }
  k = lo;
  const from = Math.max(0, k - 100), to = Math.min(V.markers.length, from + 200);
  if (!force && from === listedUpTo && k === listedCurrent) return;
  listedUpTo = from; listedCurrent = k;
  const ol = $('events');
  ol.innerHTML = '';
  for (let i = from; i < to; i++) {
    const m = V.markers[i];
    const li = document.createElement('li');
    li.dataset.index = i;
    li.dataset.tick = m.tick;
    li.className = `marker ${m.kind}${m.tick === tick ? ' current' : ''}`;
    li.innerHTML = `<b>${m.tick}</b><span style="color:${MARKER_COLOUR[m.kind] || MARKER_COLOUR.notes}">■</span> ${esc(m.text)}`;
    ol.appendChild(li);
  }
}

// ---------------------------------------------------------------- controls

function setFrame(f, keepFollow) {
  const last = lastFrame();
  f = Math.max(0, Math.min(last, Math.round(f)));
  V.frame = f;
  V.pos = f;
  if (!keepFollow) V.following = false;
  $('scrub').value = f;
  V.dirty = true;
}

function jumpToMarker(i) {
  const m = V.markers[i];
  if (!m) return;
  V.playing = false;
  setFrame(frameOfTick(m.tick));
  V.highlight = { robots: m.robots, index: i };
  if (m.robots.length) { V.selected = m.robots[0]; inspect(true); }
  eventList(true);
}

function neighbourMarker(dir) {
  const tick = tickOf(V.frame);
  if (dir > 0) {
    const i = V.markers.findIndex((m) => m.tick > tick);
    if (i >= 0) jumpToMarker(i);
  } else {
    for (let i = V.markers.length - 1; i >= 0; i--) if (V.markers[i].tick < tick) { jumpToMarker(i); break; }
  }
}

function togglePlay(on) {
  V.playing = on != null ? on : !V.playing;
  if (V.playing && V.frame >= lastFrame() && !(V.status && V.status.state === 'live')) setFrame(0);
  V.lastNow = performance.now();
  $('play').innerHTML = V.playing ? '<b>||</b>' : '&#x25B6;&#xFE0E;';
}

function bind() {
  $('play').onclick = () => { V.following = false; togglePlay(); };
  $('step-back').onclick = () => { togglePlay(false); setFrame(V.frame - 1); };
  $('step-fwd').onclick = () => { togglePlay(false); setFrame(V.frame + 1); };
  $('prev-event').onclick = () => neighbourMarker(-1);
  $('next-event').onclick = () => neighbourMarker(1);
  $('follow').onclick = () => { V.following = true; togglePlay(false); setFrame(lastFrame(), true); };
  $('speed').onchange = (e) => { V.speed = Number(e.target.value); };
  $('scrub').oninput = (e) => { setFrame(Number(e.target.value)); };
  $('trails').onchange = (e) => { V.trails = e.target.checked; V.dirty = true; };
  $('radio').onchange = (e) => { V.radio = e.target.checked; V.dirty = true; };
  $('events').onclick = (e) => {
    const li = e.target.closest('li');
    if (li) jumpToMarker(Number(li.dataset.index));
  };
  mapCanvas.addEventListener('click', (e) => {
    const r = mapCanvas.getBoundingClientRect(), dpr = V.view.dpr;
    const px = (e.clientX - r.left) * dpr, py = (e.clientY - r.top) * dpr;
    const hit = robotNear(px, py);
    V.selected = hit;
    V.inspect = null;
    if (hit == null) $('inspector').innerHTML = '<p class="hint">Click a robot to see it.</p>';
    else inspect(true);
    V.dirty = true;
  });
  mapCanvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    const r = mapCanvas.getBoundingClientRect(), dpr = V.view.dpr;
    const px = (e.clientX - r.left) * dpr, py = (e.clientY - r.top) * dpr;
    const x = wx(px), y = wy(py);
    V.zoom = Math.max(0.5, Math.min(200, (V.zoom || 1) * (e.deltaY < 0 ? 1.2 : 1 / 1.2)));
    layout();
    // keep the point under the cursor where it was
    V.centre = [x - (px - mapCanvas.width / 2) / V.view.s, y + (py - mapCanvas.height / 2) / V.view.s];
    layout();
  }, { passive: false });
  let drag = null;
  mapCanvas.addEventListener('mousedown', (e) => { drag = { x: e.clientX, y: e.clientY, moved: false }; });
  window.addEventListener('mouseup', () => { drag = null; });
  mapCanvas.addEventListener('mousemove', (e) => {
    if (!drag || !(e.buttons & 1)) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    if (Math.abs(dx) + Math.abs(dy) < 3) return;
    const [x0, y0, x1, y1] = V.meta.map.bounds;
    const c = V.centre || [(x0 + x1) / 2, (y0 + y1) / 2];
    V.centre = [c[0] - dx * V.view.dpr / V.view.s, c[1] + dy * V.view.dpr / V.view.s];
    drag.x = e.clientX; drag.y = e.clientY;
    layout();
  });
  mapCanvas.addEventListener('dblclick', () => { V.zoom = 1; V.centre = null; layout(); });
  eventsCanvas.addEventListener('click', (e) => {
    const i = markerNear(e);
    if (i != null) jumpToMarker(i);
    else {
      const r = eventsCanvas.getBoundingClientRect(), dpr = V.view.dpr;
      const left = 70 * dpr, right = eventsCanvas.width - 8 * dpr;
      const [t0, t1] = tickSpan();
      const t = t0 + ((e.clientX - r.left) * dpr - left) / (right - left) * (t1 - t0);
      setFrame(frameOfTick(Math.round(t)));
    }
  });
  eventsCanvas.addEventListener('mousemove', (e) => {
    const i = markerNear(e), tip = $('tooltip');
    if (i == null) { tip.hidden = true; return; }
    const m = V.markers[i];
    tip.textContent = `tick ${m.tick}: ${m.text}`;
    tip.style.left = `${e.offsetX + 12}px`; tip.style.top = `${e.offsetY - 24}px`;
    tip.hidden = false;
  });
  eventsCanvas.addEventListener('mouseleave', () => { $('tooltip').hidden = true; });
  window.addEventListener('keydown', (e) => {
    if (e.target.tagName === 'INPUT' || e.target.tagName === 'SELECT') return;
    if (e.key === ' ') { e.preventDefault(); $('play').click(); }
    else if (e.key === 'ArrowLeft') $('step-back').click();
    else if (e.key === 'ArrowRight') $('step-fwd').click();
    else if (e.key === '[') neighbourMarker(-1);
    else if (e.key === ']') neighbourMarker(1);
  });
  window.addEventListener('resize', layout);
}

function robotNear(px, py) {
  if (!V.drawnFrame) return null;
  const rad = Math.max(8 * V.view.dpr, V.meta.radius * V.view.s * 1.2);
  let best = null, bestD = rad * rad;
  V.drawnFrame.forEach((r, k) => {
    const dx = sx(r.x) - px, dy = sy(r.y) - py, d = dx * dx + dy * dy;
    if (d <= bestD) { best = k; bestD = d; }
  });
  return best;
}

function markerNear(e) {
  const r = eventsCanvas.getBoundingClientRect(), dpr = V.view.dpr;
  const px = (e.clientX - r.left) * dpr, py = (e.clientY - r.top) * dpr;
  let best = null, bestD = (6 * dpr) ** 2;
  for (const [x, y, i] of V.markerBoxes) {
    const d = (x - px) ** 2 + ((y - py) / 3) ** 2;
    if (d <= bestD) { best = i; bestD = d; }
  }
  return best;
}

// ---------------------------------------------------------------- live data

async function pullIncrements() {
  const s = V.status;
  if (!s) return;
  if (s.markers > 0 && (s.markers > V.markers.length || s.frames !== V.markersAt)) {
    // from the last one known: a behaviour's headline may have joined it since
    const from = Math.max(0, V.markers.length - 1);
    const more = await getJson(`/api/markers?from=${from}`);
    V.markers.splice(from, V.markers.length - from, ...more);
    V.markersAt = s.frames;
    eventList(true);
  }
  if (s.lanes > V.lanes.length) {
    const more = await getJson(`/api/lanes?from=${V.lanes.length}`);
    V.lanes.push(...more);
    if (lanesCanvas.hidden) { lanesCanvas.hidden = false; layout(); }
  }
  if (s.radio_frames != null && (!V.strip || s.radio_frames > V.strip.ticks.length)) {
    const have = V.strip ? V.strip.ticks.length : 0;
    const more = await getJson(`/api/radio/strip?from=${have}`);
    if (!V.strip) { V.strip = { ticks: [], delivered: [], dropped: [] }; legend(); }
    V.strip.ticks.push(...more.ticks);
    V.strip.delivered.push(...more.delivered);
    V.strip.dropped.push(...more.dropped);
  }
  V.dirty = true;
}

// The radio copies of the ticks of `frame`'s chunk, fetched once per chunk (a live run's
// newest chunk: only the ticks that are new), retried after a failure no sooner than 2 s.
function loadLinks(frame) {
  if (!V.strip || !V.radio || !V.status.frames) return;
  const c = chunkOf(frame), cf = V.meta.chunk_frames;
  const last = Math.min(lastFrame(), (c + 1) * cf - 1);
  const want = tickOf(last) + 1;
  let have = V.linkChunks.get(c);
  if (!have) { have = { end: tickOf(c * cf), busy: false, retry: 0 }; V.linkChunks.set(c, have); }
  if (have.busy || have.end >= want || performance.now() < have.retry) return;
  have.busy = true;
  fetch(`/api/radio/links?from=${have.end}&to=${want - 1}`)
    .then((r) => { if (!r.ok) throw new Error(`radio links: ${r.status}`); return r.arrayBuffer(); })
    .then((buf) => {
      const u = new Uint32Array(buf);
      if (u[0] !== 0x52565753) throw new Error('not a radio chunk');
      const k = u[1];
      let at = 2 + 2 * k;
      for (let i = 0; i < k; i++) {
        const tick = u[2 + 2 * i], n = u[3 + 2 * i];
        V.links.set(tick, u.subarray(at, at + 3 * n));
        at += 3 * n;
      }
      have.end = want;
      V.dirty = true;
    })
    .catch(() => { have.retry = performance.now() + 2000; })
    .finally(() => { have.busy = false; });
}

function onStatus(s) {
  const was = V.status;
  V.status = s;
  const badge = $('state');
  badge.textContent = s.state === 'complete' ? 'replay' : s.state;
  badge.className = `badge ${s.state}`;
  $('scrub').max = Math.max(0, s.frames - 1);
  const banner = $('banner');
  if (s.banner) { banner.textContent = s.banner; banner.hidden = false; } else banner.hidden = true;
  const live = s.state === 'live';
  $('follow').hidden = !live;
  if (live && (!was || was.frames === 0)) V.following = true;
  if (!live) V.following = false;
  if (V.following) setFrame(lastFrame(), true);
  pullIncrements().catch((e) => fail(String(e)));
  V.dirty = true;
}

function listen() {
  const es = new EventSource('/api/live');
  es.onmessage = (e) => onStatus(JSON.parse(e.data));
  es.onerror = () => {
    if (V.status && V.status.state !== 'live') { es.close(); return; }
    // the browser reconnects on its own; say so only if it stays away
    setTimeout(() => { if (es.readyState === EventSource.CLOSED) fail('lost the connection to swarm view'); }, 3000);
  };
}

// ---------------------------------------------------------------- the loop

function loop(now) {
  requestAnimationFrame(loop);
  if (!V.meta || !V.status) return;
  if (V.playing) {
    // rAF's time is when the frame began, which can be before a click's performance.now()
    const dt = Math.max(0, Math.min(0.25, (now - (V.lastNow || now)) / 1000));
    const next = V.pos + dt * V.speed / V.meta.dt;
    const last = lastFrame();
    if (chunkFor(Math.min(last, Math.floor(next))) || Math.floor(next) === V.frame) {
      V.pos = Math.min(last, next);
      const f = Math.floor(V.pos);
      if (f !== V.frame) { V.frame = f; $('scrub').value = f; V.dirty = true; }
      if (V.pos >= last && V.status.state !== 'live') togglePlay(false);
    } else {
      ensure(Math.floor(next));
    }
    // prefetch ahead
    ensure(Math.min(last, V.frame + V.meta.chunk_frames));
  }
  V.lastNow = now;
  if (V.dirty) {
    if (V.radio) loadLinks(V.frame);
    if (drawMap()) {
      V.dirty = false;
      V.drawn++;
      V.fpsFrames++;
      drawTimeline();
      drawLanes();
      const tick = tickOf(V.frame);
      $('tick').textContent = `tick ${tick} / ${V.status.last_tick} · ${(tick * V.meta.dt).toFixed(1)} s`;
      $('clock').textContent = `${V.status.frames} ticks recorded`;
      eventList(false);
      inspect(false);
    }
  }
  if (now - V.fpsSince >= 1000) {
    V.fps = V.fpsFrames * 1000 / (now - V.fpsSince);
    V.fpsFrames = 0;
    V.fpsSince = now;
  }
}

async function main() {
  try {
    V.meta = await getJson('/api/meta');
  } catch (e) {
    fail(`cannot load the run: ${e}`);
    return;
  }
  document.title = `swarm view: ${V.meta.name}`;
  $('title').textContent = `${V.meta.name} · ${V.meta.robots} robots · ${V.meta.behaviour}`;
  if (V.meta.aerial) sideCanvas.hidden = false;
  if (V.meta.consensus) lanesCanvas.hidden = false;
  legend();
  bind();
  layout();
  V.fpsSince = performance.now();
  listen();
  V.ready = true;
  requestAnimationFrame(loop);
}

// What the page has drawn, for tests and scripts (read-only).
window.swarmView = {
  get ready() { return V.ready && !!V.status && !!V.drawnFrame; },
  get error() { return V.error; },
  get frame() { return V.frame; },
  get tick() { return tickOf(V.frame); },
  get drawnFrame() { return V.drawnAt; },
  get playing() { return V.playing; },
  get following() { return V.following; },
  get speed() { return V.speed; },
  get status() { return V.status; },
  get meta() { return V.meta; },
  get markers() { return V.markers; },
  get lanes() { return V.lanes.length; },
  get radioTicks() { return V.strip ? V.strip.ticks.length : 0; },
  get drawn() { return V.drawn; },
  get fps() { return V.fps; },
  get selected() { return V.selected; },
  get inspected() { return V.inspect; },
  get highlight() { return V.highlight; },
  get cacheBytes() { return V.cacheBytes; },
  // the drawn robot k (position as the frame holds it) and where it is on the map canvas
  robot(k) { return V.drawnFrame ? V.drawnFrame[k] : null; },
  screenOf(k) {
    const r = V.drawnFrame && V.drawnFrame[k];
    if (!r) return null;
    const box = mapCanvas.getBoundingClientRect();
    return { x: sx(r.x) / V.view.dpr, y: sy(r.y) / V.view.dpr, width: box.width, height: box.height };
  },
  linksAt(tick) { const l = V.links.get(tick); return l ? Array.from(l) : null; },
};

main();
