"use strict";
// The console's plots (gateway/console.html loads this file before its own script): time plots and waveforms
// drawn by uPlot (gateway/vendor/uplot/), and canvas drawings of its own for what uPlot does not draw
// (pictures, dials of angles, the level meter, the floor map).  Every axis says its unit, read from /info
// (docs/protocol.md: a member's `unit`, a sequence's `grid`).  Helpers of the page's script used here at
// draw time: el, round, at, NUMERIC.

const COLORS = ["#0550ae", "#c4432b", "#1a7f37", "#8250df", "#bf8700"];

// ---- units (docs/protocol.md: a member's or a parameter's `unit`, a sequence's `grid`) ------------------

/** How a unit is shown: angles in degrees (a person reads 45°, not 0.785), the others as declared. */
function display(unit) {
  if (unit === "rad") return { unit: "deg", scale: 180 / Math.PI };
  if (unit === "rad/s") return { unit: "deg/s", scale: 180 / Math.PI };
  return { unit: unit || "", scale: 1 };
}

/** The description of the member at *path* of type *t* ({name, type, unit?, grid?, doc?}), or null. */
function memberAt(t, path) {
  let member = null;
  for (const name of path) {
    if (!t || t.kind !== "struct") return null;
    member = t.members.find((m) => m.name === name) || null;
    if (!member) return null;
    t = member.type;
  }
  return member;
}

/** A number as a plot's caption shows it: four significant digits (-6.177, 45.2, 0.0123). */
const brief = (value) => (Number.isInteger(value) ? value : Number(value.toPrecision(4)));
const labelOf = (name, unit) => (unit ? `${name} (${unit})` : name);
const isAngle = (member) => Boolean(member && (member.unit === "deg" || member.unit === "rad"));

/** The paths of the angle members of a type (unit deg or rad), and of its sequences sampled over angles. */
function anglePaths(t, prefix) {
  if (t.kind !== "struct") return [];
  return t.members.flatMap((m) => {
    const path = [...prefix, m.name];
    if (NUMERIC.has(m.type.kind) && isAngle(m)) return [path];
    if (["sequence", "array"].includes(m.type.kind) && m.grid && (m.grid.unit === "deg" || m.grid.unit === "rad")) return [path];
    return anglePaths(m.type, path);
  });
}

/** A step of 1, 2 or 5 times a power of ten that cuts *span* into about five. */
function niceStep(span) {
  const raw = span / 5, power = 10 ** Math.floor(Math.log10(raw)), f = raw / power;
  return (f <= 1 ? 1 : f <= 2 ? 2 : f <= 5 ? 5 : 10) * power;
}

/**
 * The value range of a plot, following its recent values: kept while they fit and fill at least half of
 * it (a plot that does not jump at every read), made again around them otherwise, so that a homing to
 * -179.6° does not squash the ±60° moves that follow once it is RECENT seconds old.
 */
function followRange(current, values) {
  if (!values.length) return current || [-1, 1];
  let low = Math.min(...values), high = Math.max(...values);
  const least = Math.max(Math.abs(low), Math.abs(high)) * 0.02 || 1;   // a steady value: ±1 % of itself
  if (high - low < least) { const middle = (low + high) / 2; low = middle - least / 2; high = middle + least / 2; }
  if (current && low >= current[0] && high <= current[1] && high - low >= 0.5 * (current[1] - current[0])) return current;
  const pad = (high - low) * 0.08, step = niceStep(high - low + 2 * pad);
  return [Math.floor((low - pad) / step) * step, Math.ceil((high + pad) / step) * step];
}

const AXIS = { stroke: "#333", font: "11px system-ui, sans-serif", labelFont: "12px system-ui, sans-serif",
               grid: { stroke: "#e8e8e8", width: 1 }, ticks: { stroke: "#ccc", width: 1 } };
const SPAN = 30;     // seconds of a time plot
const RECENT = 10;   // seconds its value range follows

