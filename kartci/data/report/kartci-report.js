// kartci report figures: draws each scenario's figures (JSON in <script type="application/json">)
// with uPlot; the plane view (seen from above) is a small canvas of its own. Within a scenario
// the time figures share one cursor and one zoom, the cursor's moment is a dot on the plane view,
// and hovering the plane view moves the time cursor. Wheel: zoom; shift+drag: pan; drag: zoom
// to a range; double-click: reset. No network: everything is in the page.
(function () {
  "use strict";
  const PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
    "#17becf", "#bcbd22", "#7f7f7f"];
  const VIRIDIS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  const registry = { charts: [], planes: [] };
  window.kartciFigures = registry;

  function viridis(f) {
    const x = Math.min(1, Math.max(0, f)) * (VIRIDIS.length - 1);
    const i = Math.min(VIRIDIS.length - 2, Math.floor(x));
    const a = VIRIDIS[i], b = VIRIDIS[i + 1], r = x - i;
    return "rgb(" + a.map((v, k) => Math.round(v + (b[k] - v) * r)).join(",") + ")";
  }

  function nearestIndex(xs, x) {
    let lo = 0, hi = xs.length - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (xs[mid] < x) lo = mid; else hi = mid;
    }
    return Math.abs(xs[lo] - x) <= Math.abs(xs[hi] - x) ? lo : hi;
  }

  function nearest(ts, vs, t) {
    if (!ts || ts.length === 0 || t < ts[0] || t > ts[ts.length - 1]) return null;
    const i = nearestIndex(ts, t);
    return vs[i];
  }

  function style(role, i) {
    const colour = PALETTE[i % PALETTE.length];
    switch (role) {
      case "reference": return { stroke: "#888", width: 1.2, dash: [6, 4] };
      case "command": return { stroke: colour, width: 1, dash: [2, 3] };
      case "outline": return { stroke: "#222", width: 1 };
      case "shape": return { stroke: "#8b4513", width: 1, fill: "rgba(139,69,19,0.8)" };
      default: return { stroke: colour, width: 1.3 };
    }
  }

  // ---- uPlot figures (time or distance on x) ----
  function eventsPlugin(fig) {
    return {
      hooks: {
        draw: [u => {
          const ctx = u.ctx;
          ctx.save();
          ctx.lineWidth = 1.5 * devicePixelRatio;
          for (const y of fig.hlines) {
            const py = u.valToPos(y, "y", true);
            ctx.strokeStyle = "#b00020";
            ctx.setLineDash([5, 5]);
            ctx.beginPath();
            ctx.moveTo(u.bbox.left, py);
            ctx.lineTo(u.bbox.left + u.bbox.width, py);
            ctx.stroke();
          }
          ctx.strokeStyle = "rgba(220,0,0,0.8)";
          ctx.setLineDash([2, 3]);
          for (const ev of fig.events) {
            const x = fig.axis === "time" ? ev.t : ev.lap;
            if (x === null || x === undefined) continue;
            const px = u.valToPos(x, "x", true);
            if (px < u.bbox.left || px > u.bbox.left + u.bbox.width) continue;
            ctx.beginPath();
            ctx.moveTo(px, u.bbox.top);
            ctx.lineTo(px, u.bbox.top + u.bbox.height);
            ctx.stroke();
          }
          ctx.restore();
        }],
      },
    };
  }

  function zoomPan(group) {
    return {
      hooks: {
        ready: [u => {
          const over = u.over;
          over.addEventListener("wheel", e => {
            e.preventDefault();
            const x = u.posToVal(e.offsetX, "x");
            const { min, max } = u.scales.x;
            const k = e.deltaY < 0 ? 0.8 : 1.25;
            u.setScale("x", { min: x - (x - min) * k, max: x + (max - x) * k });
          }, { passive: false });
          over.addEventListener("mousedown", e => {
            if (!e.shiftKey) return;
            e.stopPropagation();
            e.preventDefault();
            const x0 = e.clientX, { min, max } = u.scales.x;
            const perPx = (max - min) / u.over.clientWidth;
            const move = m => u.setScale("x", { min: min - (m.clientX - x0) * perPx,
              max: max - (m.clientX - x0) * perPx });
            const up = () => {
              window.removeEventListener("mousemove", move);
              window.removeEventListener("mouseup", up);
            };
            window.addEventListener("mousemove", move);
            window.addEventListener("mouseup", up);
          }, true);
        }],
        setScale: [(u, key) => {
          if (key !== "x" || group.syncing) return;
          group.syncing = true;
          const { min, max } = u.scales.x;
          for (const other of group.charts) {
            if (other !== u) other.setScale("x", { min, max });
          }
          group.syncing = false;
        }],
      },
    };
  }

  function chart(box, fig, scenario, groups, planes) {
    const tables = fig.series.map(s => [s.x, s.y]);
    const data = tables.length === 1 ? tables[0] : uPlot.join(tables);
    const groupKey = scenario + "|" + fig.axis;
    const group = groups[groupKey] || (groups[groupKey] = { charts: [], syncing: false });
    const xName = { time: "t [s]", distance: "s [m]", commit: "commit" }[fig.axis];
    const tick = v => (fig.ticks && fig.ticks[v] !== undefined ? fig.ticks[v] : v);
    const series = [{ label: xName, value: (u, v) => (v === null ? "--" : tick(v)) }].concat(
      fig.series.map((s, i) => Object.assign({ label: s.label, spanGaps: true, points:
        { show: fig.axis === "commit" } }, style(s.role, i))));
    const hooks = { setCursor: [] };
    if (fig.axis === "time") {
      hooks.setCursor.push(u => {
        const i = u.cursor.idx;
        if (i === null || i === undefined) return;
        const t = u.data[0][i];
        for (const p of planes) p.setTime(t);
      });
    }
    const opts = {
      title: fig.title,
      width: Math.min(560, box.clientWidth || 560),
      height: 300,
      series,
      scales: { x: { time: false }, y: fig.log_y ? { distr: 3 } : {} },
      axes: [fig.axis === "commit"
        ? { label: fig.xlabel, values: (u, vals) => vals.map(v => (Number.isInteger(v) ? tick(v) : "")) }
        : { label: fig.xlabel }, { label: fig.ylabel, size: 60 }],
      cursor: { sync: { key: groupKey }, drag: { x: true, y: false } },
      legend: { live: true },
      hooks,
      plugins: [eventsPlugin(fig), zoomPan(group)],
    };
    const u = new uPlot(opts, data, box);
    group.charts.push(u);
    registry.charts.push({ scenario, key: fig.key, chart: u });
    return u;
  }

  // ---- the plane view ----
  function Plane(box, fig, scenario, groups) {
    this.fig = fig;
    this.scenario = scenario;
    this.groups = groups;
    this.t = null;
    this.byPath = false;
    const title = document.createElement("div");
    title.className = "ktitle";
    title.textContent = fig.title;
    box.appendChild(title);
    this.canvas = document.createElement("canvas");
    this.canvas.className = "kplane";
    this.cssW = 560; this.cssH = 420;
    this.canvas.width = this.cssW * devicePixelRatio;
    this.canvas.height = this.cssH * devicePixelRatio;
    this.canvas.style.width = this.cssW + "px";
    this.canvas.style.height = this.cssH + "px";
    box.appendChild(this.canvas);
    const bar = document.createElement("div");
    bar.className = "kinfo";
    this.info = document.createElement("span");
    const label = document.createElement("label");
    const toggle = document.createElement("input");
    toggle.type = "checkbox";
    toggle.addEventListener("change", () => { this.byPath = toggle.checked; this.draw(); });
    label.append(toggle, " one colour per path");
    bar.append(label, " ", this.info);
    box.appendChild(bar);
    const coloured = fig.series.filter(s => s.c);
    const cs = coloured.flatMap(s => s.c).filter(v => v !== null).sort((a, b) => a - b);
    // the colour scale fitted to the data (2nd to 98th percentile), not from 0
    this.cmin = cs.length ? cs[Math.floor(cs.length * 0.02)] : 0;
    this.cmax = cs.length ? cs[Math.ceil(cs.length * 0.98) - 1] : 1;
    if (this.cmax <= this.cmin) this.cmax = this.cmin + 1e-6;
    const xs = fig.series.flatMap(s => s.x), ys = fig.series.flatMap(s => s.y);
    this.home = { x0: Math.min(...xs), x1: Math.max(...xs), y0: Math.min(...ys),
      y1: Math.max(...ys) };
    this.reset();
    this.listen();
    this.draw();
  }

  Plane.prototype.reset = function () {
    const h = this.home, pad = 0.05;
    const w = (h.x1 - h.x0) || 1, hh = (h.y1 - h.y0) || 1;
    this.scale = Math.min(this.cssW * (1 - 2 * pad) / w, (this.cssH - 40) * (1 - 2 * pad) / hh);
    this.cx = (h.x0 + h.x1) / 2;
    this.cy = (h.y0 + h.y1) / 2;
  };

  Plane.prototype.toPx = function (x, y) {
    return [this.cssW / 2 + (x - this.cx) * this.scale,
      (this.cssH - 30) / 2 - (y - this.cy) * this.scale];
  };

  Plane.prototype.listen = function () {
    const c = this.canvas;
    c.addEventListener("wheel", e => {
      e.preventDefault();
      const k = e.deltaY < 0 ? 1.25 : 0.8;
      const wx = this.cx + (e.offsetX - this.cssW / 2) / this.scale;
      const wy = this.cy - (e.offsetY - (this.cssH - 30) / 2) / this.scale;
      this.scale *= k;
      this.cx = wx - (e.offsetX - this.cssW / 2) / this.scale;
      this.cy = wy + (e.offsetY - (this.cssH - 30) / 2) / this.scale;
      this.draw();
    }, { passive: false });
    c.addEventListener("mousedown", e => {
      const x0 = e.clientX, y0 = e.clientY, cx = this.cx, cy = this.cy;
      const move = m => {
        this.cx = cx - (m.clientX - x0) / this.scale;
        this.cy = cy + (m.clientY - y0) / this.scale;
        this.draw();
      };
      const up = () => {
        window.removeEventListener("mousemove", move);
        window.removeEventListener("mouseup", up);
      };
      window.addEventListener("mousemove", move);
      window.addEventListener("mouseup", up);
    });
    c.addEventListener("dblclick", () => { this.reset(); this.draw(); });
    c.addEventListener("mousemove", e => this.hover(e.offsetX, e.offsetY));
  };

  Plane.prototype.hover = function (px, py) {
    let best = null;
    for (const s of this.fig.series) {
      if (!s.t) continue;
      for (let i = 0; i < s.x.length; i++) {
        const [qx, qy] = this.toPx(s.x[i], s.y[i]);
        const d = (qx - px) ** 2 + (qy - py) ** 2;
        if (d < 400 && (!best || d < best.d)) best = { d, s, i };
      }
    }
    if (!best) return;
    const t = best.s.t[best.i];
    this.setTime(t);
    const group = this.groups[this.scenario + "|time"];
    if (group) {
      for (const u of group.charts) {
        u.setCursor({ left: u.valToPos(t, "x"), top: u.cursor.top > 0 ? u.cursor.top : 10 });
      }
    }
  };

  Plane.prototype.setTime = function (t) {
    this.t = t;
    const parts = [];
    for (const s of this.fig.series) {
      if (!s.c || !s.t) continue;
      const v = nearest(s.t, s.c, t);
      if (v !== null) parts.push(s.label + ": " + v.toFixed(2) + " m/s");
    }
    this.info.textContent = "t = " + t.toFixed(2) + " s  " + parts.join("  ");
    this.draw();
  };

  Plane.prototype.draw = function () {
    const ctx = this.canvas.getContext("2d");
    ctx.setTransform(devicePixelRatio, 0, 0, devicePixelRatio, 0, 0);
    ctx.clearRect(0, 0, this.cssW, this.cssH);
    this.fig.series.forEach((s, i) => this.drawSeries(ctx, s, i));
    ctx.lineWidth = 2;
    ctx.strokeStyle = "#d00";
    for (const ev of this.fig.events) {
      if (ev.x === null || ev.y === null) continue;
      const [px, py] = this.toPx(ev.x, ev.y);
      ctx.beginPath();
      ctx.moveTo(px - 5, py - 5); ctx.lineTo(px + 5, py + 5);
      ctx.moveTo(px - 5, py + 5); ctx.lineTo(px + 5, py - 5);
      ctx.stroke();
    }
    if (this.t !== null) this.drawCursor(ctx);
    this.drawScale(ctx);
  };

  Plane.prototype.drawSeries = function (ctx, s, i) {
    const st = style(s.role, i);
    ctx.setLineDash(st.dash || []);
    ctx.lineWidth = st.width;
    if (s.c && !this.byPath) {
      ctx.lineWidth = 2.5;
      for (let k = 1; k < s.x.length; k++) {
        ctx.strokeStyle = viridis((s.c[k] - this.cmin) / (this.cmax - this.cmin));
        ctx.beginPath();
        ctx.moveTo(...this.toPx(s.x[k - 1], s.y[k - 1]));
        ctx.lineTo(...this.toPx(s.x[k], s.y[k]));
        ctx.stroke();
      }
      return;
    }
    ctx.strokeStyle = st.stroke;
    ctx.beginPath();
    s.x.forEach((x, k) => {
      const [px, py] = this.toPx(x, s.y[k]);
      if (k === 0) ctx.moveTo(px, py); else ctx.lineTo(px, py);
    });
    if (st.fill) { ctx.fillStyle = st.fill; ctx.fill(); }
    ctx.stroke();
    ctx.setLineDash([]);
  };

  Plane.prototype.drawCursor = function (ctx) {
    ctx.setLineDash([]);
    for (const s of this.fig.series) {
      if (!s.t) continue;
      const x = nearest(s.t, s.x, this.t), y = nearest(s.t, s.y, this.t);
      if (x === null) continue;
      const [px, py] = this.toPx(x, y);
      ctx.fillStyle = s.role === "reference" ? "#888" : "#d00";
      ctx.beginPath();
      ctx.arc(px, py, 5, 0, 2 * Math.PI);
      ctx.fill();
    }
  };

  Plane.prototype.drawScale = function (ctx) {
    if (!this.fig.series.some(s => s.c) || this.byPath) return;
    const y = this.cssH - 22, x0 = 60, w = 200;
    for (let k = 0; k < w; k++) {
      ctx.fillStyle = viridis(k / w);
      ctx.fillRect(x0 + k, y, 1, 10);
    }
    ctx.fillStyle = "#222";
    ctx.font = "11px sans-serif";
    ctx.fillText(this.cmin.toFixed(2), x0 - 38, y + 9);
    ctx.fillText(this.cmax.toFixed(2) + " " + this.fig.colour_label, x0 + w + 4, y + 9);
  };

  function build(container) {
    const doc = JSON.parse(container.querySelector("script").textContent);
    const scenario = container.dataset.scenario;
    const groups = {}, planes = [];
    for (const fig of doc.figures) {
      const box = document.createElement("div");
      box.className = "kfig";
      box.dataset.key = fig.key;
      container.appendChild(box);
      if (fig.axis === "plane") {
        const p = new Plane(box, fig, scenario, groups);
        planes.push(p);
        registry.planes.push({ scenario, key: fig.key, plane: p });
      } else {
        chart(box, fig, scenario, groups, planes);
      }
    }
  }

  document.querySelectorAll(".kfigs").forEach(build);
})();
