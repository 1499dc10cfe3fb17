// brachia run view: draws the run embedded in #brachia-data (SI units: s, m, rad, rad/s, N m, J).
// Angles: q1 absolute from +x (counter-clockwise), q2..qn relative; joint 1 at the grip bar.
(function () {
  "use strict";

  const D = JSON.parse(document.getElementById("brachia-data").textContent);
  const $ = (id) => document.getElementById(id);
  const n = D.robot.n;
  const ts = D.t;
  const t0 = ts[0];
  const T = ts[ts.length - 1];
  const HAND = "#d6249f"; // the hand's marker: one colour in both themes
  let time = t0;
  let playing = false;
  let lastFrame = null;

  // ---- samples ---------------------------------------------------------------------------------

  // Index i and fraction f with t between ts[i] and ts[i + 1].
  function locate(t) {
    if (t <= t0) return [0, 0];
    if (t >= T) return [ts.length - 1, 0];
    let lo = 0;
    let hi = ts.length - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (ts[mid] <= t) lo = mid; else hi = mid;
    }
    return [lo, (t - ts[lo]) / (ts[hi] - ts[lo])];
  }

  function lerpRow(rows, t) {
    const [i, f] = locate(t);
    const a = rows[i];
    if (f === 0 || i + 1 >= rows.length) return a.slice();
    const b = rows[i + 1];
    return a.map((v, k) => v + f * (b[k] - v));
  }

  function nearest(t) {
    const [i, f] = locate(t);
    return f > 0.5 && i + 1 < ts.length ? i + 1 : i;
  }

  // Joint positions of the chain at angles q: grip, joints 2..n, hand (m, world frame).
  function joints(q) {
    const pts = [[D.grip[0], D.grip[1]]];
    let th = 0;
    let x = D.grip[0];
    let y = D.grip[1];
    for (let i = 0; i < n; i++) {
      th += q[i];
      x += Math.cos(th) * D.robot.lengths[i];
      y += Math.sin(th) * D.robot.lengths[i];
      pts.push([x, y]);
    }
    return pts;
  }

  // Obstacle centres at time t (moving balls follow obstacle_track; the others stand still).
  function obstacleCentres(t) {
    const track = D.obstacle_track || [];
    let moving = null;
    if (track.length > 0) {
      let i = 0;
      while (i + 1 < track.length && track[i + 1][0] <= t) i++;
      moving = track[i];
    }
    let plantIndex = 0;
    return D.obstacles.map((o) => {
      if (o.kind === "planned") return [o.x, o.y];
      const k = plantIndex++;
      if (moving && moving.length >= 3 + 2 * k) return [moving[1 + 2 * k], moving[2 + 2 * k]];
      return [o.x, o.y];
    });
  }

  // The chain's points (grip first, hand last) of a sample row of D.pts (world frame, flattened).
  const unflat = (row) => Array.from({ length: n + 1 }, (_, k) => [row[2 * k], row[2 * k + 1]]);

  // The chain at time t: from the world-frame points of a traverse (D.pts, re-rooted at every grip
  // switch), else from the joint angles hanging from the grip.
  function chainAt(t) {
    return D.pts ? unflat(lerpRow(D.pts, t)) : joints(lerpRow(D.q, t));
  }
  const chainOf = (i) => (D.pts ? unflat(D.pts[i]) : joints(D.q[i]));

  // Capsule radii of the chain that holds at time t (a traverse holds by either end in turn).
  function radiiAt(t) {
    const r = D.robot.radii;
    return D.hold && D.hold[locate(t)[0]] === 1 ? r.slice().reverse() : r;
  }

  // The bar the hand swings to at time t.
  function targetAt(t) {
    if (!D.swings || !D.bars) return D.target;
    const s = D.swings.find((w) => t < w.t1) || D.swings[D.swings.length - 1];
    return s ? D.bars[s.to] : D.target;
  }

  // The hand's path; a grip switch (the other end becomes the hand) breaks it (null).
  // (the samples on either side of t always belong to one swing: a switch's two rows share a time)
  const handPath = [];
  const pathIndex = ts.map((_, i) => {
    if (D.hold && i > 0 && D.hold[i] !== D.hold[i - 1]) handPath.push(null);
    handPath.push(chainOf(i)[n]);
    return handPath.length - 1;
  });
  const ghostPath = D.ghost ? D.ghost.map((q) => joints(q)[n]) : null;

  // ---- the stage: world (m, y up) to canvas (CSS px, y down) --------------------------------------

  const bounds = (function () {
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    const add = (p, r) => {
      x0 = Math.min(x0, p[0] - r); x1 = Math.max(x1, p[0] + r);
      y0 = Math.min(y0, p[1] - r); y1 = Math.max(y1, p[1] + r);
    };
    const rmax = Math.max.apply(null, D.robot.radii.concat([0.02]));
    ts.forEach((_, i) => chainOf(i).forEach((p) => add(p, rmax)));
    (D.ghost || []).forEach((q) => joints(q).forEach((p) => add(p, rmax)));
    if (D.grip) add(D.grip, 0.05);
    if (D.target) add(D.target, 0.05);
    (D.bars || []).forEach((b) => add(b, 0.05));
    D.obstacles.forEach((o) => add([o.x, o.y], o.r));
    (D.obstacle_track || []).forEach((row) => {
      let k = 0;
      D.obstacles.forEach((o) => {
        if (o.kind === "planned") return;
        if (row.length >= 3 + 2 * k) add([row[1 + 2 * k], row[2 + 2 * k]], o.r);
        k++;
      });
    });
    const m = 0.08 * Math.max(x1 - x0, y1 - y0);
    return { x0: x0 - m, x1: x1 + m, y0: y0 - m, y1: y1 + m };
  })();

  const stage = $("stage");
  const view = { scale: 1, ox: 0, oy: 0, w: 0, h: 0 };

  function colour(name) {
    return getComputedStyle(document.documentElement).getPropertyValue(name).trim();
  }

  function px(p) {
    return [view.ox + view.scale * p[0], view.oy - view.scale * p[1]];
  }

  function sizeCanvas(c, w, h) {
    const dpr = window.devicePixelRatio || 1;
    c.width = Math.round(w * dpr);
    c.height = Math.round(h * dpr);
    c.style.height = h + "px";
    const g = c.getContext("2d");
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    return g;
  }

  function layoutStage() {
    const w = stage.parentElement.clientWidth;
    const bw = bounds.x1 - bounds.x0;
    const bh = bounds.y1 - bounds.y0;
    const h = Math.max(200, Math.min(window.innerHeight * 0.62, w * bh / bw));
    sizeCanvas(stage, w, h);
    view.w = w;
    view.h = h;
    view.scale = Math.min(w / bw, h / bh);
    view.ox = (w - view.scale * bw) / 2 - view.scale * bounds.x0;
    view.oy = (h - view.scale * bh) / 2 + view.scale * bounds.y1;
    stage.dataset.transform = JSON.stringify({ scale: view.scale, ox: view.ox, oy: view.oy });
  }

  function circle(g, p, r, fill, stroke, width) {
    const [x, y] = px(p);
    g.beginPath();
    g.arc(x, y, r, 0, 2 * Math.PI);
    if (fill) { g.fillStyle = fill; g.fill(); }
    if (stroke) { g.strokeStyle = stroke; g.lineWidth = width || 1; g.stroke(); }
  }

  // A polyline through pts; a null entry breaks it.
  function polyline(g, pts, stroke, width, dash) {
    if (pts.length < 2) return;
    g.beginPath();
    let up = true;
    pts.forEach((p) => {
      if (p === null) { up = true; return; }
      const [x, y] = px(p);
      if (up) g.moveTo(x, y); else g.lineTo(x, y);
      up = false;
    });
    g.strokeStyle = stroke;
    g.lineWidth = width;
    g.setLineDash(dash || []);
    g.stroke();
    g.setLineDash([]);
  }

  // The chain as capsules (width = capsule diameter to scale, at least 3 px) with its joints.
  function drawChain(g, pts, radii, linkColour, jointColour, alpha) {
    g.globalAlpha = alpha;
    g.lineCap = "round";
    for (let i = 0; i < n; i++) {
      const [ax, ay] = px(pts[i]);
      const [bx, by] = px(pts[i + 1]);
      g.beginPath();
      g.moveTo(ax, ay);
      g.lineTo(bx, by);
      g.strokeStyle = linkColour;
      g.lineWidth = Math.max(3, 2 * radii[i] * view.scale);
      g.stroke();
    }
    for (let i = 1; i < n; i++) circle(g, pts[i], 3.5, jointColour);
    g.globalAlpha = 1;
    return pts;
  }

  function drawStage() {
    const g = stage.getContext("2d");
    g.clearRect(0, 0, view.w, view.h);
    const centres = obstacleCentres(time);
    D.obstacles.forEach((o, k) => {
      const r = Math.max(2, o.r * view.scale);
      if (o.kind === "planned") {
        g.setLineDash([5, 4]);
        circle(g, centres[k], r, null, colour("--obstacle"), 1.5);
        g.setLineDash([]);
      } else {
        const c = o.kind === "ball" ? colour("--ball") : colour("--obstacle");
        g.globalAlpha = 0.35;
        circle(g, centres[k], r, c);
        g.globalAlpha = 1;
        circle(g, centres[k], r, null, c, 1.5);
      }
    });
    if (ghostPath) polyline(g, ghostPath, colour("--ghost-path"), 1.5, [6, 4]);
    const [i] = locate(time);
    const chain = chainAt(time);
    // the path up to now: the samples before the current one, then the hand now (no line across a
    // grip switch)
    const trail = handPath.slice(0, pathIndex[i] + 1);
    trail.push(chain[n]);
    polyline(g, ghostPath ? trail : handPath, colour("--path"), 1.5, ghostPath ? [] : [2, 3]);
    if (!ghostPath) polyline(g, trail, colour("--path"), 2);
    // the ladder's bars (filled), the target bar (a ring); the grip bar is drawn over the chain
    (D.bars || []).forEach((b) => circle(g, b, 5, colour("--bar")));
    const target = targetAt(time);
    if (target) {
      circle(g, target, 9, null, colour("--target"), 3);
      circle(g, target, 3, colour("--target"));
    }
    if (D.ghost) {
      const gp = drawChain(g, joints(lerpRow(D.ghost, time)), D.robot.radii, colour("--ghost"), colour("--ghost"), 0.45);
      circle(g, gp[n], 4, null, colour("--ghost"), 2);
    }
    const pts = drawChain(g, chain, radiiAt(time), colour("--link"), colour("--joint"), 1);
    circle(g, pts[0], 6, colour("--bar"), colour("--panel"), 1.5);
    circle(g, pts[n], 5, HAND);
  }

  // ---- plots --------------------------------------------------------------------------------------

  const names = (p, k0, m) => Array.from({ length: m }, (_, k) => p + (k + k0));
  const column = (rows, k) => rows.map((r) => r[k]);
  const chainNote = D.hold ? " (of the chain that holds)" : "";
  // The plots of the series in S (the drawn samples, D, or every row, D.full).
  function makeSpecs(S) {
    const out = [
      { title: "joint angles q" + chainNote, unit: "rad", names: names("q", 1, n), data: names("q", 1, n).map((_, k) => column(S.q, k)) },
      { title: "joint velocities qd" + chainNote, unit: "rad/s", names: names("qd", 1, n), data: names("qd", 1, n).map((_, k) => column(S.qd, k)) },
    ];
    if (S.tau) {
      const lim = D.robot.tau_min.concat(D.robot.tau_max);
      out.push({
        title: "torques tau" + chainNote + (lim.length ? " (dashed: limits)" : ""), unit: "N m", names: names("tau", 2, n - 1),
        data: names("tau", 2, n - 1).map((_, k) => column(S.tau, k)),
        limits: lim,
      });
    }
    if (S.ee_error) out.push({ title: "EE distance to the plan's EE", unit: "m", names: ["EE error"], data: [S.ee_error] });
    if (S.energy) out.push({ title: "energy (eq. 18) and positive work", unit: "J", names: ["energy", "positive work"], data: [S.energy, S.work] });
    if (S.mechanical) out.push({ title: "mechanical energy (kinetic + potential)", unit: "J", names: ["energy"], data: [S.mechanical] });
    if (S.control_us) out.push({ title: "controller step time", unit: "us", names: ["step"], data: [S.control_us] });
    return out;
  }
  const specs = makeSpecs(D);
  // the tooltips show every row of the run when the page holds them (D.full), else the drawn samples
  const full = D.full ? { t: D.full.t, specs: makeSpecs(D.full) } : { t: ts, specs: specs };

  const marks = [];
  (D.switches || []).forEach((w) => marks.push({ t: w.t, kind: "--switch", text: w.text }));
  (D.contacts || []).forEach((c) => marks.push({ t: c.t, kind: "--mark", text: "contact: link " + c.link + " with " + c.body + ", " + c.impulse + " N s" }));
  (D.replans || []).forEach((e) => {
    marks.push({ t: e.t, kind: "--replan", text: "re-plan triggered" + (e.adopted ? "" : " (not adopted)") });
    if (e.adopted && e.switch != null) marks.push({ t: e.switch, kind: "--replan", text: "switched to the re-planned swing" });
  });
  if (D.diverged_at != null) marks.push({ t: D.diverged_at, kind: "--mark", text: "diverged" });

  const plots = specs.map((s, index) => {
    const box = document.createElement("div");
    box.className = "plot";
    const h = document.createElement("h2");
    h.textContent = s.title + " [" + s.unit + "]";
    const c = document.createElement("canvas");
    c.tabIndex = 0;
    c.setAttribute("role", "img");
    c.setAttribute("aria-label", s.title + " over time; drag to move the time");
    box.appendChild(h);
    box.appendChild(c);
    $("plots").appendChild(box);
    let lo = Infinity, hi = -Infinity;
    s.data.forEach((col) => col.forEach((v) => { lo = Math.min(lo, v); hi = Math.max(hi, v); }));
    (s.limits || []).forEach((v) => { lo = Math.min(lo, v); hi = Math.max(hi, v); });
    if (!(hi > lo)) { lo -= 1; hi += 1; }
    const pad = 0.06 * (hi - lo);
    return { spec: s, index: index, canvas: c, lo: lo - pad, hi: hi + pad, bg: document.createElement("canvas"), w: 0, h: 0 };
  });

  const M = { l: 44, r: 8, t: 6, b: 16 };
  const tx = (p, t) => M.l + (p.w - M.l - M.r) * (t - t0) / Math.max(T - t0, 1e-9);
  const ty = (p, v) => M.t + (p.h - M.t - M.b) * (p.hi - v) / (p.hi - p.lo);

  function drawPlotBackground(p) {
    p.w = p.canvas.clientWidth;
    p.h = 120;
    sizeCanvas(p.canvas, p.w, p.h);
    const g = sizeCanvas(p.bg, p.w, p.h);
    g.font = "11px system-ui, sans-serif";
    g.fillStyle = colour("--muted");
    g.strokeStyle = colour("--grid");
    g.lineWidth = 1;
    [p.lo, (p.lo + p.hi) / 2, p.hi].forEach((v) => {
      const y = ty(p, v);
      g.beginPath(); g.moveTo(M.l, y); g.lineTo(p.w - M.r, y); g.stroke();
      g.fillText(fmt(v), 2, y + 4);
    });
    g.fillText(fmt(t0) + " s", M.l, p.h - 3);
    const end = fmt(T) + " s";
    g.fillText(end, p.w - M.r - g.measureText(end).width, p.h - 3);
    marks.forEach((m) => {
      g.strokeStyle = colour(m.kind);
      g.globalAlpha = 0.5;
      const x = tx(p, m.t);
      g.beginPath(); g.moveTo(x, M.t); g.lineTo(x, p.h - M.b); g.stroke();
      g.globalAlpha = 1;
    });
    (p.spec.limits || []).forEach((v) => {
      g.strokeStyle = colour("--limit");
      g.setLineDash([4, 3]);
      g.beginPath(); g.moveTo(M.l, ty(p, v)); g.lineTo(p.w - M.r, ty(p, v)); g.stroke();
      g.setLineDash([]);
    });
    p.spec.data.forEach((col, k) => {
      g.strokeStyle = colour("--s" + (k % 6));
      g.lineWidth = 1.5;
      g.beginPath();
      col.forEach((v, i) => {
        const x = tx(p, ts[i]);
        const y = ty(p, v);
        if (i === 0) g.moveTo(x, y); else g.lineTo(x, y);
      });
      g.stroke();
    });
  }

  function drawPlot(p) {
    const g = p.canvas.getContext("2d");
    g.clearRect(0, 0, p.w, p.h);
    g.drawImage(p.bg, 0, 0, p.w, p.h);
    const x = tx(p, time);
    g.strokeStyle = colour("--fg");
    g.lineWidth = 1;
    g.beginPath(); g.moveTo(x, M.t); g.lineTo(x, p.h - M.b); g.stroke();
  }

  function fmt(v) {
    const a = Math.abs(v);
    if (a !== 0 && (a < 1e-3 || a >= 1e4)) return v.toExponential(2);
    return v.toFixed(a < 1 ? 4 : 3).replace(/\.?0+$/, "") || "0";
  }

  function timeAt(p, clientX) {
    const rect = p.canvas.getBoundingClientRect();
    const f = (clientX - rect.left - M.l) / Math.max(1, p.w - M.l - M.r);
    return t0 + Math.min(1, Math.max(0, f)) * (T - t0);
  }

  // Index of the row of times `tt` nearest to t.
  function nearestIn(tt, t) {
    let lo = 0;
    let hi = tt.length - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (tt[mid] <= t) lo = mid; else hi = mid;
    }
    return Math.abs(tt[hi] - t) < Math.abs(t - tt[lo]) ? hi : lo;
  }

  function showTip(p, e) {
    const t = timeAt(p, e.clientX);
    const i = nearestIn(full.t, t);
    const fs = full.specs[p.index];
    const lines = ["t = " + full.t[i].toFixed(3) + " s"];
    fs.names.forEach((name, k) => lines.push(name + " = " + fmt(fs.data[k][i]) + " " + fs.unit));
    const span = Math.max(0.01, 4 * (T - t0) / Math.max(1, p.w));
    marks.filter((m) => Math.abs(m.t - full.t[i]) < span).slice(0, 3).forEach((m) => lines.push(m.text + " at " + m.t.toFixed(3) + " s"));
    const tip = $("tip");
    tip.textContent = lines.join("\n");
    tip.hidden = false;
    const left = Math.min(e.clientX + 14, window.innerWidth - tip.offsetWidth - 4);
    tip.style.left = left + "px";
    tip.style.top = (e.clientY + 14) + "px";
  }

  plots.forEach((p) => {
    let dragging = false;
    p.canvas.addEventListener("pointerdown", (e) => {
      dragging = true;
      p.canvas.setPointerCapture(e.pointerId);
      pause();
      setTime(timeAt(p, e.clientX));
    });
    p.canvas.addEventListener("pointermove", (e) => {
      if (dragging) setTime(timeAt(p, e.clientX));
      showTip(p, e);
    });
    p.canvas.addEventListener("pointerup", () => { dragging = false; });
    p.canvas.addEventListener("pointerleave", () => { $("tip").hidden = true; });
  });

  // ---- time, playback, keys, theme ----------------------------------------------------------------

  const slider = $("slider");
  slider.min = String(t0);
  slider.max = String(T);

  function setTime(t, keepHash) {
    if (!Number.isFinite(t)) return;
    time = Math.min(T, Math.max(t0, t));
    slider.value = String(time);
    $("time-readout").textContent = "t = " + time.toFixed(3) + " s of " + T.toFixed(3) + " s";
    drawStage();
    plots.forEach(drawPlot);
    if (!playing && !keepHash) {
      try { history.replaceState(null, "", "#t=" + time.toFixed(3)); } catch (err) { /* a page without history */ }
    }
  }

  function frame(now) {
    if (!playing) return;
    if (lastFrame !== null) {
      const speed = Number($("speed").value) || 1;
      const t = time + speed * (now - lastFrame) / 1000;
      setTime(t, true);
      if (t >= T) { pause(); return; }
    }
    lastFrame = now;
    requestAnimationFrame(frame);
  }

  function play() {
    if (playing) return;
    if (time >= T) setTime(t0, true);
    playing = true;
    lastFrame = null;
    $("play").textContent = "pause";
    requestAnimationFrame(frame);
  }

  function pause() {
    if (!playing) return;
    playing = false;
    $("play").textContent = "play";
    setTime(time);
  }

  $("play").addEventListener("click", () => (playing ? pause() : play()));
  slider.addEventListener("input", () => { pause(); setTime(Number(slider.value)); });

  document.addEventListener("keydown", (e) => {
    const tag = (e.target && e.target.tagName) || "";
    if (tag === "SELECT") return;
    if (e.key === "ArrowRight" || e.key === "ArrowLeft") {
      pause();
      const [i, f] = locate(time);
      const k = e.key === "ArrowRight" ? i + 1 : (f > 0 ? i : i - 1);
      setTime(ts[Math.min(ts.length - 1, Math.max(0, k))]);
      e.preventDefault();
    } else if (e.key === " " && tag !== "BUTTON") {
      if (playing) pause(); else play();
      e.preventDefault();
    } else if (e.key === "Home") {
      pause(); setTime(t0); e.preventDefault();
    } else if (e.key === "End") {
      pause(); setTime(T); e.preventDefault();
    }
  });

  function fromHash() {
    const m = /(?:^#|&)t=([-+0-9.eE]+)/.exec(location.hash);
    return m ? Number(m[1]) : null;
  }

  window.addEventListener("hashchange", () => {
    const t = fromHash();
    if (t !== null) { pause(); setTime(t, true); }
  });

  function redrawAll() {
    layoutStage();
    plots.forEach(drawPlotBackground);
    setTime(time, true);
  }

  $("theme").addEventListener("click", () => {
    const root = document.documentElement;
    const dark = root.dataset.theme
      ? root.dataset.theme === "dark"
      : window.matchMedia("(prefers-color-scheme: dark)").matches;
    root.dataset.theme = dark ? "light" : "dark";
    redrawAll();
  });
  window.addEventListener("resize", redrawAll);

  // ---- legend, text, first draw -------------------------------------------------------------------

  $("subtitle").textContent = D.subtitle || "";
  (D.notes || []).forEach((text) => {
    const p = document.createElement("p");
    p.className = "note";
    p.textContent = text;
    $("notes").appendChild(p);
  });
  const legend = [["--link", "robot (tracked)"]];
  if (D.target) legend.push(["--target", "target bar"]);
  legend.push(["--bar", D.bars ? "bars (filled: grip and ladder)" : "grip bar"]);
  if (D.ghost) legend.splice(1, 0, ["--ghost", "plan (ghost)"]);
  legend.push(["--path", "hand path"]);
  if (D.obstacles.some((o) => o.kind !== "ball")) legend.push(["--obstacle", "obstacles (dashed: as planned)"]);
  if (D.obstacles.some((o) => o.kind === "ball")) legend.push(["--ball", "free ball (as it moves)"]);
  if ((D.contacts || []).length || D.diverged_at != null) legend.push(["--mark", "contacts: marks in the plots"]);
  if ((D.replans || []).length) legend.push(["--replan", "re-plans: marks in the plots"]);
  if (D.switches && D.switches.length) legend.push(["--switch", "grip switches: marks in the plots"]);
  if (D.kind === "plan") legend[0][1] = "robot (plan)";
  if (D.kind === "simulate") legend[0][1] = "robot (simulated, no torque)";
  if (D.kind === "traverse") legend[0][1] = "robot (tracked, world frame)";
  legend.forEach(([c, text]) => {
    const li = document.createElement("li");
    const sw = document.createElement("span");
    sw.className = "sw";
    sw.style.background = "var(" + c + ")";
    li.appendChild(sw);
    li.appendChild(document.createTextNode(text));
    $("legend").appendChild(li);
  });

  // A small hook for scripts and tests: the drawing transform and the robot's state.
  window.brachiaView = {
    T: T,
    t0: t0,
    target: D.target ? D.target.slice() : null,
    kind: D.kind,
    time: () => time,
    playing: () => playing,
    setTime: (t) => { pause(); setTime(t); },
    // the marks of the plots (contacts, re-plans, grip switches): time, s, and what happened
    marks: () => marks.map((m) => ({ t: m.t, text: m.text })),
    hand: (t) => chainAt(t === undefined ? time : t)[n],
    // a world point (m) in page CSS pixels of the viewport
    toPage: (x, y) => {
      const r = stage.getBoundingClientRect();
      const [cx, cy] = px([x, y]);
      return [r.left + cx, r.top + cy];
    },
  };

  redrawAll();
  const start = fromHash();
  setTime(start === null ? t0 : start, true);
  document.documentElement.dataset.ready = "1";
})();