/** A plot of one number over the last SPAN seconds (uPlot): a time axis in seconds, a value axis in its unit. */
class TimeSeries {
  constructor(name, member) {
    const shown = display(member && member.unit);
    this.scale = shown.scale;
    this.label = labelOf(name, shown.unit);
    this.times = []; this.values = []; this.range = null;
    this.element = el("div", null, { class: "series", "data-member": name, "data-x-label": "time (s)",
                                     "data-y-label": this.label });
    this.caption = el("div", "", { class: "caption" });
    const chart = el("div");
    this.element.append(chart, this.caption);
    this.plot = new uPlot({
      width: 560, height: 170, legend: { show: false }, cursor: { show: false },
      scales: { x: { time: false, range: () => [-SPAN, 0] }, y: { range: () => this.range || [-1, 1] } },
      axes: [{ ...AXIS, label: "time (s)" }, { ...AXIS, label: this.label, size: 64 }],
      series: [{}, { stroke: COLORS[0], width: 1.5, points: { show: false } }],
    }, [[], []], chart);
  }
  add(t, v) {
    this.times.push(t); this.values.push(Number.isFinite(v) ? v * this.scale : null);
    while (this.times.length && this.times[0] < t - SPAN) { this.times.shift(); this.values.shift(); }
  }
  draw(now) {
    const recent = this.values.filter((v, i) => v !== null && this.times[i] >= now - RECENT);
    this.range = followRange(this.range, recent);
    this.plot.setData([this.times.map((t) => t - now), this.values]);
    const last = this.values.length ? this.values[this.values.length - 1] : null;
    this.caption.textContent = `${this.label}: ${last === null ? "—" : brief(last)} · the value axis follows the last ${RECENT} s`;
    this.element.dataset.points = String(this.values.length);
    this.element.dataset.range = this.range.map(round).join(" ");
  }
}

/** A peak meter of both channels in dBFS (-60…0), with its scale and the levels written beside it. */
class LevelMeter {
  constructor() {
    this.canvas = el("canvas", null, { width: 150, height: 290, class: "meter", "data-y-label": "peak (dBFS)" });
    this.levels = [-Infinity, -Infinity];
  }
  draw() {
    const c = this.canvas, g = c.getContext("2d"), top = 22, bottom = c.height - 40, left = 44, bar = 22;
    g.clearRect(0, 0, c.width, c.height);
    const y = (db) => top + (-Math.max(-60, Math.min(0, db)) / 60) * (bottom - top);
    g.font = "11px system-ui, sans-serif"; g.fillStyle = "#333"; g.strokeStyle = "#ccc"; g.textAlign = "right";
    for (let db = 0; db >= -60; db -= 10) {
      g.beginPath(); g.moveTo(left - 4, y(db)); g.lineTo(left + 2 * bar + 8, y(db)); g.stroke();
      g.fillText(String(db), left - 6, y(db) + 4);
    }
    this.levels.forEach((level, channel) => {
      const x = left + 2 + channel * (bar + 4);
      g.fillStyle = "#f0f0f0"; g.fillRect(x, top, bar, bottom - top);
      if (Number.isFinite(level)) {
        g.fillStyle = level > -3 ? "#c4432b" : level > -12 ? "#bf8700" : "#1a7f37";
        g.fillRect(x, y(level), bar, bottom - y(level));
      }
      g.fillStyle = "#333"; g.textAlign = "center";
      g.fillText(channel ? "R" : "L", x + bar / 2, bottom + 14);
    });
    g.textAlign = "left";
    g.fillText("peak (dBFS)", 4, 12);
    const shown = this.levels.map((l) => (Number.isFinite(l) ? l.toFixed(1) : "-∞"));
    g.fillText(`L ${shown[0]}  R ${shown[1]} dBFS`, 4, c.height - 8);
    c.dataset.levels = shown.join(" ");
  }
}

