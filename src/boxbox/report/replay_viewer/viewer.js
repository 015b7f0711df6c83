/* boxbox replay viewer: the race on a canvas, plain JS, no network.  Its data is the JSON in
   #bbr-data (written by boxbox/report/replay.py): the track, the cars, the incidents, and per car
   and sample base64 typed arrays, car after car.  window.replay is a small API for tests and the
   console: seek(t), play(), pause(), time(), setSpeed(x), worldToScreen(x, y), carState(car, t), jump(i),
   labels() (where the last frame put each car's label). */
(function () {
  "use strict";
  const root = document.getElementById("bbr-root");
  const D = JSON.parse(document.getElementById("bbr-data").textContent);
  const $ = (sel) => root.querySelector(sel);
  const FLAG = { seen: 1, inPit: 2, pitLane: 4, offTrack: 8, out: 16, python: 32 };
  const UNKNOWN = -128; // a TORCS robot's controls are not recorded
  const GAP_S = 0.5; // samples further apart are not interpolated (no Python car was driven between)
  const BEFORE_S = 3; // a click on an incident shows it from this long before
  const JUMP_SPEED = 1; // ... at most this fast (at 16x a contact is over in a fifth of a second)
  const LABEL_H = 14, LABEL_GAP = 2; // a label's height (11px text) and the room kept between two
  const MIN_CAR_PX = 11; // cars drawn at least this long (a whole track at once shrinks them to dots)
  const FOLLOW_SPAN_M = 100; // what the smaller side of the view shows when following a car
  const KIND_COLORS = { contact: "#d62728", damage: "#ff7f0e", "off-track": "#8c564b", spin: "#9467bd",
    pass: "#2ca02c", "pit-stop": "#1f77b4", "missed-stop": "#17becf", fault: "#000000", stopped: "#555555" };

  function decode(b64, Type) {
    const bin = atob(b64), n = bin.length, bytes = new Uint8Array(n);
    for (let i = 0; i < n; i++) bytes[i] = bin.charCodeAt(i);
    return new Type(bytes.buffer);
  }
  const F = D.frames;
  const T = decode(F.t, Float32Array);
  const S = T.length;
  const A = {
    x: decode(F.x, Float32Array), y: decode(F.y, Float32Array), yaw: decode(F.yaw, Int16Array),
    speed: decode(F.speed, Int16Array), damage: decode(F.damage, Int32Array), place: decode(F.place, Uint8Array),
    lap: decode(F.lap, Int16Array), flags: decode(F.flags, Uint8Array), gear: decode(F.gear, Int8Array),
    accel: decode(F.accel, Int8Array), brake: decode(F.brake, Int8Array), steer: decode(F.steer, Int8Array),
  };
  const cars = D.cars;
  const C = cars.length;
  const t0 = T[0], t1 = T[S - 1];
  const canvas = $(".bbr-canvas");
  const ctx = canvas.getContext("2d");
  const state = { t: t0, playing: false, speed: 1, mode: "track", follow: 0, zoom: 1, lastWall: null,
    shownIncident: -1, hiddenKinds: new Set(), labels: [] };
  state.follow = Math.max(0, cars.findIndex((c) => c.python));
  const view = { scale: 1, wx: 0, wy: 0, w: 0, h: 0 };

  // --- samples --------------------------------------------------------------------------------
  function sampleAt(t) {
    if (t <= T[0]) return 0;
    let lo = 0, hi = S - 1;
    if (t >= T[hi]) return hi;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (T[mid] <= t) lo = mid; else hi = mid;
    }
    return lo;
  }
  function wrapPi(a) {
    while (a > Math.PI) a -= 2 * Math.PI;
    while (a < -Math.PI) a += 2 * Math.PI;
    return a;
  }
  function carState(k, t) {
    const i = sampleAt(t), o = k * S + i, fl = A.flags[o];
    let x = A.x[o], y = A.y[o], yaw = A.yaw[o] / 1e4, speed = A.speed[o] / 100;
    const next = i + 1 < S && T[i + 1] - T[i] < GAP_S && (fl & FLAG.seen) && (A.flags[o + 1] & FLAG.seen);
    if (next && t > T[i]) {
      const u = Math.min(1, (t - T[i]) / (T[i + 1] - T[i]));
      x += (A.x[o + 1] - x) * u;
      y += (A.y[o + 1] - y) * u;
      yaw += wrapPi(A.yaw[o + 1] / 1e4 - yaw) * u;
      speed += (A.speed[o + 1] / 100 - speed) * u;
    }
    const stale = !(fl & FLAG.seen) || t - T[i] > GAP_S;
    return { car: cars[k].car, x, y, yaw, speed, sample: i, stale, flags: fl, damage: A.damage[o],
      place: A.place[o], lap: A.lap[o], gear: A.gear[o], accel: A.accel[o], brake: A.brake[o], steer: A.steer[o] };
  }
  function column(car) {
    return cars.findIndex((c) => c.car === car);
  }

  // --- the view ---------------------------------------------------------------------------------
  function trackBounds() {
    const e = D.track.edges, xs = [], ys = [];
    if (e) {
      xs.push(...e.left_x, ...e.right_x);
      ys.push(...e.left_y, ...e.right_y);
    }
    const p = D.track.pit_lane;
    if (p) { xs.push(...p.outer_x); ys.push(...p.outer_y); }
    if (!xs.length) { // no edges recorded: where the cars went
      for (let j = 0; j < A.x.length; j += 7) if (isFinite(A.x[j])) { xs.push(A.x[j]); ys.push(A.y[j]); }
    }
    let [x0, x1, y0, y1] = [Infinity, -Infinity, Infinity, -Infinity];
    for (const v of xs) { if (v < x0) x0 = v; if (v > x1) x1 = v; }
    for (const v of ys) { if (v < y0) y0 = v; if (v > y1) y1 = v; }
    return { x0, x1, y0, y1 };
  }
  const bounds = trackBounds();

  function resize() {
    const dpr = window.devicePixelRatio || 1;
    view.w = canvas.clientWidth;
    view.h = canvas.clientHeight;
    canvas.width = Math.round(view.w * dpr);
    canvas.height = Math.round(view.h * dpr);
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    trackLayer = null;
    draw();
  }
  function placeView() {
    if (state.mode === "follow") {
      const st = carState(state.follow, state.t);
      view.scale = Math.min(view.w, view.h) / (FOLLOW_SPAN_M / state.zoom);
      view.wx = st.x; view.wy = st.y;
    } else {
      const pad = 16;
      view.scale = Math.min((view.w - 2 * pad) / Math.max(1, bounds.x1 - bounds.x0),
        (view.h - 2 * pad) / Math.max(1, bounds.y1 - bounds.y0)) * state.zoom;
      view.wx = (bounds.x0 + bounds.x1) / 2; view.wy = (bounds.y0 + bounds.y1) / 2;
    }
  }
  function worldToScreen(x, y) {
    return [view.w / 2 + (x - view.wx) * view.scale, view.h / 2 - (y - view.wy) * view.scale];
  }

  // --- drawing ---------------------------------------------------------------------------------
  let trackLayer = null, trackKey = "";
  function pathAlong(g, xs, ys) {
    for (let i = 0; i < xs.length; i++) {
      const [sx, sy] = worldToScreen(xs[i], ys[i]);
      if (i === 0) g.moveTo(sx, sy); else g.lineTo(sx, sy);
    }
  }
  function drawPitLane(g) {
    const p = D.track.pit_lane;
    if (!p) return;
    g.beginPath();
    pathAlong(g, p.edge_x, p.edge_y);
    for (let i = p.outer_x.length - 1; i >= 0; i--) g.lineTo(...worldToScreen(p.outer_x[i], p.outer_y[i]));
    g.closePath();
    g.fillStyle = "#c9c9c9";
    g.fill();
    g.setLineDash([4, 3]);
    g.strokeStyle = "#777";
    g.lineWidth = 1;
    g.beginPath();
    pathAlong(g, p.outer_x, p.outer_y);
    g.stroke();
    g.setLineDash([]);
  }
  function drawTrackOn(g) {
    const e = D.track.edges;
    if (!e) return;
    const n = e.left_x.length;
    g.beginPath(); // one quad per segment, filled at once: no seams, and a figure-8 fills right
    for (let i = 0; i + 1 < n; i++) {
      g.moveTo(...worldToScreen(e.left_x[i], e.left_y[i]));
      g.lineTo(...worldToScreen(e.left_x[i + 1], e.left_y[i + 1]));
      g.lineTo(...worldToScreen(e.right_x[i + 1], e.right_y[i + 1]));
      g.lineTo(...worldToScreen(e.right_x[i], e.right_y[i]));
      g.closePath();
    }
    g.fillStyle = "#a3a3a3";
    g.fill();
    drawPitLane(g);
    g.strokeStyle = "#4d4d4d";
    g.lineWidth = 1;
    for (const side of ["left", "right"]) {
      g.beginPath();
      pathAlong(g, e[side + "_x"], e[side + "_y"]);
      g.stroke();
    }
    const [ax, ay] = worldToScreen(e.left_x[0], e.left_y[0]), [bx, by] = worldToScreen(e.right_x[0], e.right_y[0]);
    g.strokeStyle = "#fff"; g.lineWidth = 3; g.beginPath(); g.moveTo(ax, ay); g.lineTo(bx, by); g.stroke();
    g.strokeStyle = "#000"; g.lineWidth = 1; g.setLineDash([2, 2]); g.stroke(); g.setLineDash([]);
  }
  function drawTrack() {
    // the whole track is still while the cars move: drawn once per view into a layer
    const key = [view.w, view.h, view.scale, view.wx, view.wy].join(",");
    if (state.mode === "follow") { drawTrackOn(ctx); return; }
    if (!trackLayer || key !== trackKey) {
      const dpr = window.devicePixelRatio || 1;
      trackLayer = document.createElement("canvas");
      trackLayer.width = canvas.width; trackLayer.height = canvas.height;
      const g = trackLayer.getContext("2d");
      g.setTransform(dpr, 0, 0, dpr, 0, 0);
      drawTrackOn(g);
      trackKey = key;
    }
    ctx.save();
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(trackLayer, 0, 0);
    ctx.restore();
  }
  function carBox(k) {
    let L = cars[k].length_m * view.scale, W = cars[k].width_m * view.scale;
    if (L < MIN_CAR_PX) { W *= MIN_CAR_PX / L; L = MIN_CAR_PX; }
    return [L, Math.max(W, 5)];
  }
  function drawCar(k, st) {
    const [sx, sy] = worldToScreen(st.x, st.y);
    if (!isFinite(sx) || !isFinite(sy)) return;
    const [L, W] = carBox(k);
    ctx.save();
    ctx.translate(sx, sy);
    ctx.rotate(-st.yaw);
    ctx.globalAlpha = st.stale || (st.flags & FLAG.out) ? 0.4 : 1;
    ctx.fillStyle = cars[k].color;
    ctx.fillRect(-L / 2, -W / 2, L, W);
    if (cars[k].python) { ctx.lineWidth = 1.5; ctx.strokeStyle = "#000"; ctx.strokeRect(-L / 2, -W / 2, L, W); }
    const nose = Math.min(L * 0.3, 7); // the front: a white wedge
    ctx.fillStyle = "#fff";
    ctx.beginPath();
    ctx.moveTo(L / 2, 0); ctx.lineTo(L / 2 - nose, -W * 0.32); ctx.lineTo(L / 2 - nose, W * 0.32);
    ctx.fill();
    ctx.restore();
    if (k === state.follow) {
      ctx.strokeStyle = "#000"; ctx.lineWidth = 1.5;
      ctx.beginPath(); ctx.arc(sx, sy, Math.max(L, 16) * 0.75 + 3, 0, 2 * Math.PI); ctx.stroke();
    }
  }
  function overlaps(a, b) {
    return a.x < b.x + b.w + LABEL_GAP && b.x < a.x + a.w + LABEL_GAP && a.y < b.y + b.h && b.y < a.y + a.h;
  }
  function placeLabel(sx, sy, L, w, placed) {
    // beside the car (right, else left), then stepped up and down a label's height at a time, so
    // the labels of a grid or a pack stand in a column instead of on each other; inside the canvas
    const off = L * 0.6 + 6, x0 = Math.max(0, Math.min(view.w - w, sx + off)),
      x1 = Math.max(0, Math.min(view.w - w, sx - off - w)), y = sy - L * 0.6 - 4 - LABEL_H + 3;
    const fit = (r) => Math.max(0, Math.min(view.h - r.h, r.y));
    for (let step = 0; step < 2 * C + 2; step++) {
      const dy = (step % 2 ? -1 : 1) * Math.ceil(step / 2) * (LABEL_H + LABEL_GAP);
      for (const x of [x0, x1]) {
        const r = { x, y: 0, w, h: LABEL_H };
        r.y = fit({ y: y + dy, h: LABEL_H });
        if (!placed.some((p) => overlaps(p, r))) return r;
      }
    }
    return null; // no room left anywhere near: the list and the panel name the car
  }
  function drawLabel(k, st, placed) {
    const [sx, sy] = worldToScreen(st.x, st.y);
    const [L] = carBox(k);
    if (!(sx > -L && sx < view.w + L && sy > -L && sy < view.h + L)) return; // off the view (or NaN)
    const text = (st.place ? "P" + st.place + " " : "") + cars[k].name;
    ctx.font = (k === state.follow ? "bold " : "") + "11px system-ui, sans-serif";
    const r = placeLabel(sx, sy, L, 12 + ctx.measureText(text).width + 3, placed);
    if (!r) return;
    placed.push({ ...r, car: cars[k].car });
    const lx = r.x, ly = r.y + LABEL_H - 3;
    if (Math.abs(r.y - (sy - L * 0.6 - 4 - LABEL_H + 3)) > LABEL_H) { // moved away: a line to its car
      ctx.lineWidth = 1; ctx.strokeStyle = "rgba(0,0,0,.5)";
      ctx.beginPath(); ctx.moveTo(sx, sy); ctx.lineTo(r.x < sx ? r.x + r.w : r.x, r.y + LABEL_H / 2); ctx.stroke();
    }
    ctx.fillStyle = cars[k].color; // the car's colour before its name: which label is whose in a pack
    ctx.fillRect(lx, ly - 9, 9, 9);
    ctx.lineWidth = 1; ctx.strokeStyle = "#333";
    ctx.strokeRect(lx + 0.5, ly - 8.5, 8, 8);
    ctx.lineWidth = 3; ctx.strokeStyle = "rgba(255,255,255,.9)"; ctx.fillStyle = "#111";
    ctx.strokeText(text, lx + 12, ly); ctx.fillText(text, lx + 12, ly);
  }
  function fmtTime(t) {
    const tenths = Math.round(t * 10), s = Math.abs(tenths) / 10, m = Math.floor(s / 60); // no "-0:00.0"
    return (tenths < 0 ? "-" : "") + m + ":" + (s - 60 * m).toFixed(1).padStart(4, "0");
  }
  function lapText(lap) {
    // TORCS counts a finished car's lap on (4 after 3 laps): the race's laps at most
    const shown = Math.max(0, lap);
    return D.laps ? Math.min(shown, D.laps) + " of " + D.laps : String(shown);
  }
  function draw() {
    if (!view.w) return;
    placeView();
    ctx.clearRect(0, 0, view.w, view.h);
    drawTrack();
    const states = cars.map((_, k) => carState(k, state.t));
    const order = states.map((_, k) => k).filter((k) => k !== state.follow);
    order.push(state.follow); // the followed car on top
    for (const k of order) drawCar(k, states[k]);
    const placed = [];
    for (const k of order.slice().reverse()) drawLabel(k, states[k], placed); // the followed car's first
    state.labels = placed;
    const leader = states.find((s) => s.place === 1) || states[0];
    $(".bbr-clock").textContent = "t " + fmtTime(state.t) + " · lap " + lapText(leader.lap) + " · " + state.speed + "x";
    $(".bbr-scrub").value = state.t;
    drawPanel(states[state.follow]);
    markIncident();
  }

  // --- the followed car's panel ------------------------------------------------------------------
  function bar(share, color) {
    return '<div class="bbr-bar"><div style="width:' + Math.round(100 * Math.max(0, Math.min(1, share))) +
      "%;background:" + color + '"></div></div>';
  }
  function escapeHtml(s) {
    return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
  }
  function where(st) {
    if (st.flags & FLAG.out) return "out of the race / finished";
    if (st.stale) return "not seen for " + (state.t - T[st.sample]).toFixed(1) + " s (no Python car driven)";
    if (st.flags & FLAG.inPit) return "standing in its pit box";
    if (st.flags & FLAG.pitLane) return "in the pit lane";
    if (st.flags & FLAG.offTrack) return "off the track";
    return "on the track";
  }
  function drawPanel(st) {
    const c = cars[state.follow];
    const rows = [["place", st.place ? st.place + " of " + C : "-"], ["lap", lapText(st.lap)],
      ["speed", (st.speed * 3.6).toFixed(0) + " km/h"]];
    if (st.gear !== UNKNOWN) {
      rows.push(["gear", st.gear], ["throttle", bar(st.accel / 100, "#2ca02c")], ["brake", bar(st.brake / 100, "#d62728")],
        ["steer", (st.steer / 100).toFixed(2) + (st.steer > 0 ? " left" : st.steer < 0 ? " right" : "")]);
    } else {
      rows.push(["controls", "not recorded (a TORCS robot)"]);
    }
    rows.push(["damage", st.damage], ["where", where(st)]);
    const html = '<h4><span class="bbr-swatch" style="background:' + c.color + '"></span>' + escapeHtml(c.label) +
      "</h4><table>" + rows.map((r) => "<tr><td>" + r[0] + "</td><td>" + r[1] + "</td></tr>").join("") + "</table>";
    const panel = $(".bbr-panel");
    if (panel.innerHTML !== html) panel.innerHTML = html;
  }

  // --- incidents --------------------------------------------------------------------------------
  const incidents = D.incidents;
  function jump(i) {
    const inc = incidents[i];
    if (inc.cars.length && column(inc.cars[0]) >= 0) setFollow(column(inc.cars[0]));
    seek(Math.max(t0, inc.time_s - BEFORE_S));
    if (state.speed > JUMP_SPEED) setSpeed(JUMP_SPEED);
    setPlaying(true);
  }
  function markIncident() {
    let now = -1;
    for (let i = 0; i < incidents.length && incidents[i].time_s <= state.t; i++) {
      if (!state.hiddenKinds.has(incidents[i].kind)) now = i;
    }
    if (now === state.shownIncident) return;
    const rows = root.querySelectorAll(".bbr-list tbody tr");
    if (state.shownIncident >= 0) rows[state.shownIncident].classList.remove("bbr-now");
    if (now >= 0) rows[now].classList.add("bbr-now");
    state.shownIncident = now;
  }
  function buildIncidents() {
    const body = $(".bbr-list tbody"), line = $(".bbr-timeline"), counts = {};
    incidents.forEach((inc, i) => {
      counts[inc.kind] = (counts[inc.kind] || 0) + 1;
      const tr = document.createElement("tr");
      tr.dataset.kind = inc.kind;
      tr.innerHTML = "<td>" + fmtTime(inc.time_s) + "</td><td>" + inc.lap + "</td><td>" +
        '<span class="bbr-kind" style="background:' + (KIND_COLORS[inc.kind] || "#444") + '">' + inc.kind +
        "</span> " + escapeHtml(inc.text) + "</td><td>" + (inc.dist_m === null ? "-" : inc.dist_m.toFixed(0)) +
        "</td><td>" + (inc.damage || "") + "</td><td>&#9654;</td>";
      tr.addEventListener("click", () => jump(i));
      body.appendChild(tr);
      const mark = document.createElement("div");
      mark.className = "bbr-mark";
      mark.dataset.kind = inc.kind;
      mark.style.left = (100 * (inc.time_s - t0) / Math.max(1e-6, t1 - t0)) + "%";
      mark.style.background = KIND_COLORS[inc.kind] || "#444";
      mark.title = fmtTime(inc.time_s) + " " + inc.kind + ": " + inc.text;
      mark.addEventListener("click", () => jump(i));
      line.appendChild(mark);
    });
    $(".bbr-count").textContent = incidents.length;
    const kinds = $(".bbr-kinds");
    for (const kind of Object.keys(counts)) {
      const label = document.createElement("label");
      label.innerHTML = '<input type="checkbox" checked> <span class="bbr-kind" style="background:' +
        (KIND_COLORS[kind] || "#444") + '">' + kind + "</span> " + counts[kind];
      label.querySelector("input").addEventListener("change", (ev) => {
        if (ev.target.checked) state.hiddenKinds.delete(kind); else state.hiddenKinds.add(kind);
        root.querySelectorAll('[data-kind="' + kind + '"]').forEach((el) => {
          el.style.display = ev.target.checked ? "" : "none";
        });
        state.shownIncident = -2;
        draw();
      });
      kinds.appendChild(label);
    }
  }

  // --- playing -----------------------------------------------------------------------------------
  function seek(t) {
    t = Number(t);
    if (!Number.isFinite(t)) return; // NaN (an empty field, a bad sum): the time stays where it was
    state.t = Math.max(t0, Math.min(t1, t));
    draw();
  }
  function setSpeed(v) {
    v = Number(v);
    if (!Number.isFinite(v) || v <= 0) return;
    state.speed = v;
    $(".bbr-speed").value = String(v);
    draw();
  }
  function frame(now) {
    if (!state.playing) { state.lastWall = null; return; }
    if (state.lastWall !== null) {
      state.t += (now - state.lastWall) / 1000 * state.speed;
      if (state.t >= t1) { state.t = t1; setPlaying(false); }
    }
    state.lastWall = now;
    draw();
    if (state.playing) requestAnimationFrame(frame);
  }
  function setPlaying(on) {
    if (on && state.t >= t1) state.t = t0;
    const was = state.playing;
    state.playing = on;
    $(".bbr-play").innerHTML = on ? "&#10074;&#10074;" : "&#9654;";
    if (on && !was) { state.lastWall = null; requestAnimationFrame(frame); }
  }
  function setFollow(k) {
    state.follow = k;
    $(".bbr-car").value = String(k);
    draw();
  }
  function setMode(mode) {
    state.mode = mode;
    state.zoom = 1;
    $(".bbr-view").value = mode;
    draw();
  }

  // --- wiring -------------------------------------------------------------------------------------
  function wire() {
    const carSelect = $(".bbr-car");
    cars.forEach((c, k) => {
      const o = document.createElement("option");
      o.value = String(k);
      o.textContent = c.label;
      carSelect.appendChild(o);
    });
    carSelect.value = String(state.follow);
    carSelect.addEventListener("change", () => setFollow(Number(carSelect.value)));
    $(".bbr-view").addEventListener("change", (ev) => setMode(ev.target.value));
    $(".bbr-speed").addEventListener("change", (ev) => setSpeed(ev.target.value));
    $(".bbr-play").addEventListener("click", () => setPlaying(!state.playing));
    const scrub = $(".bbr-scrub");
    scrub.min = t0; scrub.max = t1; scrub.step = 0.01;
    scrub.addEventListener("input", () => seek(Number(scrub.value)));
    canvas.addEventListener("click", (ev) => { // a click on a car follows it
      const r = canvas.getBoundingClientRect(), mx = ev.clientX - r.left, my = ev.clientY - r.top;
      let best = -1, bestD = 14;
      cars.forEach((_, k) => {
        const st = carState(k, state.t), [sx, sy] = worldToScreen(st.x, st.y), d = Math.hypot(sx - mx, sy - my);
        if (d < bestD) { best = k; bestD = d; }
      });
      if (best >= 0) setFollow(best);
    });
    canvas.addEventListener("wheel", (ev) => {
      ev.preventDefault();
      state.zoom = Math.max(0.25, Math.min(40, state.zoom * (ev.deltaY < 0 ? 1.25 : 0.8)));
      draw();
    }, { passive: false });
    root.tabIndex = 0;
    root.addEventListener("keydown", (ev) => {
      if (ev.target.tagName === "SELECT" || ev.target.tagName === "INPUT") return;
      if (ev.key === " ") { setPlaying(!state.playing); ev.preventDefault(); }
      if (ev.key === "ArrowLeft") { seek(state.t - 5); ev.preventDefault(); }
      if (ev.key === "ArrowRight") { seek(state.t + 5); ev.preventDefault(); }
    });
    window.addEventListener("resize", resize);
  }

  buildIncidents();
  wire();
  resize();
  window.replay = {
    seek, play: () => setPlaying(true), pause: () => setPlaying(false), time: () => state.t,
    playing: () => state.playing, setSpeed, labels: () => state.labels.slice(),
    view: setMode, follow: (car) => setFollow(column(car)), worldToScreen: (x, y) => { placeView(); return worldToScreen(x, y); },
    carState: (car, t) => carState(column(car), t === undefined ? state.t : t), jump, incidents, cars,
    start: t0, end: t1, canvas, ready: true,
  };
})();
