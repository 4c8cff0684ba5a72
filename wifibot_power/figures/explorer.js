/* wbpower report: the interactive trace view and the sortable runs table.
 * Self-contained (no library, nothing fetched); its data is the JSON block #wb-data written
 * by wifibot_power/figures/explorer.py, whose docstring says what it holds and how precise
 * a selection's energy is. Mouse: wheel zooms at the pointer, drag selects, shift+drag (or
 * the middle button) pans, double-click shows the whole run; keys on the focused trace:
 * + - zoom, arrows pan, Escape clears the selection. The state is mirrored on the canvas's
 * data-* attributes (visible range, selection, its energy) for scripts and tests. */
(function () {
  "use strict";
  var source = document.getElementById("wb-data");
  var canvas = document.getElementById("wb-canvas");
  if (!source || !canvas) return;
  var doc = JSON.parse(source.textContent);
  var ctx = canvas.getContext("2d");
  var readout = document.getElementById("wb-readout");
  var picker = document.getElementById("wb-run");
  var M = { left: 62, right: 62, top: 12, bottom: 40 };
  var F32 = 1.2e-7; // float32's relative step: the column times' precision
  var cache = {};
  var state = { run: 0, x0: 0, x1: 1, sel: null, drag: null };

  function bytes(text) {
    var raw = atob(text), out = new Uint8Array(raw.length);
    for (var i = 0; i < raw.length; i++) out[i] = raw.charCodeAt(i);
    return out.buffer;
  }
  function levels(q) {
    var lo = new Uint16Array(bytes(q.lo)), hi = new Uint16Array(bytes(q.hi));
    var n = lo.length, L = new Float64Array(n), H = new Float64Array(n);
    for (var i = 0; i < n; i++) { L[i] = q.v0 + lo[i] * q.dv; H[i] = q.v0 + hi[i] * q.dv; }
    return { lo: L, hi: H, dv: q.dv };
  }
  function run(k) {
    if (cache[k]) return cache[k];
    var r = doc.runs[k], t = new Float32Array(bytes(r.t)), e = new Float32Array(bytes(r.e));
    var cum = new Float64Array(e.length + 1);
    for (var i = 0; i < e.length; i++) cum[i + 1] = cum[i] + e[i];
    cache[k] = { meta: r, t: t, cum: cum, p: levels(r.p), v: r.v ? levels(r.v) : null };
    return cache[k];
  }
  function n(R) { return R.t.length - 1; }
  function start(R) { return R.t[0]; }
  function end(R) { return R.t[n(R)]; }
  // the column holding time x: t[k] <= x < t[k+1], clamped to the run
  function column(R, x) {
    var lo = 0, hi = n(R);
    if (x <= R.t[0]) return 0;
    if (x >= R.t[hi]) return hi - 1;
    while (hi - lo > 1) { var mid = (lo + hi) >> 1; if (R.t[mid] <= x) lo = mid; else hi = mid; }
    return lo;
  }
  // the energy from the run's start to x [J], and the bound of its interpolation [J]
  function energyAt(R, x) {
    if (x <= start(R)) return [0, 0];
    if (x >= end(R)) return [R.cum[n(R)], 0];
    var k = column(R, x), w = R.t[k + 1] - R.t[k], f = w > 0 ? (x - R.t[k]) / w : 0;
    var span = R.p.hi[k] - R.p.lo[k] + 2 * R.p.dv;
    var peak = Math.max(Math.abs(R.p.hi[k]), Math.abs(R.p.lo[k]));
    var bound = Math.min(f, 1 - f) * w * span + 2 * Math.abs(x) * F32 * peak;
    return [R.cum[k] + f * (R.cum[k + 1] - R.cum[k]), bound];
  }
  function fmt(x, digits) {
    if (!isFinite(x)) return "-";
    var a = Math.abs(x);
    if (a !== 0 && (a >= 1e6 || a < 1e-3)) return x.toExponential(digits - 1);
    return x.toPrecision(digits).replace(/\.?0+$/, function (m) { return m.indexOf(".") >= 0 ? "" : m; });
  }
  function fixed(x, places) { return isFinite(x) ? x.toFixed(places) : "-"; }
  function niceStep(span, count) {
    var raw = span / Math.max(count, 1), mag = Math.pow(10, Math.floor(Math.log10(raw)));
    var r = raw / mag;
    return (r < 1.5 ? 1 : r < 3.5 ? 2 : r < 7.5 ? 5 : 10) * mag;
  }
  function ticks(a, b, count) {
    var step = niceStep(b - a, count), out = [];
    for (var v = Math.ceil(a / step) * step; v <= b + step * 1e-9; v += step) out.push(v);
    return { values: out, step: step };
  }
  function tickText(v, step) {
    var places = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
    return v.toFixed(Math.min(places, 6));
  }

  function size() {
    var ratio = window.devicePixelRatio || 1, w = canvas.clientWidth, h = canvas.clientHeight;
    canvas.width = Math.round(w * ratio);
    canvas.height = Math.round(h * ratio);
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    return { w: w, h: h };
  }
  function frame() {
    var w = canvas.clientWidth, h = canvas.clientHeight;
    return { x: M.left, y: M.top, w: Math.max(10, w - M.left - M.right), h: Math.max(10, h - M.top - M.bottom) };
  }
  function X(P, t) { return P.x + (t - state.x0) / (state.x1 - state.x0) * P.w; }
  function T(P, px) { return state.x0 + (px - P.x) / P.w * (state.x1 - state.x0); }

  function draw() {
    var R = run(state.run), S = size(), P = frame(), i, k;
    var k0 = column(R, state.x0), k1 = column(R, state.x1);
    var ymin = Infinity, ymax = -Infinity;
    for (k = k0; k <= k1; k++) { ymin = Math.min(ymin, R.p.lo[k]); ymax = Math.max(ymax, R.p.hi[k]); }
    if (!isFinite(ymin)) { ymin = 0; ymax = 1; }
    var pad = 0.06 * ((ymax - ymin) || Math.abs(ymax) || 1);
    ymin -= pad; ymax += pad;
    var Y = function (p) { return P.y + (ymax - p) / (ymax - ymin) * P.h; };
    ctx.clearRect(0, 0, S.w, S.h);
    ctx.save();
    ctx.beginPath(); ctx.rect(P.x, P.y, P.w, P.h); ctx.clip();
    // phases: a shaded span each, its mean power a thin line
    var levelsSeen = 0;
    R.meta.phases.forEach(function (ph) {
      var alpha = 0.28;
      if (ph[0] === "level") { alpha = levelsSeen % 2 ? 0.36 : 0.18; levelsSeen++; }
      ctx.globalAlpha = alpha;
      ctx.fillStyle = doc.colours[ph[0]] || "#dddddd";
      ctx.fillRect(X(P, ph[2]), P.y, X(P, ph[3]) - X(P, ph[2]), P.h);
      ctx.globalAlpha = 0.8;
      if (ph[4] !== null) {
        ctx.fillStyle = "#444444";
        ctx.fillRect(X(P, ph[2]), Y(ph[4]), X(P, ph[3]) - X(P, ph[2]), 1);
      }
    });
    ctx.globalAlpha = 1;
    // the power envelope: each column's min..max; columns sharing a pixel merge into one
    ctx.fillStyle = doc.colours.power;
    for (k = k0; k <= k1; k++) {
      var xa = X(P, R.t[k]), xb = X(P, R.t[k + 1]);
      var top = Y(R.p.hi[k]), bottom = Y(R.p.lo[k]);
      ctx.fillRect(xa, top, Math.max(1, xb - xa), Math.max(1, bottom - top));
    }
    // start-up spikes: a triangle at each peak
    ctx.fillStyle = "#d62728";
    R.meta.spikes.forEach(function (s) {
      if (s[0] === null || s[1] === null) return;
      var x = X(P, s[0]), y = Y(s[1]);
      ctx.beginPath(); ctx.moveTo(x - 5, y - 9); ctx.lineTo(x + 5, y - 9); ctx.lineTo(x, y - 1); ctx.fill();
    });
    // the speed on the right-hand axis
    var vmax = 0;
    if (R.v) {
      for (k = k0; k <= k1; k++) vmax = Math.max(vmax, R.v.hi[k]);
      vmax = vmax * 1.08 || 1;
      ctx.strokeStyle = doc.colours.speed; ctx.lineWidth = 1.2; ctx.beginPath();
      for (k = k0; k <= k1; k++) {
        var vy = P.y + (1 - (R.v.lo[k] + R.v.hi[k]) / 2 / vmax) * P.h;
        if (k === k0) ctx.moveTo(X(P, R.t[k]), vy); else ctx.lineTo(X(P, R.t[k]), vy);
      }
      ctx.stroke();
    }
    // the selection
    if (state.sel) {
      var sa = X(P, state.sel[0]), sb = X(P, state.sel[1]);
      ctx.fillStyle = "rgba(0, 114, 178, 0.18)";
      ctx.fillRect(sa, P.y, sb - sa, P.h);
      ctx.fillStyle = "#0072b2";
      ctx.fillRect(sa, P.y, 1.5, P.h); ctx.fillRect(sb - 1.5, P.y, 1.5, P.h);
    }
    ctx.restore();
    // axes, ticks and labels
    ctx.strokeStyle = "#888888"; ctx.lineWidth = 1;
    ctx.strokeRect(P.x + 0.5, P.y + 0.5, P.w, P.h);
    ctx.fillStyle = "#222222"; ctx.font = "12px sans-serif";
    var tx = ticks(state.x0, state.x1, Math.max(2, Math.floor(P.w / 90)));
    ctx.textAlign = "center"; ctx.textBaseline = "top";
    tx.values.forEach(function (v) {
      var x = X(P, v);
      ctx.fillRect(x, P.y + P.h, 1, 4);
      ctx.fillText(tickText(v, tx.step), x, P.y + P.h + 6);
    });
    ctx.fillText("time [s]", P.x + P.w / 2, P.y + P.h + 22);
    var ty = ticks(ymin, ymax, Math.max(2, Math.floor(P.h / 45)));
    ctx.textAlign = "right"; ctx.textBaseline = "middle";
    ty.values.forEach(function (v) {
      var y = Y(v);
      ctx.fillRect(P.x - 4, y, 4, 1);
      ctx.fillText(tickText(v, ty.step), P.x - 6, y);
    });
    ctx.save(); ctx.translate(14, P.y + P.h / 2); ctx.rotate(-Math.PI / 2);
    ctx.textAlign = "center"; ctx.fillText("power [W]", 0, 0); ctx.restore();
    if (R.v) {
      var tv = ticks(0, vmax, Math.max(2, Math.floor(P.h / 45)));
      ctx.fillStyle = doc.colours.speed; ctx.textAlign = "left";
      tv.values.forEach(function (v) {
        var y = P.y + (1 - v / vmax) * P.h;
        ctx.fillRect(P.x + P.w, y, 4, 1);
        ctx.fillText(tickText(v, tv.step), P.x + P.w + 6, y);
      });
      ctx.save(); ctx.translate(S.w - 10, P.y + P.h / 2); ctx.rotate(-Math.PI / 2);
      ctx.textAlign = "center"; ctx.fillText("speed [m/s]", 0, 0); ctx.restore();
    }
    report(R);
  }

  function report(R) {
    var d = canvas.dataset;
    d.run = R.meta.id; d.x0 = state.x0; d.x1 = state.x1;
    var view = "showing " + fixed(state.x0, 3) + " to " + fixed(state.x1, 3) + " s of " +
      fixed(start(R), 3) + " to " + fixed(end(R), 3) + " s";
    if (!state.sel) {
      delete d.selT0; delete d.selT1; delete d.selEnergyJ; delete d.selBoundJ;
      readout.textContent = view + ". Drag across the trace to select a span: its duration, energy and mean power show here.";
      return;
    }
    var a = energyAt(R, state.sel[0]), b = energyAt(R, state.sel[1]);
    var duration = state.sel[1] - state.sel[0], energy = b[0] - a[0], bound = a[1] + b[1];
    d.selT0 = state.sel[0]; d.selT1 = state.sel[1]; d.selEnergyJ = energy; d.selBoundJ = bound;
    readout.textContent = "selection " + fixed(state.sel[0], 4) + " to " + fixed(state.sel[1], 4) +
      " s: duration " + fmt(duration, 5) + " s, energy " + fmt(energy, 6) + " J (± " +
      fmt(bound, 2) + " J), mean power " + (duration > 0 ? fmt(energy / duration, 5) : "-") +
      " W. " + view + ".";
  }

  function clampView(x0, x1) {
    var R = run(state.run), lo = start(R), hi = end(R), whole = hi - lo;
    var least = Math.min(whole, 8 * whole / n(R)); // no closer than 8 columns: nothing finer to show
    var span = Math.max(least, Math.min(whole, x1 - x0));
    var mid = (x0 + x1) / 2;
    x0 = Math.max(lo, Math.min(hi - span, mid - span / 2));
    state.x0 = x0; state.x1 = x0 + span;
  }
  function zoom(factor, at) {
    if (at === undefined) at = (state.x0 + state.x1) / 2;
    var x0 = at - (at - state.x0) * factor, x1 = at + (state.x1 - at) * factor;
    var R = run(state.run), whole = end(R) - start(R);
    var least = Math.min(whole, 8 * whole / n(R));
    var span = Math.max(least, Math.min(whole, x1 - x0));
    var f = (at - state.x0) / (state.x1 - state.x0);
    state.x0 = Math.max(start(R), Math.min(end(R) - span, at - f * span));
    state.x1 = state.x0 + span;
    draw();
  }
  function pan(fraction) {
    var span = state.x1 - state.x0;
    clampView(state.x0 + fraction * span, state.x1 + fraction * span);
    draw();
  }
  function whole() { var R = run(state.run); state.x0 = start(R); state.x1 = end(R); draw(); }
  function showRun(k) {
    state.run = k; state.sel = null;
    var R = run(k); state.x0 = start(R); state.x1 = end(R);
    if (picker) picker.value = String(k);
    var tables = document.querySelectorAll(".wb-run-phases");
    for (var i = 0; i < tables.length; i++) tables[i].hidden = tables[i].getAttribute("data-run") !== String(k);
    draw();
  }

  function pointer(event) { var r = canvas.getBoundingClientRect(); return event.clientX - r.left; }
  canvas.addEventListener("wheel", function (event) {
    event.preventDefault();
    var factor = Math.exp(Math.max(-1, Math.min(1, event.deltaY / 300)));
    zoom(factor, T(frame(), pointer(event)));
  }, { passive: false });
  canvas.addEventListener("mousedown", function (event) {
    var px = pointer(event), P = frame();
    var panning = event.shiftKey || event.button === 1;
    state.drag = { from: px, t: T(P, px), x0: state.x0, x1: state.x1, pan: panning, moved: false };
    event.preventDefault();
  });
  window.addEventListener("mousemove", function (event) {
    var g = state.drag;
    if (!g) return;
    var px = pointer(event), P = frame();
    if (Math.abs(px - g.from) > 2) g.moved = true;
    if (!g.moved) return;
    if (g.pan) {
      var shift = (px - g.from) / P.w * (g.x1 - g.x0);
      clampView(g.x0 - shift, g.x1 - shift);
    } else {
      var R = run(state.run), t = Math.max(start(R), Math.min(end(R), T(P, px)));
      var t0 = Math.max(start(R), Math.min(end(R), g.t));
      state.sel = [Math.min(t0, t), Math.max(t0, t)];
    }
    draw();
  });
  window.addEventListener("mouseup", function () {
    var g = state.drag;
    state.drag = null;
    if (g && !g.moved && !g.pan) { state.sel = null; draw(); }
  });
  canvas.addEventListener("dblclick", whole);
  canvas.addEventListener("keydown", function (event) {
    var keys = { "+": function () { zoom(1 / 1.5); }, "=": function () { zoom(1 / 1.5); },
      "-": function () { zoom(1.5); }, ArrowLeft: function () { pan(-0.25); },
      ArrowRight: function () { pan(0.25); }, Escape: function () { state.sel = null; draw(); } };
    if (keys[event.key]) { keys[event.key](); event.preventDefault(); }
  });
  function button(id, action) { var b = document.getElementById(id); if (b) b.addEventListener("click", action); }
  button("wb-zoom-in", function () { zoom(1 / 2); });
  button("wb-zoom-out", function () { zoom(2); });
  button("wb-left", function () { pan(-0.5); });
  button("wb-right", function () { pan(0.5); });
  button("wb-whole", whole);
  button("wb-zoom-sel", function () { if (state.sel) { clampView(state.sel[0], state.sel[1]); draw(); } });
  if (picker) picker.addEventListener("change", function () { showRun(Number(picker.value)); });
  window.addEventListener("resize", draw);

  // the runs table: a click on a heading sorts by it (again: the other way); a run's name
  // shows it in the trace view
  var table = document.getElementById("wb-runs");
  if (table) {
    var heads = table.tHead.rows[0].cells;
    Array.prototype.forEach.call(heads, function (th, col) {
      th.addEventListener("click", function () {
        var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
        var up = th.getAttribute("aria-sort") !== "ascending";
        var numeric = th.getAttribute("data-type") === "number";
        rows.sort(function (a, b) {
          var x = a.cells[col].getAttribute("data-v"), y = b.cells[col].getAttribute("data-v");
          if (numeric) {
            x = x === "" ? NaN : Number(x); y = y === "" ? NaN : Number(y);
            if (isNaN(x) || isNaN(y)) return isNaN(x) - isNaN(y); // blanks last either way
            return up ? x - y : y - x;
          }
          return up ? x.localeCompare(y) : y.localeCompare(x);
        });
        rows.forEach(function (r) { body.appendChild(r); });
        Array.prototype.forEach.call(heads, function (h) { h.removeAttribute("aria-sort"); });
        th.setAttribute("aria-sort", up ? "ascending" : "descending");
      });
    });
    table.addEventListener("click", function (event) {
      var link = event.target.closest("a[data-run]");
      if (!link) return;
      event.preventDefault();
      showRun(Number(link.getAttribute("data-run")));
      document.getElementById("explore").scrollIntoView();
    });
  }
  showRun(doc.first || 0);
  // when the view was ready [ms after navigation]: what opening the page costs
  document.body.setAttribute("data-explorer-ms", String(Math.round(performance.now())));
  document.body.setAttribute("data-explorer", "ready");
})();