/** Two-channel audio as it arrives: each ear's min/max envelope over the last seconds (uPlot), and a peak meter. */
class Waveform {
  constructor() {
    this.seconds = 4;
    this.width = 440;   // columns: one min/max pair per pixel of the plot
    this.columns = [[], []];   // per channel: [min, max] per column, newest last, in full scale (-1…1)
    this.pending = [[], []];   // samples not yet making a whole column
    this.rate = 44100;
    this.chunks = 0;
    this.meter = new LevelMeter();
    this.element = el("div", null, { class: "waveform", "data-x-label": "time (s)" });
    const charts = el("div");
    this.plots = ["left", "right"].map((name, channel) => {
      const holder = el("div", null, { "data-y-label": `${name} (full scale)` });
      charts.append(holder);
      return new uPlot({
        width: 560, height: 150, legend: { show: false }, cursor: { show: false },
        scales: { x: { time: false, range: () => [-this.seconds, 0] }, y: { range: () => [-1, 1] } },
        axes: [{ ...AXIS, label: "time (s)" },
               { ...AXIS, label: `${name} (full scale)`, size: 50, splits: () => [-1, -0.5, 0, 0.5, 1] }],
        series: [{}, { stroke: COLORS[channel], width: 1, points: { show: false } },
                 { stroke: COLORS[channel], width: 1, points: { show: false } }],
        bands: [{ series: [1, 2], fill: channel ? "rgba(196,67,43,.45)" : "rgba(5,80,174,.45)" }],
      }, [[], [], []], holder);
    });
    this.element.append(charts, this.meter.canvas);
  }
  add(left, right, rate) {
    this.rate = rate || this.rate;
    const perColumn = Math.max(1, Math.round(this.rate * this.seconds / this.width));
    [left, right].forEach((samples, channel) => {
      let peak = 0;
      for (const s of samples) peak = Math.max(peak, Math.abs(s));
      if (samples.length) this.meter.levels[channel] = 20 * Math.log10(Math.max(peak, 1) / 2147483648);
      let pending = this.pending[channel];
      for (let i = 0; i < samples.length; i += perColumn) {
        pending = pending.concat(Array.from(samples.subarray(i, i + perColumn)));
        if (pending.length >= perColumn) {
          let low = Infinity, high = -Infinity;
          for (const s of pending) { low = Math.min(low, s); high = Math.max(high, s); }
          this.columns[channel].push([low / 2147483648, high / 2147483648]);
          pending = [];
        }
      }
      this.pending[channel] = pending;
      const extra = this.columns[channel].length - this.width;
      if (extra > 0) this.columns[channel].splice(0, extra);
    });
    this.chunks++;
    this.element.dataset.chunks = String(this.chunks);
  }
  draw() {
    const perColumn = Math.max(1, Math.round(this.rate * this.seconds / this.width));
    this.plots.forEach((plot, channel) => {
      const columns = this.columns[channel], n = columns.length;
      const xs = columns.map((_, i) => -(n - 1 - i) * perColumn / this.rate);
      plot.setData([xs, columns.map((c) => c[1]), columns.map((c) => c[0])]);
    });
    this.meter.draw();
  }
}

/** Draws tick labels along one edge of a canvas figure: *place* maps a value to pixels. */
function ticks(g, values, place, vertical, edge) {
  g.fillStyle = "#333"; g.strokeStyle = "#999"; g.font = "11px system-ui, sans-serif";
  g.textAlign = vertical ? "right" : "center";
  for (const v of values) {
    const p = place(v);
    g.beginPath();
    if (vertical) { g.moveTo(edge - 4, p); g.lineTo(edge, p); } else { g.moveTo(p, edge); g.lineTo(p, edge + 4); }
    g.stroke();
    if (vertical) g.fillText(String(round(v)), edge - 6, p + 4); else g.fillText(String(round(v)), p, edge + 15);
  }
  g.textAlign = "left";
}

/** The multiples of a step that cuts *start*…*end* into about five, from *start* to *end*. */
function steps(start, end) {
  const step = niceStep(end - start), out = [];
  for (let k = Math.ceil(start / step); k * step <= end + step * 1e-9; k++) out.push(k * step);
  return out;
}

