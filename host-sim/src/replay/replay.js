// Replay of a virtual-tube transport flight (host-sim, issue 17). Plain <canvas> 2-D drawing
// with its own perspective projection; no library, no network. World frame ENU, metres.
(function () {
  'use strict';

  // ------------------------------------------------------------------ test hooks
  const errors = [];
  window.addEventListener('error', (e) => { errors.push(String(e.message || e)); });
  const consoleError = console.error.bind(console);
  console.error = function () { errors.push(Array.from(arguments).join(' ')); consoleError.apply(null, arguments); };

  // ------------------------------------------------------------------ data
  const RAW = JSON.parse(document.getElementById('vt-data').textContent);
  const MM = 1e-3, DN = 0.1;
  /** Tensions below this are drawn as slack, N. */
  const SLACK_N = 0.1;
  const m = (v) => (v === null || v === undefined ? NaN : v * MM);

  function decodeRun(r) {
    const k = r.t.length, n = r.n;
    const run = {
      name: r.controller, scenario: r.scenario, n: n, colors: r.colors, rated: r.rated_n > 0 ? r.rated_n : 1,
      fmax: r.f_max_n, altRef: r.alt_ref_m, trayH: r.tray_h_m, events: r.events || [],
      t: new Float64Array(k), uav: [], load: [], ten: [], node: [], mode: r.mode || [], clear: [],
    };
    for (let i = 0; i < k; i++) {
      run.t[i] = r.t[i] === null ? NaN : r.t[i] * 1e-3;
      const u = new Float32Array(3 * n);
      for (let j = 0; j < 3 * n; j++) u[j] = m(r.uav[i] ? r.uav[i][j] : null);
      run.uav.push(u);
      run.load.push([m(r.load[i][0]), m(r.load[i][1]), m(r.load[i][2])]);
      const t = new Float32Array(n);
      for (let j = 0; j < n; j++) { const v = r.ten[i] ? r.ten[i][j] : null; t[j] = v === null || v === undefined ? NaN : v * DN; }
      run.ten.push(t);
      if (r.node && r.node[i]) {
        const q = new Float32Array(2 * n);
        for (let j = 0; j < 2 * n; j++) q[j] = m(r.node[i][j]);
        run.node.push(q);
      }
      const c = r.clear[i] || [null, null, null];
      run.clear.push([m(c[0]), m(c[1]), m(c[2])]);
    }
    // Highest point flown, for the obstacle height.
    let zmax = 0;
    for (const u of run.uav) for (let j = 2; j < u.length; j += 3) if (u[j] > zmax) zmax = u[j];
    run.zmax = zmax;
    return run;
  }

  const scene = {
    center: RAW.scene.centerline.map((p) => [p[0] * MM, p[1] * MM]),
    left: RAW.scene.left.map((p) => [p[0] * MM, p[1] * MM]),
    right: RAW.scene.right.map((p) => [p[0] * MM, p[1] * MM]),
    obstacles: RAW.scene.obstacles.map((o) => [o[0] * MM, o[1] * MM, o[2] * MM]),
    bounds: RAW.scene.bounds.map((v) => v * MM),
  };
  const runs = RAW.runs.map(decodeRun);
  const tEnd = Math.max(0, ...runs.map((r) => (r.t.length ? r.t[r.t.length - 1] : 0)));
  const obstacleTop = Math.max(4, ...runs.map((r) => r.zmax + 1.5));
  if (!(scene.bounds[1] > scene.bounds[0] && scene.bounds[3] > scene.bounds[2])) {
    // No bounds recorded: fit the samples.
    let b = [Infinity, -Infinity, Infinity, -Infinity];
    for (const r of runs) for (const u of r.uav) for (let j = 0; j < u.length; j += 3) {
      if (!isFinite(u[j])) continue;
      b = [Math.min(b[0], u[j]), Math.max(b[1], u[j]), Math.min(b[2], u[j + 1]), Math.max(b[3], u[j + 1])];
    }
    scene.bounds = isFinite(b[0]) ? [b[0] - 2, b[1] + 2, b[2] - 2, b[3] + 2] : [-10, 10, -10, 10];
  }

  // ------------------------------------------------------------------ state
  const st = {
    time: 0, playing: true, speed: 1, layout: 'side', tray: false, follow: true, trail: true,
    cams: [], tops: [],
  };
  (function parseHash() {
    const h = (location.hash || '').replace(/^#/, '');
    for (const part of h.split('&')) {
      const [k, v] = part.split('=');
      if (k === 't' && isFinite(parseFloat(v))) st.time = Math.min(Math.max(parseFloat(v), 0), tEnd);
      if (k === 'paused') st.playing = false;
      if (k === 'speed' && parseFloat(v) > 0) st.speed = parseFloat(v);
      if (k === 'overlay') st.layout = 'overlay';
      if (k === 'tray') st.tray = true;
    }
  })();

  /** Index of the last sample at or before `t` (binary search). */
  function frameOf(run, t) {
    const a = run.t;
    if (!a.length) return -1;
    let lo = 0, hi = a.length - 1;
    if (t >= a[hi]) return hi;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (a[mid] <= t) lo = mid; else hi = mid - 1;
    }
    return lo;
  }

  // ------------------------------------------------------------------ colours
  /** Tension colour: green (slack side) through yellow to red at the rated capacity, dark red above. */
  function tensionColor(f, rated) {
    if (!isFinite(f)) return '#888888';
    const x = Math.max(0, f / rated);
    const stops = [[0, [26, 152, 80]], [0.5, [254, 224, 139]], [0.85, [215, 48, 39]], [1.0, [127, 0, 0]]];
    if (x >= 1) return 'rgb(127,0,0)';
    for (let i = 1; i < stops.length; i++) {
      if (x <= stops[i][0]) {
        const [x0, c0] = stops[i - 1], [x1, c1] = stops[i];
        const s = (x - x0) / (x1 - x0);
        const c = c0.map((v, j) => Math.round(v + s * (c1[j] - v)));
        return 'rgb(' + c.join(',') + ')';
      }
    }
    return 'rgb(127,0,0)';
  }
  const BG = '#f7f9fc';
  const EVENT_STYLE = {
    snap: ['#d62728', 'cable snap'], silent: ['#7b3fa0', 'UAV silent'], thrust_loss: ['#8c564b', 'thrust loss'],
    own_feed_stall: ['#e377c2', 'own feed stall'], link_dead: ['#17becf', 'link dead'],
    hold: ['#ff9f1c', 'hold'], resume: ['#2ca02c', 'resume'],
  };
  /** Faults that happened to UAV `i` of `run` up to time `t`. */
  function faultsOf(run, t) {
    const f = {};
    for (const e of run.events) {
      if (e.time_s > t) break;
      if (e.kind === 'snap' || e.kind === 'silent' || e.kind === 'thrust_loss' || e.kind === 'link_dead') (f[e.uav] = f[e.uav] || {})[e.kind] = true;
    }
    return f;
  }

  // ------------------------------------------------------------------ layout
  const panelsEl = document.getElementById('vt-panels');
  let panels = [];
  if (runs.length > 1) document.getElementById('vt-layout-box').hidden = false;

  function buildPanels() {
    panelsEl.textContent = '';
    panels = [];
    const groups = st.layout === 'overlay' || runs.length < 2 ? [runs.map((_, i) => i)] : runs.map((_, i) => [i]);
    groups.forEach((g, pi) => {
      const p = document.createElement('div');
      p.className = 'panel';
      const label = g.map((i) => runs[i].name + (g.length > 1 ? (i === 0 ? ' (filled)' : ' (rings)') : '')).join(' + ');
      const mk = (cls, tag) => {
        const v = document.createElement('div');
        v.className = 'view ' + cls;
        const c = document.createElement('canvas');
        const s = document.createElement('span');
        s.className = 'tag';
        s.textContent = tag + ' - ' + label;
        v.appendChild(c); v.appendChild(s); p.appendChild(v);
        return c;
      };
      const c3 = mk('v3d', '3-D view'), ct = mk('vtop', 'top view');
      panelsEl.appendChild(p);
      if (!st.cams[pi]) st.cams[pi] = defaultCam();
      if (!st.tops[pi]) st.tops[pi] = null;
      const panel = { runs: g, c3: c3, ct: ct, cam: pi, uavPx: [], topPx: [] };
      attach3d(c3, pi);
      attachTop(ct, pi);
      panels.push(panel);
    });
    resize();
  }

  function resize() {
    for (const p of panels) for (const c of [p.c3, p.ct]) {
      const r = c.parentElement.getBoundingClientRect();
      const dpr = window.devicePixelRatio || 1;
      c.width = Math.max(1, Math.round(r.width * dpr));
      c.height = Math.max(1, Math.round(r.height * dpr));
    }
    drawTimeline();
    render();
  }

  // ------------------------------------------------------------------ 3-D camera
  function formationSpan() {
    const r = runs[0];
    if (!r || !r.uav.length) return 5;
    const u = r.uav[0], l = r.load[0];
    let s = 1;
    for (let j = 0; j < u.length; j += 3) {
      const d = Math.hypot(u[j] - l[0], u[j + 1] - l[1], u[j + 2] - l[2]);
      if (isFinite(d)) s = Math.max(s, d);
    }
    return s;
  }
  function defaultCam() {
    const span = formationSpan();
    const b = scene.bounds;
    // Behind the start of the tube, looking along it, a little to its right.
    const c = scene.center;
    const d = c.length > 1 ? [c[c.length - 1][0] - c[0][0], c[c.length - 1][1] - c[0][1]] : [1, 0];
    const yaw = Math.atan2(d[1], d[0]) + Math.PI - 0.6;
    return { yaw: yaw, pitch: 0.72, dist: Math.max(12, 5.5 * span), target: [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, 2], pan: [0, 0, 0] };
  }
  /** Camera basis: eye, right, up, forward. */
  function basis(cam, target) {
    const cp = Math.cos(cam.pitch), sp = Math.sin(cam.pitch);
    const f = [-cp * Math.cos(cam.yaw), -cp * Math.sin(cam.yaw), -sp];
    const eye = [target[0] - cam.dist * f[0], target[1] - cam.dist * f[1], target[2] - cam.dist * f[2]];
    let r = [f[1], -f[0], 0];
    const rn = Math.hypot(r[0], r[1]) || 1;
    r = [r[0] / rn, r[1] / rn, 0];
    const u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]];
    return { eye: eye, r: r, u: u, f: f };
  }
  const NEAR = 0.2;
  /** Perspective projection of world point `p`: [x, y, depth] in canvas pixels, or null behind the camera. */
  function projector(cam, target, w, h) {
    const B = basis(cam, target);
    const F = (0.5 * h) / Math.tan((50 * Math.PI) / 360);
    const fn = function (p) {
      const v = [p[0] - B.eye[0], p[1] - B.eye[1], p[2] - B.eye[2]];
      const z = v[0] * B.f[0] + v[1] * B.f[1] + v[2] * B.f[2];
      if (!(z > NEAR)) return null;
      const x = v[0] * B.r[0] + v[1] * B.r[1] + v[2] * B.r[2];
      const y = v[0] * B.u[0] + v[1] * B.u[1] + v[2] * B.u[2];
      return [w / 2 + (F * x) / z, h / 2 - (F * y) / z, z];
    };
    fn.F = F; fn.B = B;
    return fn;
  }
  function camTarget(pi) {
    const cam = st.cams[pi];
    const p = panels.find((q) => q.cam === pi);
    let t = cam.target;
    if (st.follow && p) {
      const r = runs[p.runs[0]];
      const k = frameOf(r, st.time);
      const l = k >= 0 ? r.load[k] : null;
      if (l && isFinite(l[0])) t = [l[0], l[1], l[2] + 0.4 * (r.trayH || 2)];
    }
    return [t[0] + cam.pan[0], t[1] + cam.pan[1], t[2] + cam.pan[2]];
  }

  function attach3d(c, pi) {
    let drag = null;
    c.addEventListener('contextmenu', (e) => e.preventDefault());
    c.addEventListener('pointerdown', (e) => { drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2 }; c.setPointerCapture(e.pointerId); });
    c.addEventListener('pointerup', () => { drag = null; });
    c.addEventListener('pointermove', (e) => {
      if (!drag) return;
      const cam = st.cams[pi];
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      drag.x = e.clientX; drag.y = e.clientY;
      if (drag.pan) {
        const B = basis(cam, [0, 0, 0]);
        const s = (cam.dist * 1.2) / c.clientHeight;
        for (let j = 0; j < 3; j++) cam.pan[j] += s * (-dx * B.r[j] + dy * B.u[j]);
      } else {
        cam.yaw -= dx * 0.008;
        cam.pitch = Math.min(1.55, Math.max(0.03, cam.pitch + dy * 0.006));
      }
      render();
    });
    c.addEventListener('wheel', (e) => {
      e.preventDefault();
      const cam = st.cams[pi];
      cam.dist = Math.min(500, Math.max(2, cam.dist * Math.exp(e.deltaY * 0.0012)));
      render();
    }, { passive: false });
  }

  // ------------------------------------------------------------------ 3-D view
  function line(ctx, pts) {
    let on = false;
    ctx.beginPath();
    for (const q of pts) {
      if (!q) { on = false; continue; }
      if (on) ctx.lineTo(q[0], q[1]); else ctx.moveTo(q[0], q[1]);
      on = true;
    }
    ctx.stroke();
  }

  function drawGround(ctx, P, dpr) {
    const b = scene.bounds;
    // Grid every 5 m.
    ctx.strokeStyle = '#dfe4ec';
    ctx.lineWidth = dpr;
    const step = 5;
    for (let x = Math.ceil(b[0] / step) * step; x <= b[1]; x += step) line(ctx, seg([x, b[2], 0], [x, b[3], 0], P));
    for (let y = Math.ceil(b[2] / step) * step; y <= b[3]; y += step) line(ctx, seg([b[0], y, 0], [b[1], y, 0], P));
    // Tube corridor on the ground.
    if (scene.left.length > 1 && scene.right.length > 1) {
      const poly = scene.left.map((p) => P([p[0], p[1], 0])).concat(scene.right.slice().reverse().map((p) => P([p[0], p[1], 0])));
      if (poly.every((q) => q)) {
        ctx.fillStyle = 'rgba(120,160,230,0.16)';
        ctx.beginPath();
        poly.forEach((q, i) => (i ? ctx.lineTo(q[0], q[1]) : ctx.moveTo(q[0], q[1])));
        ctx.closePath();
        ctx.fill();
      }
    }
    ctx.strokeStyle = '#283759';
    ctx.lineWidth = 1.6 * dpr;
    line(ctx, scene.left.map((p) => P([p[0], p[1], 0])));
    line(ctx, scene.right.map((p) => P([p[0], p[1], 0])));
    ctx.setLineDash([6 * dpr, 5 * dpr]);
    ctx.strokeStyle = '#8f97a6';
    ctx.lineWidth = dpr;
    line(ctx, scene.center.map((p) => P([p[0], p[1], 0])));
    ctx.setLineDash([]);
  }
  /** A straight segment subdivided so the near-plane clip does not drop it whole. */
  function seg(a, b, P) {
    const out = [];
    for (let i = 0; i <= 16; i++) {
      const s = i / 16;
      out.push(P([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]), a[2] + s * (b[2] - a[2])]));
    }
    return out;
  }
  /** Tube boundary at the load's reference altitude (faint), for depth. */
  function drawTubeAtAltitude(ctx, P, dpr, z) {
    ctx.strokeStyle = 'rgba(40,55,90,0.28)';
    ctx.lineWidth = dpr;
    line(ctx, scene.left.map((p) => P([p[0], p[1], z])));
    line(ctx, scene.right.map((p) => P([p[0], p[1], z])));
  }

  const LIGHT = [0.55, -0.35, 0.76];
  function obstacleItems(P, eye) {
    const items = [];
    const SEG = 28;
    for (const o of scene.obstacles) {
      const [cx, cy, r] = o;
      const depth = Math.hypot(cx - eye[0], cy - eye[1], obstacleTop / 2 - eye[2]);
      items.push({
        depth: depth,
        draw: (ctx) => {
          const quads = [];
          for (let i = 0; i < SEG; i++) {
            const a0 = (i / SEG) * 2 * Math.PI, a1 = ((i + 1) / SEG) * 2 * Math.PI, am = (a0 + a1) / 2;
            const nx = Math.cos(am), ny = Math.sin(am);
            const px = cx + r * nx, py = cy + r * ny;
            if (nx * (eye[0] - px) + ny * (eye[1] - py) <= 0) continue;
            const pts = [[a0, 0], [a1, 0], [a1, obstacleTop], [a0, obstacleTop]].map(([a, z]) => P([cx + r * Math.cos(a), cy + r * Math.sin(a), z]));
            if (pts.some((q) => !q)) continue;
            const lum = 0.58 + 0.32 * Math.max(0, nx * LIGHT[0] + ny * LIGHT[1]);
            quads.push([pts, lum]);
          }
          for (const [pts, lum] of quads) {
            const g = Math.round(200 * lum);
            ctx.fillStyle = 'rgb(' + g + ',' + g + ',' + Math.round(g * 1.03) + ')';
            ctx.strokeStyle = ctx.fillStyle;
            ctx.lineWidth = 1;
            ctx.beginPath();
            pts.forEach((q, i) => (i ? ctx.lineTo(q[0], q[1]) : ctx.moveTo(q[0], q[1])));
            ctx.closePath();
            ctx.fill();
            ctx.stroke();
          }
          if (eye[2] > obstacleTop) {
            const cap = [];
            for (let i = 0; i < SEG; i++) cap.push(P([cx + r * Math.cos((i / SEG) * 2 * Math.PI), cy + r * Math.sin((i / SEG) * 2 * Math.PI), obstacleTop]));
            if (cap.every((q) => q)) {
              ctx.fillStyle = '#d9dce2';
              ctx.strokeStyle = '#8a8f99';
              ctx.beginPath();
              cap.forEach((q, i) => (i ? ctx.lineTo(q[0], q[1]) : ctx.moveTo(q[0], q[1])));
              ctx.closePath();
              ctx.fill();
              ctx.stroke();
            }
          }
        },
      });
    }
    return items;
  }

  /** Draw list of one run at the current time: cables, tray, UAVs, load. */
  function runItems(ri, slot, P, dpr, ctx, panel) {
    const run = runs[ri];
    const k = frameOf(run, st.time);
    const items = [];
    if (k < 0) return items;
    const u = run.uav[k], l = run.load[k], ten = run.ten[k];
    const faults = faultsOf(run, st.time);
    const mode = run.mode[k] || '';
    const hollow = slot > 0;
    const eye = P.B.eye;
    const dist = (p) => Math.hypot(p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]);
    const px = [];
    // Load trail.
    if (st.trail) {
      const pts = [];
      for (let i = 0; i <= k; i += 2) pts.push(P(run.load[i]));
      ctx.strokeStyle = hollow ? 'rgba(60,60,60,0.35)' : 'rgba(30,30,30,0.5)';
      ctx.lineWidth = 1.2 * dpr;
      line(ctx, pts);
    }
    const lp = P(l);
    for (let i = 0; i < run.n; i++) {
      const p = [u[3 * i], u[3 * i + 1], u[3 * i + 2]];
      const q = isFinite(p[0]) ? P(p) : null;
      px.push(q);
      if (!q) continue;
      // Shadow and drop line.
      const sh = P([p[0], p[1], 0]);
      if (sh) {
        items.push({ depth: dist([p[0], p[1], 0]) + 1e3, draw: () => {
          ctx.fillStyle = 'rgba(40,50,70,0.18)';
          ctx.beginPath();
          ctx.ellipse(sh[0], sh[1], (0.35 * P.F) / sh[2], (0.18 * P.F) / sh[2], 0, 0, 2 * Math.PI);
          ctx.fill();
        } });
      }
      // Cable.
      if (lp && !faults[i]?.snap) {
        const f = ten[i];
        items.push({ depth: dist([(p[0] + l[0]) / 2, (p[1] + l[1]) / 2, (p[2] + l[2]) / 2]) + 0.01, draw: () => {
          ctx.strokeStyle = f > SLACK_N ? tensionColor(f, run.rated) : '#9aa0aa';
          ctx.lineWidth = (f > SLACK_N ? 2.6 : 1.4) * dpr;
          if (hollow) ctx.setLineDash([7 * dpr, 4 * dpr]);
          ctx.beginPath(); ctx.moveTo(q[0], q[1]); ctx.lineTo(lp[0], lp[1]); ctx.stroke();
          ctx.setLineDash([]);
        } });
      }
      // UAV: body and four rotors, drawn as a disc of 0.35 m radius (at least 5 px).
      const rad = Math.max(5 * dpr, (0.35 * P.F) / q[2]);
      const hold = mode[i] === '1';
      items.push({ depth: dist(p), draw: () => {
        ctx.lineWidth = 1.5 * dpr;
        ctx.strokeStyle = '#1b2232';
        ctx.fillStyle = run.colors[i];
        ctx.beginPath();
        ctx.arc(q[0], q[1], rad, 0, 2 * Math.PI);
        if (hollow) { ctx.lineWidth = 3 * dpr; ctx.strokeStyle = run.colors[i]; ctx.stroke(); ctx.fillStyle = 'rgba(255,255,255,0.55)'; ctx.fill(); }
        else { ctx.fill(); ctx.stroke(); }
        if (hold || faults[i]) {
          ctx.strokeStyle = faults[i]?.thrust_loss ? EVENT_STYLE.thrust_loss[0] : faults[i]?.silent ? EVENT_STYLE.silent[0] : faults[i]?.link_dead ? EVENT_STYLE.link_dead[0] : EVENT_STYLE.hold[0];
          ctx.lineWidth = 2.5 * dpr;
          if (faults[i]?.silent) ctx.setLineDash([4 * dpr, 3 * dpr]);
          ctx.beginPath(); ctx.arc(q[0], q[1], rad + 4 * dpr, 0, 2 * Math.PI); ctx.stroke();
          ctx.setLineDash([]);
        }
      } });
    }
    // Tray nodes and springs (eq:2-4 nodes, springs between every pair of nodes, eq:2-5).
    if (st.tray && run.node[k] && isFinite(l[2])) {
      const z = l[2] + run.trayH;
      const nq = [];
      for (let i = 0; i < run.n; i++) nq.push(isFinite(run.node[k][2 * i]) ? P([run.node[k][2 * i], run.node[k][2 * i + 1], z]) : null);
      const lq = P([l[0], l[1], z]);
      items.push({ depth: dist([l[0], l[1], z]), draw: () => {
        ctx.strokeStyle = 'rgba(120,70,170,0.35)';
        ctx.lineWidth = dpr;
        ctx.beginPath();
        for (let i = 0; i < nq.length; i++) for (let j = i + 1; j < nq.length; j++) {
          if (nq[i] && nq[j]) { ctx.moveTo(nq[i][0], nq[i][1]); ctx.lineTo(nq[j][0], nq[j][1]); }
        }
        if (lq) for (const a of nq) if (a) { ctx.moveTo(a[0], a[1]); ctx.lineTo(lq[0], lq[1]); }
        ctx.stroke();
        ctx.fillStyle = '#7846aa';
        for (let i = 0; i < nq.length; i++) if (nq[i]) { ctx.fillRect(nq[i][0] - 3 * dpr, nq[i][1] - 3 * dpr, 6 * dpr, 6 * dpr); }
        if (lq) { ctx.beginPath(); ctx.arc(lq[0], lq[1], 3.5 * dpr, 0, 2 * Math.PI); ctx.fill(); }
      } });
    }
    // Load: a dark box of 0.5 m.
    if (lp) {
      const s = Math.max(5 * dpr, (0.25 * P.F) / lp[2]);
      items.push({ depth: dist(l), draw: () => {
        ctx.fillStyle = hollow ? 'rgba(255,255,255,0.6)' : '#1b1b1b';
        ctx.strokeStyle = '#000';
        ctx.lineWidth = (hollow ? 3 : 1.5) * dpr;
        ctx.fillRect(lp[0] - s, lp[1] - s, 2 * s, 2 * s);
        ctx.strokeRect(lp[0] - s, lp[1] - s, 2 * s, 2 * s);
      } });
    }
    panel.uavPx[slot] = px;
    return items;
  }

  function render3d(panel) {
    const c = panel.c3, ctx = c.getContext('2d');
    const dpr = window.devicePixelRatio || 1;
    const w = c.width, h = c.height;
    ctx.fillStyle = BG;
    ctx.fillRect(0, 0, w, h);
    const P = projector(st.cams[panel.cam], camTarget(panel.cam), w, h);
    drawGround(ctx, P, dpr);
    drawTubeAtAltitude(ctx, P, dpr, runs[panel.runs[0]]?.altRef || 0);
    let items = obstacleItems(P, P.B.eye);
    panel.uavPx = [];
    panel.runs.forEach((ri, slot) => { items = items.concat(runItems(ri, slot, P, dpr, ctx, panel)); });
    items.sort((a, b) => b.depth - a.depth);
    for (const it of items) it.draw(ctx);
  }

  // ------------------------------------------------------------------ top view
  function topFit(c) {
    const b = scene.bounds;
    const w = c.width, h = c.height;
    const s = Math.min(w / (b[1] - b[0]), h / (b[3] - b[2])) * 0.94;
    return { s: s, cx: (b[0] + b[1]) / 2, cy: (b[2] + b[3]) / 2 };
  }
  function attachTop(c, pi) {
    let drag = null;
    c.addEventListener('pointerdown', (e) => { drag = { x: e.clientX, y: e.clientY }; c.setPointerCapture(e.pointerId); });
    c.addEventListener('pointerup', () => { drag = null; });
    c.addEventListener('pointermove', (e) => {
      if (!drag) return;
      const v = st.tops[pi] || (st.tops[pi] = topFit(c));
      const dpr = window.devicePixelRatio || 1;
      v.cx -= ((e.clientX - drag.x) * dpr) / v.s;
      v.cy += ((e.clientY - drag.y) * dpr) / v.s;
      drag.x = e.clientX; drag.y = e.clientY;
      render();
    });
    c.addEventListener('wheel', (e) => {
      e.preventDefault();
      const v = st.tops[pi] || (st.tops[pi] = topFit(c));
      v.s = Math.min(2000, Math.max(0.5, v.s * Math.exp(-e.deltaY * 0.0012)));
      render();
    }, { passive: false });
  }
  function renderTop(panel, pi) {
    const c = panel.ct, ctx = c.getContext('2d');
    const dpr = window.devicePixelRatio || 1;
    const w = c.width, h = c.height;
    const v = st.tops[pi] || topFit(c);
    const T = (p) => [w / 2 + (p[0] - v.cx) * v.s, h / 2 - (p[1] - v.cy) * v.s];
    ctx.fillStyle = BG;
    ctx.fillRect(0, 0, w, h);
    if (scene.left.length > 1) {
      ctx.fillStyle = 'rgba(120,160,230,0.16)';
      ctx.beginPath();
      scene.left.concat(scene.right.slice().reverse()).forEach((p, i) => { const q = T(p); i ? ctx.lineTo(q[0], q[1]) : ctx.moveTo(q[0], q[1]); });
      ctx.closePath();
      ctx.fill();
    }
    ctx.strokeStyle = '#283759'; ctx.lineWidth = 1.6 * dpr;
    line(ctx, scene.left.map(T)); line(ctx, scene.right.map(T));
    ctx.setLineDash([6 * dpr, 5 * dpr]); ctx.strokeStyle = '#8f97a6'; ctx.lineWidth = dpr;
    line(ctx, scene.center.map(T));
    ctx.setLineDash([]);
    for (const o of scene.obstacles) {
      const q = T(o);
      ctx.fillStyle = '#afafaf'; ctx.strokeStyle = '#6e6e6e'; ctx.lineWidth = dpr;
      ctx.beginPath(); ctx.arc(q[0], q[1], o[2] * v.s, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    }
    // Scale bar.
    const bar = [1, 2, 5, 10, 20, 50].find((x) => x * v.s > 60 * dpr) || 100;
    ctx.strokeStyle = '#44516a'; ctx.lineWidth = 2 * dpr;
    ctx.beginPath(); ctx.moveTo(12 * dpr, h - 14 * dpr); ctx.lineTo(12 * dpr + bar * v.s, h - 14 * dpr); ctx.stroke();
    ctx.fillStyle = '#44516a'; ctx.font = 11 * dpr + 'px sans-serif';
    ctx.fillText(bar + ' m', 16 * dpr + bar * v.s, h - 10 * dpr);
    panel.topPx = [];
    panel.runs.forEach((ri, slot) => {
      const run = runs[ri];
      const k = frameOf(run, st.time);
      if (k < 0) return;
      const hollow = slot > 0;
      if (st.trail) {
        const pts = [];
        for (let i = 0; i <= k; i += 2) pts.push(isFinite(run.load[i][0]) ? T(run.load[i]) : null);
        ctx.strokeStyle = hollow ? 'rgba(60,60,60,0.35)' : 'rgba(30,30,30,0.55)'; ctx.lineWidth = 1.2 * dpr;
        line(ctx, pts);
      }
      const u = run.uav[k], l = run.load[k], ten = run.ten[k];
      const faults = faultsOf(run, st.time);
      const mode = run.mode[k] || '';
      const lq = isFinite(l[0]) ? T(l) : null;
      if (st.tray && run.node[k]) {
        const nq = [];
        for (let i = 0; i < run.n; i++) nq.push(isFinite(run.node[k][2 * i]) ? T([run.node[k][2 * i], run.node[k][2 * i + 1]]) : null);
        ctx.strokeStyle = 'rgba(120,70,170,0.35)'; ctx.lineWidth = dpr;
        ctx.beginPath();
        for (let i = 0; i < nq.length; i++) for (let j = i + 1; j < nq.length; j++) if (nq[i] && nq[j]) { ctx.moveTo(nq[i][0], nq[i][1]); ctx.lineTo(nq[j][0], nq[j][1]); }
        ctx.stroke();
        ctx.fillStyle = '#7846aa';
        for (const a of nq) if (a) ctx.fillRect(a[0] - 2.5 * dpr, a[1] - 2.5 * dpr, 5 * dpr, 5 * dpr);
      }
      const px = [];
      for (let i = 0; i < run.n; i++) {
        const q = isFinite(u[3 * i]) ? T([u[3 * i], u[3 * i + 1]]) : null;
        px.push(q);
        if (!q || !lq || faults[i]?.snap) continue;
        ctx.strokeStyle = ten[i] > SLACK_N ? tensionColor(ten[i], run.rated) : '#9aa0aa';
        ctx.lineWidth = 2.2 * dpr;
        if (hollow) ctx.setLineDash([7 * dpr, 4 * dpr]);
        ctx.beginPath(); ctx.moveTo(q[0], q[1]); ctx.lineTo(lq[0], lq[1]); ctx.stroke();
        ctx.setLineDash([]);
      }
      const rad = Math.max(4.5 * dpr, 0.3 * v.s);
      for (let i = 0; i < run.n; i++) {
        const q = px[i];
        if (!q) continue;
        ctx.beginPath(); ctx.arc(q[0], q[1], rad, 0, 2 * Math.PI);
        if (hollow) { ctx.fillStyle = 'rgba(255,255,255,0.55)'; ctx.fill(); ctx.strokeStyle = run.colors[i]; ctx.lineWidth = 3 * dpr; ctx.stroke(); }
        else { ctx.fillStyle = run.colors[i]; ctx.fill(); ctx.strokeStyle = '#1b2232'; ctx.lineWidth = 1.3 * dpr; ctx.stroke(); }
        if (mode[i] === '1' || faults[i]) {
          ctx.strokeStyle = faults[i]?.thrust_loss ? EVENT_STYLE.thrust_loss[0] : faults[i]?.silent ? EVENT_STYLE.silent[0] : faults[i]?.link_dead ? EVENT_STYLE.link_dead[0] : EVENT_STYLE.hold[0];
          ctx.lineWidth = 2.2 * dpr;
          ctx.beginPath(); ctx.arc(q[0], q[1], rad + 3.5 * dpr, 0, 2 * Math.PI); ctx.stroke();
        }
      }
      if (lq) {
        const s = Math.max(4 * dpr, 0.25 * v.s);
        ctx.fillStyle = hollow ? 'rgba(255,255,255,0.6)' : '#1b1b1b'; ctx.strokeStyle = '#000'; ctx.lineWidth = (hollow ? 2.5 : 1) * dpr;
        ctx.fillRect(lq[0] - s, lq[1] - s, 2 * s, 2 * s); ctx.strokeRect(lq[0] - s, lq[1] - s, 2 * s, 2 * s);
      }
      panel.topPx[slot] = px;
    });
  }

  // ------------------------------------------------------------------ timeline
  const tl = document.getElementById('vt-timeline');
  function tlX(t) { return tEnd > 0 ? 8 + ((tl.width - 16) * t) / tEnd : 8; }
  function drawTimeline() {
    const dpr = window.devicePixelRatio || 1;
    tl.width = Math.max(1, Math.round(tl.clientWidth * dpr));
    tl.height = Math.round(64 * dpr);
    const ctx = tl.getContext('2d'), w = tl.width, h = tl.height;
    ctx.fillStyle = '#fbfcfe'; ctx.fillRect(0, 0, w, h);
    // Minimum UAV-boundary clearance of each run, 0 .. max, as a sparkline.
    const top = 6 * dpr, bot = h - 16 * dpr;
    runs.forEach((run, ri) => {
      let hi = 0;
      for (const c of run.clear) if (isFinite(c[0])) hi = Math.max(hi, c[0]);
      if (!(hi > 0)) return;
      // Hold periods shaded.
      ctx.fillStyle = 'rgba(255,159,28,0.25)';
      for (let k = 0; k < run.mode.length; k++) if (run.mode[k].indexOf('1') >= 0) ctx.fillRect(tlX(run.t[k]), top, Math.max(1, tlX(run.t[k + 1] || run.t[k]) - tlX(run.t[k])), bot - top);
      ctx.strokeStyle = ri === 0 ? '#1f5fa8' : '#c2571a';
      ctx.lineWidth = 1.2 * dpr;
      ctx.beginPath();
      let on = false;
      for (let k = 0; k < run.t.length; k++) {
        const c = run.clear[k][0];
        if (!isFinite(c)) { on = false; continue; }
        const x = tlX(run.t[k]), y = bot - ((bot - top) * Math.max(0, c)) / hi;
        if (on) ctx.lineTo(x, y); else ctx.moveTo(x, y);
        on = true;
      }
      ctx.stroke();
      for (const e of run.events) {
        const [col] = EVENT_STYLE[e.kind] || ['#000'];
        if (e.kind === 'hold' || e.kind === 'resume') continue;
        if (e.kind.startsWith('phase_')) {
          // Ground start: a thin line and the phase's name at each phase change.
          const x = tlX(e.time_s);
          ctx.fillStyle = '#5d6a80';
          ctx.fillRect(x - 0.5 * dpr, top, dpr, bot - top);
          ctx.font = 10 * dpr + 'px sans-serif';
          ctx.fillText(e.kind.slice(6), x + 2 * dpr, top + 10 * dpr);
          continue;
        }
        const x = tlX(e.time_s);
        ctx.fillStyle = col;
        ctx.beginPath(); ctx.moveTo(x, top); ctx.lineTo(x - 5 * dpr, top - 5 * dpr + 12 * dpr); ctx.lineTo(x + 5 * dpr, top + 7 * dpr); ctx.closePath(); ctx.fill();
        ctx.fillRect(x - 0.75 * dpr, top, 1.5 * dpr, bot - top);
      }
    });
    ctx.fillStyle = '#5d6a80'; ctx.font = 11 * dpr + 'px sans-serif';
    const step = [1, 2, 5, 10, 20, 50, 100].find((s) => (tEnd / s) < 16) || 200;
    for (let t = 0; t <= tEnd + 1e-9; t += step) {
      ctx.fillRect(tlX(t), bot, dpr, 3 * dpr);
      const label = t + ' s';
      // The last label is right-aligned on its tick when it would run off the canvas.
      const lx = tlX(t) + 2 * dpr + ctx.measureText(label).width > w ? tlX(t) - 2 * dpr - ctx.measureText(label).width : tlX(t) + 2 * dpr;
      ctx.fillText(label, lx, h - 3 * dpr);
    }
    ctx.fillText('min UAV-boundary distance; faults, hold and phases marked', w - 330 * dpr, 12 * dpr);
  }
  function drawCursor() {
    const ctx = tl.getContext('2d');
    const dpr = window.devicePixelRatio || 1;
    const x = tlX(st.time);
    ctx.fillStyle = '#1d2330';
    ctx.fillRect(x - dpr, 0, 2 * dpr, tl.height - 14 * dpr);
  }

  // ------------------------------------------------------------------ readouts
  const fmt = (x, d) => (isFinite(x) ? x.toFixed(d) : '-');
  function readouts() {
    let html = '';
    runs.forEach((run) => {
      const k = frameOf(run, st.time);
      html += '<h2>' + esc(run.name) + '</h2>';
      if (k < 0) { html += '<p>no samples recorded</p>'; return; }
      const c = run.clear[k], l = run.load[k], ten = run.ten[k];
      let tmax = 0, tsum = 0, tn = 0;
      for (const f of ten) if (isFinite(f)) { tmax = Math.max(tmax, f); tsum += f; tn++; }
      const mode = run.mode[k] || '';
      const held = [];
      for (let i = 0; i < mode.length; i++) if (mode[i] === '1') held.push(i);
      const faults = faultsOf(run, st.time);
      const flist = Object.keys(faults).map((i) => 'UAV ' + i + ': ' + Object.keys(faults[i]).map((x) => EVENT_STYLE[x][1]).join(', '));
      const row = (a, b, bad) => '<tr><td>' + a + '</td><td class="v' + (bad ? ' bad' : '') + '">' + b + '</td></tr>';
      html += '<table>' +
        row('time', fmt(run.t[k], 2) + ' s') +
        row('min UAV-boundary', fmt(c[0], 2) + ' m', c[0] < 0.4) +
        row('load-boundary', fmt(c[1], 2) + ' m', c[1] <= 0) +
        row('min UAV-UAV', fmt(c[2], 2) + ' m', c[2] < 0.4) +
        row('load altitude error', fmt(l[2] - run.altRef, 2) + ' m') +
        row('max / mean tension', fmt(tmax, 1) + ' / ' + fmt(tn ? tsum / tn : NaN, 1) + ' N', tmax >= run.rated) +
        row('rated capacity', fmt(run.rated, 0) + ' N') +
        row('mode', run.mode.length ? (held.length ? 'hold (UAV ' + held.join(', ') + ')' : 'transport') : '-', held.length > 0) +
        '</table>';
      if (flist.length) html += '<p class="bad">' + flist.map(esc).join('<br>') + '</p>';
      html += '<div class="bars" title="tension per UAV (full height = rated capacity)">';
      for (let i = 0; i < run.n; i++) {
        const f = ten[i];
        const hpx = Math.min(1, Math.max(0, f / run.rated)) * 100;
        html += '<div style="height:' + (isFinite(hpx) ? hpx : 0).toFixed(1) + '%;background:' + tensionColor(f, run.rated) + '"></div>';
      }
      html += '</div>';
    });
    document.getElementById('vt-readouts').innerHTML = html;
  }
  function esc(s) { return String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' })[c]); }
  function legend() {
    let html = '<h2>Legend</h2><div class="legend-row">cable tension: 0</div><div class="ramp"></div>' +
      '<div class="legend-row" style="justify-content:space-between"><span></span><span>rated capacity</span></div>';
    const sw = (col, label, extra) => '<div class="legend-row"><span class="sw" style="background:' + col + ';' + (extra || '') + '"></span>' + label + '</div>';
    html += sw('#9aa0aa', 'slack cable') + sw('#1b1b1b', 'load (trail behind)') + sw('rgba(120,160,230,0.35)', 'virtual tube', 'border:2px solid #283759') +
      sw('#afafaf', 'obstacle') + sw('#7846aa', 'tray nodes and springs (toggle)');
    for (const k of ['hold', 'snap', 'silent', 'thrust_loss', 'own_feed_stall', 'link_dead']) html += sw(EVENT_STYLE[k][0], EVENT_STYLE[k][1]);
    if (runs.length > 1) html += '<p>Overlaid: ' + esc(runs[0].name) + ' filled, ' + esc(runs[1].name) + ' as rings with dashed cables.</p>';
    document.getElementById('vt-legend').innerHTML = html;
  }

  // ------------------------------------------------------------------ render + state for tests
  const slider = document.getElementById('vt-slider');
  const timeEl = document.getElementById('vt-time');
  const stateEl = document.getElementById('vt-state');
  let lastReadout = -1;
  function render() {
    panels.forEach((p, pi) => { render3d(p); renderTop(p, pi); });
    drawTimeline();
    drawCursor();
    slider.value = String(tEnd > 0 ? Math.round((1000 * st.time) / tEnd) : 0);
    timeEl.textContent = 't = ' + st.time.toFixed(2) + ' s';
    const k0 = runs.length ? frameOf(runs[0], st.time) : -1;
    if (k0 !== lastReadout) { readouts(); lastReadout = k0; }
    publishState();
  }
  function publishState() {
    const dpr = window.devicePixelRatio || 1;
    const page = (c, q) => {
      if (!q) return null;
      const r = c.getBoundingClientRect();
      return [Math.round((r.left + q[0] / dpr) * 10) / 10, Math.round((r.top + q[1] / dpr) * 10) / 10];
    };
    const p0 = panels[0];
    const s = {
      frame: runs.map((r) => frameOf(r, st.time)),
      frames: runs.map((r) => r.t.length),
      time: Math.round(st.time * 1000) / 1000,
      playing: st.playing,
      ticks: ticks,
      errors: errors,
      background: BG,
      viewport: [window.innerWidth, window.innerHeight],
      colors: runs.map((r) => r.colors),
      uav_px: p0 ? runs.map((_, ri) => { const pp = panels.find((p) => p.runs.indexOf(ri) >= 0); const slot = pp ? pp.runs.indexOf(ri) : -1; return pp && pp.uavPx[slot] ? pp.uavPx[slot].map((q) => page(pp.c3, q)) : []; }) : [],
      top_px: p0 ? runs.map((_, ri) => { const pp = panels.find((p) => p.runs.indexOf(ri) >= 0); const slot = pp ? pp.runs.indexOf(ri) : -1; return pp && pp.topPx[slot] ? pp.topPx[slot].map((q) => page(pp.ct, q)) : []; }) : [],
    };
    stateEl.textContent = JSON.stringify(s);
  }

  // ------------------------------------------------------------------ controls and clock
  const playBtn = document.getElementById('vt-play');
  function setPlaying(p) { st.playing = p; playBtn.innerHTML = p ? '&#10074;&#10074;' : '&#9654;'; }
  playBtn.addEventListener('click', () => { if (!st.playing && st.time >= tEnd) st.time = 0; setPlaying(!st.playing); });
  const speedEl = document.getElementById('vt-speed');
  speedEl.value = String(st.speed);
  speedEl.addEventListener('change', () => { st.speed = parseFloat(speedEl.value) || 1; });
  slider.addEventListener('input', () => { st.time = (tEnd * parseFloat(slider.value)) / 1000; render(); });
  tl.addEventListener('pointerdown', (e) => {
    const r = tl.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
    st.time = Math.min(tEnd, Math.max(0, (((e.clientX - r.left) * dpr - 8) / (tl.width - 16)) * tEnd));
    render();
  });
  document.getElementById('vt-tray').checked = st.tray;
  document.getElementById('vt-tray').addEventListener('change', (e) => { st.tray = e.target.checked; render(); });
  document.getElementById('vt-follow').addEventListener('change', (e) => { st.follow = e.target.checked; render(); });
  document.getElementById('vt-trail').addEventListener('change', (e) => { st.trail = e.target.checked; render(); });
  document.getElementById('vt-reset').addEventListener('click', () => { st.cams = []; st.tops = []; buildPanels(); });
  const layoutEl = document.getElementById('vt-layout');
  layoutEl.value = st.layout;
  layoutEl.addEventListener('change', () => { st.layout = layoutEl.value; st.cams = []; st.tops = []; buildPanels(); });
  document.addEventListener('keydown', (e) => {
    if (e.target && e.target.tagName === 'SELECT') return;
    const dt = runs[0] && runs[0].t.length > 1 ? runs[0].t[1] - runs[0].t[0] : 0.05;
    if (e.key === ' ') { e.preventDefault(); playBtn.click(); }
    else if (e.key === 'ArrowRight') { st.time = Math.min(tEnd, st.time + dt); render(); }
    else if (e.key === 'ArrowLeft') { st.time = Math.max(0, st.time - dt); render(); }
  });
  window.addEventListener('resize', resize);

  /** Clock ticks so far (the test checks the animation advances). */
  let ticks = 0;
  let last = performance.now();
  const TICK_MS = 40;
  setInterval(() => {
    const now = performance.now();
    const dt = Math.min(0.25, (now - last) / 1000);
    last = now;
    if (!st.playing) return;
    ticks++;
    st.time += dt * st.speed;
    if (st.time >= tEnd) { st.time = tEnd; setPlaying(false); }
    render();
  }, TICK_MS);

  setPlaying(st.playing);
  legend();
  buildPanels();
})();
