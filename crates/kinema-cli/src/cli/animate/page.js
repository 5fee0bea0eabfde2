// kinema's animation page: plays the poses in KINEMA_DATA on a canvas.
//
// Layers: a static one (grid, axes, paths of points, fixed points), redrawn
// when the size or a toggle changes, and the bodies drawn over it at every
// frame. What was drawn last is kept in `window.kinema.drawn` for tests.
(function () {
  const D = KINEMA_DATA;
  const nb = D.bodies.length;
  const nf = D.frames;

  // --- data -------------------------------------------------------------
  function bytes(b64) {
    const bin = atob(b64);
    const out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return new DataView(out.buffer);
  }
  const times = new Float64Array(nf);
  {
    const v = bytes(D.times);
    for (let k = 0; k < nf; k++) times[k] = v.getFloat64(8 * k, true);
  }
  // Poses x, y, phi per body per frame; x and y back in model coordinates.
  const poses = new Float64Array(nf * nb * 3);
  {
    const v = bytes(D.poses);
    const [cx, cy] = D.centre;
    for (let j = 0; j < nf * nb; j++) {
      poses[3 * j] = v.getFloat32(12 * j, true) + cx;
      poses[3 * j + 1] = v.getFloat32(12 * j + 4, true) + cy;
      poses[3 * j + 2] = v.getFloat32(12 * j + 8, true);
    }
  }
  const t0 = times[0];
  const tEnd = times[nf - 1];
  const [bx0, bx1, by0, by1] = D.bounds;
  const size = Math.max(bx1 - bx0, by1 - by0, 1e-12);

  function global(k, i, lx, ly, out) {
    const o = 3 * (k * nb + i);
    const x = poses[o], y = poses[o + 1], phi = poses[o + 2];
    const c = Math.cos(phi), s = Math.sin(phi);
    out[0] = x + c * lx - s * ly;
    out[1] = y + s * lx + c * ly;
    return out;
  }

  // Last frame whose time is at most t (0 before the start).
  function frameAt(t) {
    let lo = 0, hi = nf - 1;
    if (t >= times[hi]) return hi;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (times[mid] <= t) lo = mid; else hi = mid - 1;
    }
    return lo;
  }

  // --- elements ---------------------------------------------------------
  const $ = (id) => document.getElementById(id);
  const canvas = $("view");
  const ctx = canvas.getContext("2d");
  const layer = document.createElement("canvas");
  const lctx = layer.getContext("2d");
  const slider = $("slider");
  const playButton = $("play");
  const speedSelect = $("speed");
  const loopBox = $("loop");
  const framesBox = $("show-frames");
  const jointsBox = $("show-joints");
  const timeText = $("time");
  const frameText = $("frame");
  $("title").textContent = D.title;
  $("subtitle").textContent = D.subtitle;
  slider.max = String(nf - 1);

  // Decimals enough to tell two frames apart.
  let minStep = Infinity;
  for (let k = 1; k < nf; k++) minStep = Math.min(minStep, times[k] - times[k - 1]);
  const decimals = Number.isFinite(minStep) && minStep > 0
    ? Math.min(9, Math.max(2, Math.ceil(-Math.log10(minStep)) + 1)) : 3;

  // --- state ------------------------------------------------------------
  const state = {
    frame: 0,
    time: t0,
    clock: t0, // continuous playback time
    playing: false,
    speed: Number(speedSelect.value),
    loop: loopBox.checked,
    frames: framesBox.checked,
    joints: jointsBox.checked,
  };
  const view = { width: 0, height: 0, dpr: 1, scale: 1, ox: 0, oy: 0 };
  const drawn = { frame: -1, time: NaN, poses: new Float64Array(3 * nb), pixels: new Float64Array(2 * nb) };
  const perf = { intervals: [], draws: [], last: 0 };

  const px = (x) => view.ox + x * view.scale;
  const py = (y) => view.oy - y * view.scale;

  // --- view -------------------------------------------------------------
  const margin = { left: 62, right: 14, top: 12, bottom: 40 };
  function layout() {
    const r = canvas.getBoundingClientRect();
    view.dpr = window.devicePixelRatio || 1;
    view.width = Math.max(50, r.width);
    view.height = Math.max(50, r.height);
    for (const c of [canvas, layer]) {
      c.width = Math.round(view.width * view.dpr);
      c.height = Math.round(view.height * view.dpr);
    }
    // Equal aspect, 6 % padding, as the SVG plot.
    const pw = view.width - margin.left - margin.right;
    const ph = view.height - margin.top - margin.bottom;
    const pad = 0.06 * size;
    const dx = bx1 - bx0 + 2 * pad, dy = by1 - by0 + 2 * pad;
    view.scale = Math.max(1e-300, Math.min(pw / dx, ph / dy));
    const mx = 0.5 * (bx0 + bx1), my = 0.5 * (by0 + by1);
    view.ox = margin.left + 0.5 * pw - mx * view.scale;
    view.oy = margin.top + 0.5 * ph + my * view.scale;
    drawLayer();
  }

  function niceStep(span) {
    const raw = span / 8;
    const p = Math.pow(10, Math.floor(Math.log10(raw)));
    for (const m of [1, 2, 5, 10]) if (m * p >= raw) return m * p;
    return 10 * p;
  }

  function tickLabel(v, step) {
    if (Math.abs(v) < 1e-9 * step) return "0";
    const digits = Math.max(0, -Math.floor(Math.log10(step)));
    const a = Math.abs(v);
    if (a >= 1e5 || a < 1e-3) return v.toExponential(1);
    return v.toFixed(Math.min(digits, 6));
  }

  const unit = D.unit ? D.unit : "length";

  function drawLayer() {
    const c = lctx;
    c.setTransform(view.dpr, 0, 0, view.dpr, 0, 0);
    c.fillStyle = "#fff";
    c.fillRect(0, 0, view.width, view.height);
    // Grid and ticks over the plotting area.
    const xMin = (margin.left - view.ox) / view.scale;
    const xMax = (view.width - margin.right - view.ox) / view.scale;
    const yMax = (view.oy - margin.top) / view.scale;
    const yMin = (view.oy - (view.height - margin.bottom)) / view.scale;
    const step = niceStep(Math.max(xMax - xMin, yMax - yMin) * 0.8);
    c.lineWidth = 1;
    c.font = "12px sans-serif";
    c.fillStyle = "#444";
    c.strokeStyle = "#ececec";
    c.textAlign = "center";
    c.textBaseline = "top";
    for (let v = Math.ceil(xMin / step) * step; v <= xMax; v += step) {
      const x = Math.round(px(v)) + 0.5;
      c.beginPath(); c.moveTo(x, margin.top); c.lineTo(x, view.height - margin.bottom); c.stroke();
      c.fillText(tickLabel(v, step), x, view.height - margin.bottom + 4);
    }
    c.textAlign = "right";
    c.textBaseline = "middle";
    for (let v = Math.ceil(yMin / step) * step; v <= yMax; v += step) {
      const y = Math.round(py(v)) + 0.5;
      c.beginPath(); c.moveTo(margin.left, y); c.lineTo(view.width - margin.right, y); c.stroke();
      c.fillText(tickLabel(v, step), margin.left - 6, y);
    }
    c.strokeStyle = "#bbb";
    c.strokeRect(margin.left + 0.5, margin.top + 0.5,
      view.width - margin.left - margin.right - 1, view.height - margin.top - margin.bottom - 1);
    c.textAlign = "center";
    c.textBaseline = "bottom";
    c.fillStyle = "#222";
    c.font = "13px sans-serif";
    c.fillText("x [" + unit + "]", margin.left + 0.5 * (view.width - margin.left - margin.right), view.height - 2);
    c.save();
    c.translate(14, margin.top + 0.5 * (view.height - margin.top - margin.bottom));
    c.rotate(-Math.PI / 2);
    c.textBaseline = "middle";
    c.fillText("y [" + unit + "]", 0, 0);
    c.restore();

    // Paths of the points that are switched on, under everything else.
    const p = [0, 0];
    c.lineWidth = 2;
    c.lineJoin = "round";
    for (const tr of D.traces) {
      if (!tr.on) continue;
      c.strokeStyle = tr.color;
      c.beginPath();
      for (let k = 0; k < nf; k++) {
        global(k, tr.body, tr.local[0], tr.local[1], p);
        if (k === 0) c.moveTo(px(p[0]), py(p[1])); else c.lineTo(px(p[0]), py(p[1]));
      }
      c.stroke();
    }
    // Fixed points: a hatched ground triangle below each, as the plot.
    const s = 0.035 * size * view.scale;
    for (const f of D.fixed) {
      const x = px(f[0]), y = py(f[1]);
      const base = y + 0.9 * s;
      c.beginPath();
      c.moveTo(x, y); c.lineTo(x - 0.55 * s, base); c.lineTo(x + 0.55 * s, base); c.closePath();
      c.fillStyle = "rgba(120,120,120,0.35)";
      c.fill();
      c.strokeStyle = "#000";
      c.lineWidth = 1;
      c.stroke();
      c.lineWidth = 2;
      c.beginPath(); c.moveTo(x - 0.8 * s, base); c.lineTo(x + 0.8 * s, base); c.stroke();
      c.lineWidth = 1;
      for (let h = 0; h < 5; h++) {
        const x0 = x - 0.8 * s + h * 0.4 * s;
        c.beginPath(); c.moveTo(x0, base); c.lineTo(x0 - 0.25 * s, base + 0.3 * s); c.stroke();
      }
      c.beginPath(); c.arc(x, y, 4, 0, 2 * Math.PI);
      c.fillStyle = "#fff"; c.fill();
      c.lineWidth = 2; c.stroke();
    }
  }

  // --- drawing a frame --------------------------------------------------
  const GREY = "rgb(30,30,30)";
  function hexAlpha(hex, a) {
    const n = parseInt(hex.slice(1), 16);
    return "rgba(" + (n >> 16) + "," + ((n >> 8) & 255) + "," + (n & 255) + "," + a + ")";
  }
  const fills = D.bodies.map((b) => (b.color ? hexAlpha(b.color, 0.45) : "rgba(30,30,30,0.45)"));
  const [blockW, blockH] = D.block;
  // Body frame axes: about half the body's reach, within 1.5–6 % of the
  // view.
  const axes = D.bodies.map((b) => {
    let r = 0;
    for (const p of b.joints.concat(b.outline)) r = Math.max(r, Math.hypot(p[0], p[1]));
    for (const q of b.rects) r = Math.max(r, Math.hypot(Math.abs(q[0]) + 0.5 * q[2], Math.abs(q[1]) + 0.5 * q[3]));
    if (r === 0) r = blockW;
    return Math.min(0.06 * size, Math.max(0.015 * size, 0.6 * r));
  });

  function draw() {
    const started = performance.now();
    const k = state.frame;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(layer, 0, 0);
    ctx.setTransform(view.dpr, 0, 0, view.dpr, 0, 0);
    ctx.lineJoin = "round";
    ctx.lineCap = "round";
    for (let i = 0; i < nb; i++) {
      const o = 3 * (k * nb + i);
      const x = poses[o], y = poses[o + 1], phi = poses[o + 2];
      drawn.poses[3 * i] = x;
      drawn.poses[3 * i + 1] = y;
      drawn.poses[3 * i + 2] = phi;
      drawn.pixels[2 * i] = px(x);
      drawn.pixels[2 * i + 1] = py(y);
      // Body frame to pixels: rotation by phi, scale, y up.
      const c = Math.cos(phi) * view.scale, s = Math.sin(phi) * view.scale;
      ctx.save();
      ctx.transform(c, -s, -s, -c, px(x), py(y));
      drawBody(D.bodies[i], i);
      ctx.restore();
    }
    // Where the traced points are now.
    const p = [0, 0];
    for (const tr of D.traces) {
      if (!tr.on) continue;
      global(k, tr.body, tr.local[0], tr.local[1], p);
      ctx.beginPath();
      ctx.arc(px(p[0]), py(p[1]), 4, 0, 2 * Math.PI);
      ctx.fillStyle = tr.color;
      ctx.fill();
    }
    drawn.frame = k;
    drawn.time = times[k];
    showNumbers();
    perf.draws.push(performance.now() - started);
    if (perf.draws.length > 4000) perf.draws.splice(0, 2000);
  }

  // In body coordinates (the context maps them to pixels); line widths in
  // pixels through 1 / scale.
  function drawBody(b, i) {
    const w = 1 / view.scale;
    for (const r of b.rects) {
      ctx.beginPath();
      ctx.rect(r[0] - 0.5 * r[2], r[1] - 0.5 * r[3], r[2], r[3]);
      ctx.fillStyle = fills[i];
      ctx.fill();
      ctx.lineWidth = w;
      ctx.strokeStyle = GREY;
      ctx.stroke();
    }
    const o = b.outline;
    if (b.link === "block") {
      ctx.beginPath();
      ctx.rect(-0.5 * blockW, -0.5 * blockH, blockW, blockH);
      ctx.fillStyle = "rgba(30,30,30,0.25)";
      ctx.fill();
      ctx.lineWidth = 3 * w;
      ctx.strokeStyle = GREY;
      ctx.stroke();
    } else if (b.link === "bar") {
      ctx.beginPath();
      ctx.moveTo(o[0][0], o[0][1]);
      ctx.lineTo(o[1][0], o[1][1]);
      ctx.lineWidth = 4 * w;
      ctx.strokeStyle = GREY;
      ctx.stroke();
    } else if (o.length > 0) {
      ctx.beginPath();
      ctx.moveTo(o[0][0], o[0][1]);
      for (let j = 1; j < o.length; j++) ctx.lineTo(o[j][0], o[j][1]);
      ctx.closePath();
      ctx.fillStyle = "rgba(30,30,30,0.18)";
      ctx.fill();
      ctx.lineWidth = 3 * w;
      ctx.strokeStyle = GREY;
      ctx.stroke();
    }
    if (state.joints) {
      ctx.lineWidth = w;
      ctx.strokeStyle = GREY;
      ctx.fillStyle = "#fff";
      for (const p of b.joints) {
        ctx.beginPath();
        ctx.arc(p[0], p[1], 3 * w, 0, 2 * Math.PI);
        ctx.fill();
        ctx.stroke();
      }
    }
    if (state.frames) {
      const axis = axes[i];
      ctx.lineWidth = 2 * w;
      ctx.beginPath(); ctx.moveTo(0, 0); ctx.lineTo(axis, 0);
      ctx.strokeStyle = "#e15759"; ctx.stroke();
      ctx.beginPath(); ctx.moveTo(0, 0); ctx.lineTo(0, axis);
      ctx.strokeStyle = "#59a14f"; ctx.stroke();
    }
  }

  // --- numbers ----------------------------------------------------------
  const drivenCells = [];
  for (const d of D.driven) {
    const row = $("driven").insertRow();
    row.insertCell().textContent = d.label;
    const cell = row.insertCell();
    cell.className = "num";
    drivenCells.push(cell);
  }
  function drivenValue(d, k) {
    if (d.coordinate !== undefined) return poses[3 * k * nb + d.coordinate];
    const p = global(k, d.body, d.local[0], d.local[1], [0, 0]);
    return p[d.component];
  }
  function number(v) {
    if (!Number.isFinite(v)) return String(v);
    const a = Math.abs(v);
    return a !== 0 && (a >= 1e5 || a < 1e-3) ? v.toExponential(4) : v.toFixed(4);
  }
  let shownFrame = -1, tableFrame = -1, tableShown = 0;
  // The time at every frame; the driven values, a table that may have a
  // hundred rows, ten times a second while playing (relayout costs more
  // than drawing), at once otherwise.
  function showNumbers() {
    const k = state.frame;
    if (k !== shownFrame) {
      shownFrame = k;
      timeText.textContent = "t = " + times[k].toFixed(decimals) + " s";
      frameText.textContent = "frame " + (k + 1) + " of " + nf + " · t = " + t0 + " … " + tEnd + " s";
      slider.value = String(k);
    }
    const now = performance.now();
    if (k === tableFrame || (state.playing && now - tableShown < 100)) return;
    tableFrame = k;
    tableShown = now;
    D.driven.forEach((d, j) => {
      const v = drivenValue(d, k);
      let text = number(v) + (d.unit ? " " + d.unit : "");
      if (d.unit === "rad") text += " (" + (v * 180 / Math.PI).toFixed(2) + "°)";
      drivenCells[j].textContent = text;
    });
  }

  // --- traces and events ------------------------------------------------
  const traceBoxes = [];
  D.traces.forEach((tr) => {
    const label = document.createElement("label");
    const box = document.createElement("input");
    box.type = "checkbox";
    box.checked = tr.on;
    box.addEventListener("change", () => { tr.on = box.checked; box.blur(); drawLayer(); draw(); });
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = tr.color;
    label.append(box, swatch, document.createTextNode(tr.label));
    $("traces").append(label);
    traceBoxes.push(box);
  });
  if (D.traces.length === 0) $("traces-section").hidden = true;
  function setAllTraces(on) {
    D.traces.forEach((tr, j) => { tr.on = on; traceBoxes[j].checked = on; });
    drawLayer();
    draw();
  }
  $("traces-all").addEventListener("click", (e) => { e.currentTarget.blur(); setAllTraces(true); });
  $("traces-none").addEventListener("click", (e) => { e.currentTarget.blur(); setAllTraces(false); });

  const marks = $("marks");
  const events = $("events");
  for (const m of D.markers) {
    const k = frameAt(m.t);
    const frac = nf > 1 ? k / (nf - 1) : 0;
    const mark = document.createElement("div");
    mark.className = "mark";
    mark.style.left = (100 * frac) + "%";
    mark.title = "t = " + m.t + " s: " + m.label;
    mark.addEventListener("click", () => seek(k));
    marks.append(mark);
    const li = document.createElement("li");
    li.textContent = "t = " + m.t + " s — " + m.label;
    li.addEventListener("click", () => seek(k));
    events.append(li);
    $("events-section").hidden = false;
  }

  // --- playback ---------------------------------------------------------
  function seek(k) {
    state.frame = Math.max(0, Math.min(nf - 1, k | 0));
    state.clock = times[state.frame];
    state.time = times[state.frame];
    draw();
  }
  function setPlaying(on) {
    state.playing = on && nf > 1;
    playButton.textContent = state.playing ? "❚❚" : "▶";
    if (!state.playing) showNumbers();
    if (state.playing) {
      if (state.frame === nf - 1) seek(0);
      perf.last = 0;
      requestAnimationFrame(tick);
    }
  }
  function tick(now) {
    if (!state.playing) return;
    if (perf.last) {
      const dt = now - perf.last;
      perf.intervals.push(dt);
      if (perf.intervals.length > 4000) perf.intervals.splice(0, 2000);
      // A hidden tab or a stall does not jump far ahead.
      state.clock += Math.min(dt, 100) / 1000 * state.speed;
    }
    perf.last = now;
    if (state.clock > tEnd) {
      if (state.loop) {
        state.clock = t0;
      } else {
        state.clock = tEnd;
        state.frame = nf - 1;
        state.time = tEnd;
        draw();
        setPlaying(false);
        return;
      }
    }
    state.frame = frameAt(state.clock);
    state.time = times[state.frame];
    draw();
    requestAnimationFrame(tick);
  }

  playButton.addEventListener("click", () => { playButton.blur(); setPlaying(!state.playing); });
  slider.addEventListener("input", () => seek(Number(slider.value)));
  speedSelect.addEventListener("change", () => { state.speed = Number(speedSelect.value); speedSelect.blur(); });
  loopBox.addEventListener("change", () => { state.loop = loopBox.checked; loopBox.blur(); });
  framesBox.addEventListener("change", () => { state.frames = framesBox.checked; framesBox.blur(); draw(); });
  jointsBox.addEventListener("change", () => { state.joints = jointsBox.checked; jointsBox.blur(); draw(); });
  document.addEventListener("keydown", (e) => {
    const tag = e.target && e.target.tagName;
    if (tag === "SELECT" || (tag === "INPUT" && e.target.type === "range" && e.key !== " ")) return;
    const step = e.shiftKey ? 10 : 1;
    if (e.key === " ") { setPlaying(!state.playing); }
    else if (e.key === "ArrowRight") { seek(state.frame + step); }
    else if (e.key === "ArrowLeft") { seek(state.frame - step); }
    else if (e.key === "Home") { seek(0); }
    else if (e.key === "End") { seek(nf - 1); }
    else if (e.key === "l") { loopBox.checked = !loopBox.checked; state.loop = loopBox.checked; return; }
    else if (e.key === "f") { framesBox.checked = !framesBox.checked; state.frames = framesBox.checked; draw(); return; }
    else return;
    e.preventDefault();
  });
  new ResizeObserver(() => { layout(); draw(); }).observe($("stage"));
  layout();
  seek(0);

  // --- for tests and the curious ----------------------------------------
  function quantile(a, q) {
    if (a.length === 0) return NaN;
    const s = Array.from(a).sort((x, y) => x - y);
    return s[Math.min(s.length - 1, Math.floor(q * s.length))];
  }
  const median = (a) => quantile(a, 0.5);
  window.kinema = {
    data: D,
    times,
    poses,
    state,
    view,
    drawn,
    perf,
    seek,
    play: () => setPlaying(true),
    pause: () => setPlaying(false),
    toPixel: (x, y) => [px(x), py(y)],
    perfSummary: () => ({
      frames: perf.intervals.length,
      medianInterval: median(perf.intervals),
      p90Interval: quantile(perf.intervals, 0.9),
      fps: perf.intervals.length ? 1000 * perf.intervals.length / perf.intervals.reduce((a, b) => a + b, 0) : NaN,
      medianDraw: median(perf.draws),
      maxDraw: perf.draws.length ? Math.max.apply(null, perf.draws) : NaN,
    }),
  };
})();