/** An `rgba8` picture, scaled to 256 pixels, with pixel axes (x right, y down, as the image's rows). */
class Picture {
  constructor(name) {
    this.canvas = el("canvas", null, { class: "picture", width: 1, height: 1, "data-image": name,
                                       "data-x-label": "x (px)", "data-y-label": "y (px)" });
    this.pixels = document.createElement("canvas");
  }
  draw(image, bytes) {
    const w = image.width, h = image.height, box = 256, scale = Math.min(box / w, box / h);
    this.pixels.width = w; this.pixels.height = h;
    this.pixels.getContext("2d").putImageData(new ImageData(new Uint8ClampedArray(bytes.buffer, bytes.byteOffset, w * h * 4), w, h), 0, 0);
    const left = 48, top = 22, c = this.canvas;
    c.width = left + w * scale + 16; c.height = top + h * scale + 40;
    const g = c.getContext("2d");
    g.clearRect(0, 0, c.width, c.height);
    g.imageSmoothingEnabled = scale < 1;   // pixels shown as squares when enlarged, averaged when reduced
    g.drawImage(this.pixels, left, top, w * scale, h * scale);
    ticks(g, steps(0, w), (x) => left + x * scale, false, top + h * scale);
    ticks(g, steps(0, h), (y) => top + y * scale, true, left);
    g.fillText(`x (px) →   ${w} × ${h} px, ${image.encoding}`, left, c.height - 6);
    g.fillText("y (px) ↓", 2, 12);
    Object.assign(c.dataset, { left: String(left), top: String(top), scale: String(scale),
                                frames: String(Number(c.dataset.frames || 0) + 1) });
  }
}

/**
 * A dial of the angles of a port, seen from above with 0° ahead and positive angles to the left (counter-
 * clockwise), in degrees: a needle per angle member, and the sequences sampled over angles (a log-likelihood
 * per azimuth) as a ring of how likely each direction is.
 */
class Dial {
  constructor(type, paths) {
    this.needles = paths.filter((p) => NUMERIC.has(memberAt(type, p).type.kind)).map((p) => ({ path: p, member: memberAt(type, p) }));
    this.rings = paths.filter((p) => !NUMERIC.has(memberAt(type, p).type.kind)).map((p) => ({ path: p, member: memberAt(type, p) }));
    this.canvas = el("canvas", null, { width: 340, height: 330, class: "dial", "data-axis-label": "azimuth (deg, + = left)" });
    this.caption = el("div", "", { class: "caption" });
    this.element = el("div", null, { class: "dial-view" });
    this.element.append(this.canvas, this.caption);
  }
  draw(data) {
    const c = this.canvas, g = c.getContext("2d"), cx = c.width / 2, cy = 150, R = 112;
    g.clearRect(0, 0, c.width, c.height);
    const point = (deg, r) => [cx - Math.sin(deg * Math.PI / 180) * r, cy - Math.cos(deg * Math.PI / 180) * r];
    g.strokeStyle = "#ccc"; g.lineWidth = 1;
    for (const r of [R, R * 2 / 3, R / 3]) { g.beginPath(); g.arc(cx, cy, r, 0, 2 * Math.PI); g.stroke(); }
    g.font = "11px system-ui, sans-serif"; g.fillStyle = "#333"; g.textAlign = "center";
    for (let a = -150; a <= 180; a += 30) {
      g.strokeStyle = "#e4e4e4"; g.beginPath(); g.moveTo(cx, cy); g.lineTo(...point(a, R)); g.stroke();
      const [x, y] = point(a, R + 15);
      g.fillText(`${a}°`, x, y + 4);
    }
    const lines = [];
    this.rings.forEach(({ path, member }, k) => {
      const values = at(data, path);
      if (!values || !values.length) return;
      const grid = member.grid, toDeg = grid.unit === "rad" ? 180 / Math.PI : 1;
      let peak = -Infinity;
      for (const v of values) if (Number.isFinite(v)) peak = Math.max(peak, v);
      const inner = R - 34 - 8 * k, width = 30, share = (i) => (Number.isFinite(values[i]) ? Math.exp(values[i] - peak) : 0);
      const spread = Math.abs(grid.step * toDeg) / 2 + 0.3;
      for (let i = 0; i < values.length; i++) {
        const a = (grid.start + i * grid.step) * toDeg, p = share(i);
        if (p < 0.01) continue;
        g.fillStyle = `rgba(130,80,223,${(0.15 + 0.85 * p).toFixed(3)})`;
        g.beginPath();
        const from = (-90 - a - spread) * Math.PI / 180, to = (-90 - a + spread) * Math.PI / 180;
        g.arc(cx, cy, inner + width * p, from, to); g.arc(cx, cy, inner, to, from, true); g.fill();
      }
      lines.push(el("div", `${path.join(".")}: ring, how likely each direction is (exp of the log-likelihood, its peak = 1)`,
                    { class: "ring" }));
    });
    const confidence = Number(at(data, ["confidence"]));
    this.needles.forEach(({ path, member }, k) => {
      const shown = display(member.unit), value = Number(at(data, path)) * shown.scale;
      const name = path.join(".");
      const line = (text) => lines.push(el("div", text, { class: "needle", "data-color": String(k % COLORS.length) }));
      if (!Number.isFinite(value)) { line(`${name}: unknown`); return; }
      const color = COLORS[k % COLORS.length];
      g.strokeStyle = color; g.fillStyle = color; g.lineWidth = 2.5;
      g.beginPath(); g.moveTo(cx, cy); g.lineTo(...point(value, R * 0.92)); g.stroke();
      g.beginPath(); g.arc(...point(value, R * 0.92), 4, 0, 2 * Math.PI); g.fill();
      line(`${name}: ${brief(value)} deg` + (member.unit === "rad" ? " (from rad)" : ""));
    });
    if (Number.isFinite(confidence) && this.needles.length) lines.push(el("div", `confidence: ${brief(confidence)}`));
    g.lineWidth = 1; g.fillStyle = "#333"; g.textAlign = "left";
    g.fillText("azimuth (deg, + = left), 0° ahead", 4, c.height - 6);
    this.caption.replaceChildren(...lines);
    c.dataset.draws = String(Number(c.dataset.draws || 0) + 1);
  }
}

