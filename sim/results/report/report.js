// The replay report's page. Reads the run's data (the JSON block "run-data", written by
// sim/results/report.cc: ReportData) and draws everything from it; it fetches nothing.
//
// data = {
//   meta: {scenario, scenario_file, run_dir, seed, sim_seconds, wall_seconds, real_time_factor,
//          passed, result_sha256, scenario_sha256, kernel_events, autonomsim, preset,
//          trajectory_stride (1: every sample; k: every k-th, for long runs)},
//   floor: {image (PNG data URL of the floor the cameras see), x0_m, y0_m (map coordinates of its
//           top-left corner), m_per_px, width_px, height_px},
//   track: {name, size_m, intersections: [{id, name, area, stop_zones: [box]}]}  box = {x_min_m, ..}
//   obstacles: [{name, x_m, y_m, yaw_rad, length_m, width_m, appear_s, disappear_s}],
//   cars: [{id, colour, length_m, width_m, route, driver, has_board, preset, laps, ...}],
//   trajectory: {"<car id>": {t, x, y, yaw, speed, steering, throttle, curvature, lateral_error}},
//   events: [{t, type, car, intersection, other_car, obstacle, granted, lap, fault, detail}],
//   expectations: [{name, passed, detail, at_s, car}],
//   boards: {"car0": {cores, load_bin_s, cpu_load_percent, e2e_topic, e2e_mean_ms, e2e_max_ms}},
//   snapshots: [{t, car, reasons, lane, color, depth, chase, overview}] (images: JPEG data URLs;
//              chase and overview, the 3D views, where OpenGL ES was available)
//   scene: {t, overview} (the 3D overview at the run's end) or {note} (why there is none)
// }
// Units: metres, seconds, radians; the map's x is east and y north.
"use strict";
(function () {
  const data = JSON.parse(document.getElementById("run-data").textContent);
  const T_END = data.meta.sim_seconds;
  const cars = data.cars;
  const carById = new Map(cars.map((c) => [c.id, c]));
  const colourOf = (id) => (carById.has(id) ? carById.get(id).colour : "#cccccc");
  const state = { t: 0, playing: false, speed: 1, trail: 10, lastFrame: null, plotsDrawnAt: 0 };

  // ---------- small helpers ----------
  const $ = (id) => document.getElementById(id);
  function el(tag, attrs, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (k === "class") e.className = v;
      else if (k === "style") e.style.cssText = v;
      else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
      else e.setAttribute(k, v);
    }
    for (const c of children) e.append(c instanceof Node ? c : document.createTextNode(String(c)));
    return e;
  }
  const fmt = (v, d) => (v === null || v === undefined || Number.isNaN(v) ? "–" : v.toFixed(d));
  const swatch = (colour) => el("span", { class: "swatch", style: "background:" + colour });
  const clamp = (v, lo, hi) => Math.min(hi, Math.max(lo, v));

  // Index of the last value <= t in the sorted array a (-1 if none).
  function lastAtOrBefore(a, t) {
    let lo = 0, hi = a.length - 1, found = -1;
    while (lo <= hi) {
      const mid = (lo + hi) >> 1;
      if (a[mid] <= t) { found = mid; lo = mid + 1; } else hi = mid - 1;
    }
    return found;
  }

  // A car's pose at t: linear between its samples (the heading the short way round).
  function poseAt(carId, t) {
    const tr = data.trajectory[String(carId)];
    if (!tr || tr.t.length === 0) return null;
    const i = lastAtOrBefore(tr.t, t);
    if (i < 0) return { x: tr.x[0], y: tr.y[0], yaw: tr.yaw[0], speed: tr.speed[0], i: 0 };
    if (i >= tr.t.length - 1 || tr.t[i] === t) {
      return { x: tr.x[i], y: tr.y[i], yaw: tr.yaw[i], speed: tr.speed[i], i };
    }
    const f = (t - tr.t[i]) / (tr.t[i + 1] - tr.t[i]);
    let dyaw = tr.yaw[i + 1] - tr.yaw[i];
    dyaw = Math.atan2(Math.sin(dyaw), Math.cos(dyaw));
    return {
      x: tr.x[i] + f * (tr.x[i + 1] - tr.x[i]),
      y: tr.y[i] + f * (tr.y[i + 1] - tr.y[i]),
      yaw: tr.yaw[i] + f * dyaw,
      speed: tr.speed[i] + f * (tr.speed[i + 1] - tr.speed[i]),
      i,
    };
  }

  // ---------- what the events say over time ----------
  const EVENT_STYLE = {
    [EVENT.COLLISION]: { colour: "#ff3b30", label: EVENT.COLLISION, size: 7 },
    [EVENT.ENTER]: { colour: "#58a6ff", label: "enters an intersection", size: 4 },
    [EVENT.EXIT]: { colour: "#2f6fb3", label: "leaves it", size: 3 },
    [EVENT.REQUEST]: { colour: "#8b949e", label: EVENT.REQUEST, size: 2 },
    [EVENT.GRANT]: { colour: "#3fb950", label: EVENT.GRANT, size: 4 },
    [EVENT.DENIED]: { colour: "#d29922", label: EVENT.DENIED, size: 3 },
    [EVENT.FREE]: { colour: "#a371f7", label: EVENT.FREE, size: 3 },
    [EVENT.LEASE_EXPIRED]: { colour: "#ff7b72", label: "lease expired", size: 5 },
    [EVENT.QUEUE_DROP]: { colour: "#ff7b72", label: "dropped from the queue", size: 5 },
    [EVENT.WAIT]: { colour: "#e3b341", label: "waiting (bar: until go)", size: 3 },
    [EVENT.GO]: { colour: "#e3b341", label: EVENT.GO, size: 2 },
    [EVENT.LAP]: { colour: "#ffffff", label: EVENT.LAP, size: 5 },
    [EVENT.BEHAVIOR]: { colour: "#db61a2", label: "behaviour", size: 3 },
    [EVENT.PARKED]: { colour: "#bbbbbb", label: EVENT.PARKED, size: 4 },
    [EVENT.FAULT_BEGIN]: { colour: "#f0883e", label: "fault (bar: while it lasts)", size: 5 },
    [EVENT.FAULT_END]: { colour: "#f0883e", label: "fault ends", size: 3 },
    [EVENT.RECONFIGURE_BEGIN]: { colour: "#39c5cf", label: "slot reconfiguration begins", size: 3 },
    [EVENT.RECONFIGURE_END]: { colour: "#1b7c83", label: "slot reconfigured", size: 2 },
  };
  const styleOf = (type) => EVENT_STYLE[type] || { colour: "#cccccc", label: type, size: 3 };

  function describe(e) {
    const who = e.car !== undefined ? "car " + e.car : "server";
    let what = e.type;
    if (e.intersection !== undefined) what += " intersection " + e.intersection;
    if (e.type === EVENT.ENTER) what += e.granted ? " (granted)" : " (WITHOUT grant)";
    if (e.other_car !== undefined) what += " with car " + e.other_car;
    if (e.obstacle) what += " with obstacle '" + e.obstacle + "'";
    if (e.lap) what += " " + e.lap;
    if (e.fault) what += " " + e.fault;
    if (e.detail) what += ": " + e.detail;
    return "t = " + e.t.toFixed(3) + " s  " + who + "  " + what;
  }

  // Per intersection, its holder and queue after each event that changes them.
  const intersectionStates = new Map();
  for (const x of data.track.intersections) {
    intersectionStates.set(x.id, { times: [0], states: [{ holder: null, queue: [] }] });
  }
  const waitBars = []; // {car, intersection, from, to}
  {
    const openWait = new Map();
    for (const e of data.events) {
      if (e.type === EVENT.WAIT) openWait.set(e.car, { car: e.car, intersection: e.intersection, from: e.t });
      if (e.type === EVENT.GO && openWait.has(e.car)) {
        waitBars.push({ ...openWait.get(e.car), to: e.t });
        openWait.delete(e.car);
      }
      const s = intersectionStates.get(e.intersection);
      if (!s) continue;
      const prev = s.states[s.states.length - 1];
      const next = { holder: prev.holder, queue: prev.queue.slice() };
      if (e.type === EVENT.GRANT) next.holder = e.car;
      if ((e.type === EVENT.FREE && prev.holder === e.car) || e.type === EVENT.LEASE_EXPIRED) next.holder = null;
      if (e.type === EVENT.WAIT && !next.queue.includes(e.car)) next.queue.push(e.car);
      if (e.type === EVENT.GO || e.type === EVENT.ENTER) next.queue = next.queue.filter((c) => c !== e.car);
      if (next.holder !== prev.holder || next.queue.length !== prev.queue.length) {
        s.times.push(e.t);
        s.states.push(next);
      }
    }
    for (const w of openWait.values()) waitBars.push({ ...w, to: T_END });
  }
  // The faults, from their fault_begin to their fault_end (or the run's end): a bar on the struck
  // car's row, or on the "fleet faults" row for the server, the broker and every car's link.
  const FLEET = "fleet";
  const faultBars = []; // {row, fault, from, to}
  {
    const open = [];
    for (const e of data.events) {
      const row = e.car !== undefined ? e.car : FLEET;
      if (e.type === EVENT.FAULT_BEGIN) open.push({ row, fault: e.fault, from: e.t, to: T_END });
      if (e.type === EVENT.FAULT_END) {
        const i = open.findIndex((b) => b.row === row && b.fault === e.fault);
        if (i >= 0) faultBars.push({ ...open.splice(i, 1)[0], to: e.t });
      }
    }
    faultBars.push(...open);
  }
  function intersectionAt(id, t) {
    const s = intersectionStates.get(id);
    return s.states[Math.max(0, lastAtOrBefore(s.times, t))];
  }
  const eventTimes = data.events.map((e) => e.t);
  const collisions = data.events.filter((e) => e.type === EVENT.COLLISION);
  const failures = data.expectations.filter((x) => !x.passed && x.at_s !== undefined);

  // ---------- header ----------
  {
    const m = data.meta;
    const verdict = el("span", { class: "badge " + (m.passed ? "pass" : "fail") }, m.passed ? "PASS" : "FAIL");
    const failed = data.expectations.filter((x) => !x.passed).length;
    $("header").append(
      el("h1", {}, m.scenario + " ", verdict),
      el("div", { class: "facts" },
        el("span", {}, "seed " + m.seed),
        el("span", {}, m.sim_seconds + " s simulated"),
        el("span", {}, cars.length + " cars"),
        el("span", {}, "stack preset " + (m.preset || "(per car / defaults)")),
        el("span", {}, data.expectations.length + " expectations, " + failed + " failed"),
        el("span", {}, "scenario file " + m.scenario_file),
        el("span", {}, "run folder " + m.run_dir),
        m.trajectory_stride > 1
          ? el("span", {}, "a long run: every " + m.trajectory_stride + "th trajectory sample shown")
          : ""));
  }

  // ---------- the replay ----------
  const canvas = $("track");
  const ctx = canvas.getContext("2d");
  const dpr = window.devicePixelRatio || 1;
  const floor = data.floor;
  const floorW_m = floor.width_px * floor.m_per_px;
  const floorH_m = floor.height_px * floor.m_per_px;
  // The floor fills the canvas but for a strip below it that holds the clock and the scale bar
  // (nothing is drawn over the floor that could hide a car).
  const STRIP_PX = 30;
  const view = { px_per_m: 1, cssW: 0, cssH: 0, floorH: 0 };
  function sizeCanvas() {
    const avail = Math.max(360, Math.min(760, window.innerWidth - 420, window.innerHeight - 150));
    view.cssW = Math.round(avail);
    view.px_per_m = view.cssW / floorW_m;
    view.floorH = floorH_m * view.px_per_m;
    view.cssH = Math.round(view.floorH + STRIP_PX);
    canvas.style.width = view.cssW + "px";
    canvas.style.height = view.cssH + "px";
    canvas.width = Math.round(view.cssW * dpr);
    canvas.height = Math.round(view.cssH * dpr);
  }
  // Map metres -> canvas CSS pixels, and back.
  const toPx = (x, y) => [(x - floor.x0_m) * view.px_per_m, (floor.y0_m - y) * view.px_per_m];
  const toMap = (px, py) => [floor.x0_m + px / view.px_per_m, floor.y0_m - py / view.px_per_m];
  const floorImage = new Image();
  floorImage.src = floor.image;

  function rotatedRect(x, y, yaw, length, width) {
    const c = Math.cos(yaw), s = Math.sin(yaw);
    return [[1, 1], [1, -1], [-1, -1], [-1, 1]].map(([a, b]) => {
      const dx = (a * length) / 2, dy = (b * width) / 2;
      return toPx(x + c * dx - s * dy, y + s * dx + c * dy);
    });
  }
  function polygon(points) {
    ctx.beginPath();
    points.forEach(([px, py], k) => (k ? ctx.lineTo(px, py) : ctx.moveTo(px, py)));
    ctx.closePath();
  }
  function withAlpha(hex, alpha) {
    const n = parseInt(hex.slice(1), 16);
    return "rgba(" + (n >> 16) + "," + ((n >> 8) & 255) + "," + (n & 255) + "," + alpha + ")";
  }
  // A car's colour lightened towards white: for text about a car, as the exact colour is kept for
  // the car's body alone.
  function tint(hex) {
    const n = parseInt(hex.slice(1), 16);
    const mix = (c) => Math.round(c + (255 - c) * 0.35);
    return "rgb(" + mix(n >> 16) + "," + mix((n >> 8) & 255) + "," + mix(n & 255) + ")";
  }
  function labelText(text, px, py, colour) {
    ctx.font = "bold 12px system-ui, 'DejaVu Sans', sans-serif";
    ctx.lineWidth = 3;
    ctx.strokeStyle = "rgba(0,0,0,0.85)";
    ctx.strokeText(text, px, py);
    ctx.fillStyle = colour || "#ffffff";
    ctx.fillText(text, px, py);
  }
  function boxPx(b) {
    const [x0, y0] = toPx(b.x_min_m, b.y_max_m);
    const [x1, y1] = toPx(b.x_max_m, b.y_min_m);
    return [x0, y0, x1 - x0, y1 - y0];
  }

  // Draws the world at t. Cars are filled with their colour alone (their heading mark sits ahead
  // of the bumper), so the browser test can find each car's drawn pixels by colour.
  function drawTrack(t) {
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.imageSmoothingEnabled = true;
    ctx.fillStyle = "#000";
    ctx.fillRect(0, 0, view.cssW, view.cssH);
    if (floorImage.complete) ctx.drawImage(floorImage, 0, 0, view.cssW, view.floorH);

    // intersections: held (filled in the holder's colour), queued cars listed under the label
    for (const x of data.track.intersections) {
      const s = intersectionAt(x.id, t);
      const [bx, by, bw, bh] = boxPx(x.area);
      if (s.holder !== null) {
        ctx.fillStyle = withAlpha(colourOf(s.holder), 0.28);
        ctx.fillRect(bx, by, bw, bh);
      }
      ctx.strokeStyle = "#9aa0a8";
      ctx.lineWidth = 2;
      ctx.setLineDash([]);
      ctx.strokeRect(bx, by, bw, bh);
      ctx.lineWidth = 1;
      ctx.setLineDash([4, 3]);
      for (const z of x.stop_zones) ctx.strokeRect(...boxPx(z));
      ctx.setLineDash([]);
      labelText("intersection " + x.id, bx + 4, by + 14, "#c9d1d9");
      let line = by + 30;
      if (s.holder !== null) {
        labelText("held by car " + s.holder, bx + 4, line, tint(colourOf(s.holder)));
        line += 15;
      }
      if (s.queue.length) labelText("queue: car " + s.queue.join(", car "), bx + 4, line, "#e3b341");
    }
    // obstacles present at t
    for (const o of data.obstacles) {
      if (t < o.appear_s || (o.disappear_s !== null && t >= o.disappear_s)) continue;
      polygon(rotatedRect(o.x_m, o.y_m, o.yaw_rad, o.length_m, o.width_m));
      ctx.fillStyle = "#c82828";
      ctx.fill();
      ctx.strokeStyle = "#ffffff"; // hatched outline and name: not to be taken for a red car
      ctx.setLineDash([3, 2]);
      ctx.lineWidth = 1;
      ctx.stroke();
      ctx.setLineDash([]);
      const [ox, oy] = toPx(o.x_m, o.y_m);
      labelText(o.name, ox + (Math.max(o.length_m, o.width_m) / 2) * view.px_per_m + 4, oy + 4, "#ffb4b4");
    }
    // trails
    for (const car of cars) {
      const tr = data.trajectory[String(car.id)];
      if (!tr || state.trail === 0) continue;
      const from = state.trail < 0 ? 0 : Math.max(0, lastAtOrBefore(tr.t, t - state.trail));
      const to = lastAtOrBefore(tr.t, t);
      if (to <= from) continue;
      ctx.beginPath();
      for (let i = from; i <= to; ++i) {
        const [px, py] = toPx(tr.x[i], tr.y[i]);
        i === from ? ctx.moveTo(px, py) : ctx.lineTo(px, py);
      }
      ctx.strokeStyle = withAlpha(car.colour, 0.6);
      ctx.lineWidth = 2;
      ctx.stroke();
    }
    // collisions so far
    let lastCross = null;
    for (const e of collisions) {
      if (e.t > t) break;
      const p = poseAt(e.car, e.t);
      if (!p) continue;
      const [px, py] = toPx(p.x, p.y);
      if (lastCross && Math.hypot(px - lastCross[0], py - lastCross[1]) < 6) continue;
      lastCross = [px, py];
      ctx.strokeStyle = "#ff3b30";
      ctx.lineWidth = 3;
      ctx.beginPath();
      ctx.moveTo(px - 8, py - 8); ctx.lineTo(px + 8, py + 8);
      ctx.moveTo(px - 8, py + 8); ctx.lineTo(px + 8, py - 8);
      ctx.stroke();
    }
    // cars
    for (const car of cars) {
      const p = poseAt(car.id, t);
      if (!p) continue;
      polygon(rotatedRect(p.x, p.y, p.yaw, car.length_m, car.width_m));
      ctx.fillStyle = car.colour;
      ctx.fill();
      // heading: a white arrowhead just ahead of the bumper
      const c = Math.cos(p.yaw), s = Math.sin(p.yaw);
      const tip = car.length_m / 2 + 0.12, base = car.length_m / 2 + 0.03, half = 0.07;
      polygon([
        toPx(p.x + c * tip, p.y + s * tip),
        toPx(p.x + c * base - s * half, p.y + s * base + c * half),
        toPx(p.x + c * base + s * half, p.y + s * base - c * half),
      ]);
      ctx.fillStyle = "#ffffff";
      ctx.fill();
      // the id above the car's drawn extent, whichever way it points (not on its body)
      const [lx, ly] = toPx(p.x, p.y);
      const halfHeight = Math.abs(s) * car.length_m / 2 + Math.abs(c) * car.width_m / 2;
      labelText(String(car.id), lx - 4, ly - halfHeight * view.px_per_m - 6, "#ffffff");
    }
    // the strip below the floor: clock and scale bar
    ctx.fillStyle = "#1d1f23";
    ctx.fillRect(0, view.floorH, view.cssW, view.cssH - view.floorH);
    labelText("t = " + t.toFixed(2) + " s", 10, view.floorH + 20, "#ffffff");
    const barPx = view.px_per_m;
    const bx = view.cssW - barPx - 16, by = view.floorH + 15;
    ctx.strokeStyle = "#e6e6e6";
    ctx.lineWidth = 3;
    ctx.beginPath();
    ctx.moveTo(bx, by); ctx.lineTo(bx + barPx, by);
    ctx.stroke();
    labelText("1 m", bx - 34, by + 5, "#e6e6e6");
  }

  // ---------- the state at t, in words ----------
  function drawStatus(t) {
    const status = $("status");
    status.replaceChildren();
    status.append(el("h3", {}, "Cars at t = " + t.toFixed(2) + " s"));
    const table = el("table", {},
      el("tr", {}, el("th", {}, "car"), el("th", {}, "route, driver"), el("th", {}, "speed (m/s)"),
        el("th", {}, "lateral error (m)"), el("th", {}, "laps")));
    for (const car of cars) {
      const tr = data.trajectory[String(car.id)];
      const p = poseAt(car.id, t);
      const i = p ? p.i : -1;
      const laps = (car.lap_times_s || []).filter((lt) => lt <= t).length;
      table.append(el("tr", {},
        el("td", {}, swatch(car.colour), String(car.id)),
        el("td", {}, (car.route || "–") + ", " + car.driver + (car.preset ? " (" + car.preset + ")" : "")),
        el("td", {}, p ? fmt(p.speed, 2) : "–"),
        el("td", {}, i >= 0 ? fmt(tr.lateral_error[i], 3) : "–"),
        el("td", {}, String(laps))));
    }
    status.append(table);
    const faultsNow = faultBars.filter((b) => b.from <= t && t < b.to);
    if (faultsNow.length) {
      status.append(el("h3", {}, "Faults now"));
      const fl = el("ul", { class: "events" });
      for (const b of faultsNow) {
        fl.append(el("li", {}, (b.row === FLEET ? "fleet" : "car " + b.row) + ": " + b.fault +
          " (since " + b.from.toFixed(1) + " s, " + (b.to >= T_END ? "to the end" : "until " + b.to.toFixed(1) + " s") + ")"));
      }
      status.append(fl);
    }
    status.append(el("h3", {}, "Intersections"));
    const xt = el("table", {}, el("tr", {}, el("th", {}, "intersection"), el("th", {}, "held by"), el("th", {}, "queued")));
    for (const x of data.track.intersections) {
      const s = intersectionAt(x.id, t);
      xt.append(el("tr", {},
        el("td", {}, x.id + " (" + x.name + ")"),
        el("td", {}, s.holder === null ? "nobody" : el("span", {}, swatch(colourOf(s.holder)), "car " + s.holder)),
        el("td", {}, s.queue.length ? s.queue.map((c) => "car " + c).join(", ") : "–")));
    }
    status.append(xt);
    status.append(el("h3", {}, "Latest events"));
    const list = el("ul", { id: "events-now" });
    const last = lastAtOrBefore(eventTimes, t);
    for (let k = Math.max(0, last - 7); k <= last; ++k) {
      const e = data.events[k];
      list.append(el("li", { class: t - e.t < 1.0 ? "recent" : "" }, describe(e)));
    }
    if (last < 0) list.append(el("li", {}, "none yet"));
    status.append(list);
  }

  // ---------- the timeline ----------
  const tl = $("timeline");
  const tctx = tl.getContext("2d");
  const TL = { left: 96, right: 16, rowH: 26, top: 8, axis: 26 };
  const tlRows = cars.map((c) => ({ label: "car " + c.id, car: c.id }));
  if (faultBars.some((b) => b.row === FLEET)) tlRows.push({ label: "fleet faults", car: FLEET });
  tlRows.push({ label: "expectations", car: null }); // always the last row
  let tlMarks = []; // {x, y, text} for the tooltip
  function sizeTimeline() {
    const w = tl.parentElement.clientWidth;
    const h = TL.top + tlRows.length * TL.rowH + TL.axis;
    tl.style.height = h + "px";
    tl.width = Math.round(w * dpr);
    tl.height = Math.round(h * dpr);
  }
  const tlX = (t) => TL.left + (t / T_END) * (tl.width / dpr - TL.left - TL.right);
  const tlT = (x) => clamp(((x - TL.left) / (tl.width / dpr - TL.left - TL.right)) * T_END, 0, T_END);
  function drawTimeline(t) {
    const w = tl.width / dpr, h = tl.height / dpr;
    tctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    tctx.clearRect(0, 0, w, h);
    tctx.font = "12px system-ui, 'DejaVu Sans', sans-serif";
    tlMarks = [];
    tlRows.forEach((row, r) => {
      const y = TL.top + r * TL.rowH + TL.rowH / 2;
      tctx.fillStyle = row.car === null || row.car === FLEET ? "#c9d1d9" : colourOf(row.car);
      tctx.fillText(row.label, 8, y + 4);
      tctx.strokeStyle = "#3a3e46";
      tctx.beginPath(); tctx.moveTo(TL.left, y); tctx.lineTo(w - TL.right, y); tctx.stroke();
    });
    const rowOf = (car) => tlRows.findIndex((r) => r.car === car);
    for (const b of waitBars) {
      const r = rowOf(b.car);
      if (r < 0) continue;
      const y = TL.top + r * TL.rowH + TL.rowH / 2;
      tctx.fillStyle = "rgba(227,179,65,0.35)";
      tctx.fillRect(tlX(b.from), y - 5, Math.max(1, tlX(b.to) - tlX(b.from)), 10);
    }
    const faultLabels = new Map(); // "row@from" -> {r, x, names}: faults that begin together
    for (const b of faultBars) {
      const r = rowOf(b.row);
      if (r < 0) continue;
      const y = TL.top + r * TL.rowH + TL.rowH / 2;
      const x0 = tlX(b.from), x1 = Math.max(tlX(b.to), x0 + 2);
      tctx.fillStyle = "rgba(240,136,62,0.30)";
      tctx.fillRect(x0, y - 10, x1 - x0, 20);
      const key = b.row + "@" + b.from;
      if (!faultLabels.has(key)) faultLabels.set(key, { y, x: x0, names: [] });
      faultLabels.get(key).names.push(b.fault);
    }
    tctx.fillStyle = "#f0883e";
    for (const l of faultLabels.values()) tctx.fillText(l.names.join(" + "), l.x + 3, l.y - 1);
    for (const e of data.events) {
      const r = rowOf(e.car !== undefined ? e.car : (e.type === EVENT.FAULT_BEGIN || e.type === EVENT.FAULT_END) ? FLEET : undefined);
      if (r < 0) continue;
      const st = styleOf(e.type);
      const x = tlX(e.t), y = TL.top + r * TL.rowH + TL.rowH / 2;
      tctx.fillStyle = e.type === EVENT.ENTER && !e.granted ? "#ff3b30" : st.colour;
      if (e.type === EVENT.COLLISION) {
        tctx.beginPath(); tctx.moveTo(x, y - st.size); tctx.lineTo(x + st.size, y + st.size);
        tctx.lineTo(x - st.size, y + st.size); tctx.closePath(); tctx.fill();
      } else {
        tctx.fillRect(x - st.size / 2, y - st.size - 2, st.size, 2 * st.size + 4);
      }
      tlMarks.push({ x, y, text: describe(e) });
    }
    const fr = tlRows.length - 1, fy = TL.top + fr * TL.rowH + TL.rowH / 2;
    for (const f of failures) {
      const x = tlX(f.at_s);
      tctx.fillStyle = "#f85149";
      tctx.beginPath(); tctx.moveTo(x, fy + 7); tctx.lineTo(x + 6, fy - 6); tctx.lineTo(x - 6, fy - 6);
      tctx.closePath(); tctx.fill();
      tlMarks.push({ x, y: fy, text: "t = " + f.at_s.toFixed(3) + " s  FAILED " + f.name + ": " + f.detail });
    }
    // axis
    const axisY = TL.top + tlRows.length * TL.rowH + 4;
    tctx.strokeStyle = "#9aa0a8";
    tctx.fillStyle = "#9aa0a8";
    tctx.beginPath(); tctx.moveTo(TL.left, axisY); tctx.lineTo(w - TL.right, axisY); tctx.stroke();
    const step = niceStep(T_END / 10);
    for (let s = 0; s <= T_END + 1e-9; s += step) {
      const x = tlX(s);
      tctx.beginPath(); tctx.moveTo(x, axisY); tctx.lineTo(x, axisY + 5); tctx.stroke();
      tctx.fillText(String(+s.toFixed(3)), x - 8, axisY + 17);
    }
    tctx.fillText("time (s)", 8, axisY + 17);
    // now
    tctx.strokeStyle = "#ffffff";
    tctx.lineWidth = 2;
    tctx.beginPath(); tctx.moveTo(tlX(t), TL.top); tctx.lineTo(tlX(t), axisY); tctx.stroke();
    tctx.lineWidth = 1;
  }
  function niceStep(raw) {
    const p = Math.pow(10, Math.floor(Math.log10(raw)));
    for (const m of [1, 2, 5, 10]) if (m * p >= raw) return m * p;
    return 10 * p;
  }
  {
    const legend = $("timeline-legend");
    const shown = new Set(data.events.map((e) => e.type));
    for (const [type, st] of Object.entries(EVENT_STYLE)) {
      if (!shown.has(type)) continue;
      legend.append(el("span", {}, el("i", { style: "background:" + st.colour }), st.label));
    }
    if (data.events.some((e) => e.type === EVENT.ENTER && !e.granted)) {
      legend.append(el("span", {}, el("i", { style: "background:#ff3b30" }), "enters without grant"));
    }
    if (failures.length) legend.append(el("span", {}, el("i", { style: "background:#f85149" }), "failed expectation"));
  }
  tl.addEventListener("click", (e) => seek(tlT(e.offsetX)));
  tl.addEventListener("mousemove", (e) => {
    const tip = $("tooltip");
    let best = null, bestD = 8;
    for (const m of tlMarks) {
      const d = Math.hypot(m.x - e.offsetX, m.y - e.offsetY);
      if (d < bestD) { best = m; bestD = d; }
    }
    if (!best) { tip.hidden = true; return; }
    tip.hidden = false;
    tip.textContent = best.text;
    tip.style.left = e.clientX + 12 + "px";
    tip.style.top = e.clientY + 12 + "px";
  });
  tl.addEventListener("mouseleave", () => ($("tooltip").hidden = true));

  // ---------- plots ----------
  const plots = [];
  function nowLinePlugin() {
    return {
      hooks: {
        draw: (u) => {
          const x = u.valToPos(state.t, "x", true);
          if (x < u.bbox.left || x > u.bbox.left + u.bbox.width) return;
          u.ctx.save();
          u.ctx.strokeStyle = "#ffffff";
          u.ctx.setLineDash([]);
          u.ctx.lineWidth = 1.5 * dpr;
          u.ctx.beginPath();
          u.ctx.moveTo(x, u.bbox.top);
          u.ctx.lineTo(x, u.bbox.top + u.bbox.height);
          u.ctx.stroke();
          u.ctx.restore();
        },
      },
    };
  }
  function addPlot(title, unit, series, note, yScale) {
    // series: [{label, colour, xs, ys, dash}] on one time axis (uPlot.join aligns them)
    if (!series.length) return;
    const joined = uPlot.join(series.map((s) => [s.xs, s.ys]));
    const box = el("div", { class: "plot" });
    $("plots").append(box);
    const width = Math.max(400, box.clientWidth - 12);
    const axisStyle = { stroke: "#c9d1d9", grid: { stroke: "#3a3e46" }, ticks: { stroke: "#3a3e46" } };
    const u = new uPlot({
      title,
      width,
      height: 220,
      plugins: [nowLinePlugin()],
      cursor: { sync: { key: "run" }, drag: { x: true, y: false }, y: false },
      scales: { x: { time: false, range: [0, T_END] }, y: yScale || {} },
      axes: [{ ...axisStyle, label: "time (s)" }, { ...axisStyle, label: unit, size: 60 }],
      series: [{ label: "t (s)", value: (u, v) => (v === null ? "–" : v.toFixed(2)) }].concat(
        series.map((s) => ({ label: s.label, stroke: s.colour, width: 1.5, dash: s.dash, spanGaps: false,
          value: (u, v) => (v === null || v === undefined ? "–" : (+v).toPrecision(3)) }))),
    }, joined, box);
    if (note) box.append(el("div", { class: "note" }, note));
    let downX = null;
    u.over.addEventListener("mousedown", (e) => (downX = e.clientX));
    u.over.addEventListener("click", (e) => {
      if (downX !== null && Math.abs(e.clientX - downX) > 3) return; // a drag zooms
      seek(clamp(u.posToVal(e.offsetX, "x"), 0, T_END));
    });
    plots.push(u);
  }
  function perCar(column, label) {
    return cars.filter((c) => data.trajectory[String(c.id)]).map((c) => ({
      label: "car " + c.id + (label ? " " + label : ""),
      colour: c.colour,
      xs: data.trajectory[String(c.id)].t,
      ys: data.trajectory[String(c.id)][column],
    }));
  }
  function perBoard(key, label, dash) {
    const out = [];
    for (const [board, b] of Object.entries(data.boards)) {
      if (!b[key]) continue;
      const id = Number(board.replace(/^car/, ""));
      out.push({
        label: board + (label ? " " + label : ""),
        colour: colourOf(id),
        dash,
        xs: b[key].map((_, k) => (k + 0.5) * b.load_bin_s),
        ys: b[key],
      });
    }
    return out;
  }
  function buildPlots() {
    addPlot("Speed", "m/s", perCar("speed"));
    addPlot("Lateral error from the lane centre", "m", perCar("lateral_error"),
      "Signed distance of the chassis centre from its route's lane centre line.");
    addPlot("Steering command", "rad", perCar("steering"));
    addPlot("Throttle command", "fraction", perCar("throttle"));
    if (Object.keys(data.boards).length) {
      const bin = Object.values(data.boards)[0].load_bin_s;
      const cores = Object.values(data.boards)[0].cores;
      addPlot("CPU load of each board (100 % = one core)", "%", perBoard("cpu_load_percent"),
        "Mean over each " + bin + " s bin; the board has " + cores + " cores (" + 100 * cores + " %).",
        { range: [0, 100 * cores] });
      addPlot("End-to-end latency, camera to motor command", "ms",
        perBoard("e2e_max_ms", "max", undefined).concat(perBoard("e2e_mean_ms", "mean", [5, 4])),
        "Per " + bin + " s bin, of the messages on " + (Object.values(data.boards)[0].e2e_topic || "the command topic") +
        ": publish time minus the sensor stamp they derive from (solid: max, dashed: mean; log " +
        "scale). Seconds-long values are commands derived from old input (see the cruise control's " +
        "watchdog stop in stack/cruise_control.h).",
        { distr: 3 });
    }
  }

  // ---------- expectations ----------
  function buildExpectations() {
    const table = $("expectations");
    table.append(el("tr", {}, el("th", {}, "verdict"), el("th", {}, "expectation"), el("th", {}, "what was measured"), el("th", {}, "when")));
    if (!data.expectations.length) {
      table.append(el("tr", {}, el("td", { colspan: 4, class: "muted" }, "This scenario has no expectations.")));
    }
    for (const x of data.expectations) {
      const when = x.at_s === undefined ? el("span", { class: "muted" }, x.passed ? "" : "whole run")
        : el("a", { onclick: () => seek(x.at_s), title: "jump there" },
          "t = " + x.at_s.toFixed(2) + " s" + (x.car !== undefined ? ", car " + x.car : ""));
      table.append(el("tr", {},
        el("td", {}, el("span", { class: "badge " + (x.passed ? "pass" : "fail") }, x.passed ? "pass" : "FAIL")),
        el("td", {}, x.name), el("td", {}, x.detail), el("td", {}, when)));
    }
  }

  // ---------- camera snapshots ----------
  function buildScene() {
    const box = $("scene");
    if (data.scene.overview) {
      box.append(el("figure", {}, el("img", { src: data.scene.overview, alt: "overview at the end" }),
        el("figcaption", {}, "3D: the track from above its south side at the run's end, t = " +
          data.scene.t.toFixed(2) + " s (each car in its colour, its id above it)")));
    } else {
      box.append(el("p", { class: "muted" }, data.scene.note));
    }
  }
  function buildSnapshots() {
    const box = $("snapshots");
    if (!data.snapshots.length) {
      box.append(el("p", { class: "muted" }, failures.length
        ? "No failing instant concerns a car with a board (cameras and a stack): nothing to show."
        : "No expectation failed at an instant: nothing to show."));
      return;
    }
    for (const s of data.snapshots) {
      const images = el("div", { class: "images" });
      if (s.color) images.append(el("figure", {}, el("img", { src: s.color, alt: "colour camera" }),
        el("figcaption", {}, "colour camera: the lane detector's region (grey), its fitted line (yellow or white) and the trajectory it sends (green)")));
      if (s.depth) images.append(el("figure", {}, el("img", { src: s.depth, alt: "depth camera" }),
        el("figcaption", {}, "depth camera, false colour")));
      if (s.chase) images.append(el("figure", {}, el("img", { src: s.chase, alt: "chase view" }),
        el("figcaption", {}, "3D: behind car " + s.car)));
      if (s.overview) images.append(el("figure", {}, el("img", { src: s.overview, alt: "overview" }),
        el("figcaption", {}, "3D: the track from above its south side")));
      box.append(el("div", { class: "snapshot" },
        el("h3", {}, el("a", { onclick: () => seek(s.t) }, "t = " + s.t.toFixed(2) + " s"),
          ", car " + s.car + ": " + s.reasons.join(", ")),
        el("div", { class: "muted" }, s.lane), images));
    }
  }

  // ---------- time ----------
  const slider = $("slider");
  function render() {
    drawTrack(state.t);
    drawTimeline(state.t);
    drawStatus(state.t);
    slider.value = state.t;
    $("clock").textContent = "t = " + state.t.toFixed(2) + " s";
    for (const u of plots) {
      // the legends read the values at the current time
      u.setCursor({ left: u.valToPos(state.t, "x"), top: u.bbox.height / dpr / 2 }, false);
    }
  }
  function seek(t) {
    state.t = clamp(t, 0, T_END);
    render();
  }
  function setPlaying(on) {
    state.playing = on && state.t < T_END;
    $("play").innerHTML = state.playing ? "&#10074;&#10074; pause" : "&#9654; play";
    state.lastFrame = null;
    if (state.playing) requestAnimationFrame(tick);
  }
  function tick(now) {
    if (!state.playing) return;
    if (state.lastFrame !== null) {
      state.t = Math.min(T_END, state.t + ((now - state.lastFrame) / 1000) * state.speed);
      drawTrack(state.t);
      slider.value = state.t;
      $("clock").textContent = "t = " + state.t.toFixed(2) + " s";
      if (now - state.plotsDrawnAt > 150) { // the rest ~7 times a second
        state.plotsDrawnAt = now;
        drawTimeline(state.t);
        drawStatus(state.t);
        for (const u of plots) u.redraw(false, false);
      }
    }
    state.lastFrame = now;
    if (state.t >= T_END) { setPlaying(false); render(); return; }
    requestAnimationFrame(tick);
  }

  function buildControls() {
    slider.max = T_END;
    slider.addEventListener("input", () => seek(Number(slider.value)));
    for (const s of [0.25, 0.5, 1, 2, 5, 10, 20]) {
      $("speed").append(el("option", s === 1 ? { value: s, selected: "" } : { value: s }, s + "×"));
    }
    $("speed").addEventListener("change", (e) => (state.speed = Number(e.target.value)));
    for (const [v, label] of [[0, "none"], [5, "5 s"], [10, "10 s"], [30, "30 s"], [-1, "all"]]) {
      $("trail").append(el("option", v === 10 ? { value: v, selected: "" } : { value: v }, label));
    }
    $("trail").addEventListener("change", (e) => { state.trail = Number(e.target.value); render(); });
    $("play").addEventListener("click", () => setPlaying(!state.playing));
    document.addEventListener("keydown", (e) => {
      if (e.target.tagName === "SELECT" || e.target.tagName === "INPUT") return; // they have keys of their own
      if (e.key === " ") { e.preventDefault(); setPlaying(!state.playing); }
      if (e.key === "ArrowRight") seek(state.t + (e.shiftKey ? 0.05 : 1));
      if (e.key === "ArrowLeft") seek(state.t - (e.shiftKey ? 0.05 : 1));
    });
  }

  // ---------- the browser test's probe ----------
  // With "#probe=t1,t2,..." in the address, the page seeks to each instant, finds each car's
  // drawn pixels by its colour, and writes what it found as JSON into <pre id="probe">: the car
  // centres in map metres as drawn and as interpolated, the page's load time, its errors and the
  // resources it fetched (none expected).
  async function runProbe(times) {
    const decoded = await Promise.allSettled(Array.from(document.images).map((i) => i.decode()));
    const samples = [];
    for (const t of times) {
      slider.value = t; // as a user drags it
      slider.dispatchEvent(new Event("input"));
      const image = ctx.getImageData(0, 0, canvas.width, canvas.height).data;
      const found = [];
      for (const car of cars) {
        const n = parseInt(car.colour.slice(1), 16);
        const r = n >> 16, g = (n >> 8) & 255, b = n & 255;
        let sx = 0, sy = 0, count = 0;
        for (let k = 0, px = 0; k < image.length; k += 4, ++px) {
          if (image[k] === r && image[k + 1] === g && image[k + 2] === b) {
            sx += px % canvas.width;
            sy += Math.floor(px / canvas.width);
            ++count;
          }
        }
        const p = poseAt(car.id, t);
        const drawn = count ? toMap((sx / count + 0.5) / dpr, (sy / count + 0.5) / dpr) : [null, null];
        found.push({ car: car.id, pixels: count, drawn_x_m: drawn[0], drawn_y_m: drawn[1],
          model_x_m: p ? p.x : null, model_y_m: p ? p.y : null });
      }
      samples.push({ t: state.t, cars: found });
    }
    const out = {
      load_ms: window.reportLoadMs,
      errors: window.reportErrors,
      resources: performance.getEntriesByType("resource").map((r) => r.name),
      images: Array.from(document.images).map((i, k) =>
        decoded[k].status === "fulfilled" ? i.naturalWidth : 0),
      canvas_px_per_m: view.px_per_m * dpr,
      samples,
    };
    document.body.append(el("pre", { id: "probe" }, JSON.stringify(out)));
  }

  // ---------- start ----------
  function start() {
    sizeCanvas();
    sizeTimeline();
    buildControls();
    buildPlots();
    buildExpectations();
    buildSnapshots();
    buildScene();
    render();
    window.reportLoadMs = performance.now();
    const m = data.meta;
    $("footer").append(
      "Written by autonomsim " + m.autonomsim + " from " + m.run_dir + " (result " +
      m.result_sha256.slice(0, 12) + "…, scenario " + m.scenario_sha256.slice(0, 12) + "…; " +
      m.kernel_events + " kernel events; the run took " + fmt(m.wall_seconds, 1) + " s wall" +
      (m.real_time_factor ? ", " + fmt(m.real_time_factor, 1) + "× real time" : "") +
      "). Page ready in " + window.reportLoadMs.toFixed(0) + " ms. Plots: uPlot (MIT).");
    if (window.reportErrors.length) $("footer").append(el("div", { style: "color:#f85149" }, "Errors: " + window.reportErrors.join("; ")));
    const at = /^#t=([0-9.]+)$/.exec(location.hash); // report.html#t=35.4 opens at that instant
    if (at) seek(Number(at[1]));
    const probe = /^#probe=(.*)$/.exec(location.hash);
    if (probe) runProbe(probe[1].split(",").filter((s) => s).map(Number));
  }
  window.addEventListener("resize", () => { sizeCanvas(); sizeTimeline(); render(); });
  // the floor image is a data URL: decoding it is all the loading there is
  floorImage.decode().then(start, (err) => { window.reportErrors.push("floor image: " + err); start(); });
})();