/** A top-down map of a position's trail (x right, y up, metres), with the heading when the data has one (w). */
class FloorMap {
  constructor(name) {
    this.name = name; this.trail = [];
    this.canvas = el("canvas", null, { width: 330, height: 330, class: "map", "data-x-label": "x (m)", "data-y-label": "y (m)" });
  }
  add(point) {
    const last = this.trail[this.trail.length - 1];
    if (!last || last.x !== point.x || last.y !== point.y || last.w !== point.w) this.trail.push(point);
    if (this.trail.length > 2000) this.trail.shift();
  }
  draw() {
    const c = this.canvas, g = c.getContext("2d"), left = 44, top = 10, size = c.width - left - 10;
    g.clearRect(0, 0, c.width, c.height);
    const xs = this.trail.map((p) => p.x), ys = this.trail.map((p) => p.y);
    // The view holds the whole trail and at least a metre around the origin.
    const half = Math.max(1, ...xs.map(Math.abs), ...ys.map(Math.abs)) * 1.1;
    const px = (x) => left + size / 2 + x / half * size / 2, py = (y) => top + size / 2 - y / half * size / 2;
    g.strokeStyle = "#ddd"; g.strokeRect(left, top, size, size);
    g.beginPath(); g.moveTo(left, py(0)); g.lineTo(left + size, py(0)); g.moveTo(px(0), top); g.lineTo(px(0), top + size); g.stroke();
    ticks(g, steps(-half, half), px, false, top + size);
    ticks(g, steps(-half, half), py, true, left);
    g.fillText("x (m) →", left + size - 44, top + size + 30);
    g.save(); g.translate(10, top + 40); g.rotate(-Math.PI / 2); g.fillText("y (m) →", -30, 0); g.restore();
    g.strokeStyle = COLORS[0]; g.beginPath();
    this.trail.forEach((p, i) => (i ? g.lineTo(px(p.x), py(p.y)) : g.moveTo(px(p.x), py(p.y))));
    g.stroke();
    const now = this.trail[this.trail.length - 1];
    if (now) {
      g.fillStyle = COLORS[1]; g.beginPath(); g.arc(px(now.x), py(now.y), 5, 0, 2 * Math.PI); g.fill();
      if (Number.isFinite(now.w)) {
        g.strokeStyle = COLORS[1]; g.beginPath(); g.moveTo(px(now.x), py(now.y));
        g.lineTo(px(now.x) + 14 * Math.cos(now.w), py(now.y) - 14 * Math.sin(now.w)); g.stroke();
      }
      g.fillStyle = "#222";
      g.fillText(`${this.name}: x ${round(now.x)} m, y ${round(now.y)} m`, left + 4, top + 14);
    }
    c.dataset.points = String(this.trail.length);
  }
}
