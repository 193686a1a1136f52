// bellyflop's viewer: plain JavaScript and SVG, no library, no network.
// The data is the JSON of the script element #bellyflop-data (built by
// bellyflop::output::viewer). window.viewer exposes the state the browser
// test reads: the time, the trajectory there, and the scene's transform.
(function () {
  'use strict';
  var NS = 'http://www.w3.org/2000/svg';
  var DEG = 180 / Math.PI;
  var CHART_COLUMNS = 3; // .charts in viewer.css

  function el(tag, attrs, parent, text) {
    var e = document.createElementNS(NS, tag);
    for (var k in attrs) { e.setAttribute(k, attrs[k]); }
    if (text !== undefined) { e.textContent = text; }
    if (parent) { parent.appendChild(e); }
    return e;
  }

  function html(tag, attrs, parent, text) {
    var e = document.createElement(tag);
    for (var k in attrs) { e.setAttribute(k, attrs[k]); }
    if (text !== undefined) { e.textContent = text; }
    if (parent) { parent.appendChild(e); }
    return e;
  }

  function fmt(v, digits) {
    if (v === null || v === undefined || !isFinite(v)) { return '-'; }
    return Number(v).toFixed(digits === undefined ? 3 : digits);
  }

  // Linear interpolation of column ys over the sorted times ts, clamped.
  function at(ts, ys, t) {
    var n = ts.length;
    if (t <= ts[0]) { return ys[0]; }
    if (t >= ts[n - 1]) { return ys[n - 1]; }
    var lo = 0, hi = n - 1;
    while (hi - lo > 1) {
      var mid = (lo + hi) >> 1;
      if (ts[mid] <= t) { lo = mid; } else { hi = mid; }
    }
    var w = ts[hi] > ts[lo] ? (t - ts[lo]) / (ts[hi] - ts[lo]) : 1;
    return ys[lo] + w * (ys[hi] - ys[lo]);
  }

  function extent(arrays) {
    var lo = Infinity, hi = -Infinity;
    arrays.forEach(function (a) {
      (a || []).forEach(function (v) {
        if (v !== null && isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
      });
    });
    if (!isFinite(lo)) { return [0, 1]; }
    if (hi - lo < 1e-9 * Math.max(1, Math.abs(hi))) { lo -= 1; hi += 1; }
    return [lo, hi];
  }

  function points(xs, ys, fx, fy) {
    var p = [];
    for (var i = 0; i < xs.length; i++) {
      if (ys[i] !== null && isFinite(ys[i])) { p.push(fx(xs[i]).toFixed(2) + ',' + fy(ys[i]).toFixed(2)); }
    }
    return p.join(' ');
  }

  // ---- the scene: x–z to scale --------------------------------------------

  // A scene of width w px that holds every path given (each {x, z}) and the
  // pad, to one scale in x and z: world (x, z) -> (ox + s x, oy - s z).
  function Scene(parent, paths, vehicle, w) {
    var xs = [0], zs = [0];
    paths.forEach(function (p) { xs = xs.concat(p.x); zs = zs.concat(p.z); });
    var margin = vehicle.length_m * 0.7;
    var bx = extent([xs]), bz = extent([zs]);
    bx = [bx[0] - margin, bx[1] + margin];
    bz = [Math.min(bz[0], 0) - 0.15 * margin, bz[1] + margin];
    var s = (w - 20) / Math.max(bx[1] - bx[0], (bz[1] - bz[0]) * 0.8);
    var h = Math.round((bz[1] - bz[0]) * s + 20);
    this.s = s;
    this.ox = 10 - s * bx[0];
    this.oy = 10 + s * bz[1];
    this.vehicle = vehicle;
    this.svg = el('svg', { width: w, height: h, class: 'scene', id: 'scene',
      'data-scale': s, 'data-ox': this.ox, 'data-oy': this.oy }, parent);
    this.drawGround(bx);
  }

  Scene.prototype.X = function (x) { return this.ox + this.s * x; };
  Scene.prototype.Y = function (z) { return this.oy - this.s * z; };

  Scene.prototype.drawGround = function (bx) {
    var padHalf = 15;
    el('line', { class: 'ground', x1: this.X(bx[0]), x2: this.X(bx[1]), y1: this.oy, y2: this.oy }, this.svg);
    el('rect', { class: 'pad', id: 'pad', x: this.X(-padHalf), y: this.oy, width: 2 * padHalf * this.s,
      height: Math.max(3, 0.06 * this.vehicle.length_m * this.s) }, this.svg);
    el('text', { x: this.X(0), y: this.oy + 14, 'text-anchor': 'middle' }, this.svg, 'pad (x = 0)');
  };

  Scene.prototype.path = function (cls, x, z) {
    var self = this;
    var xs = x.map(function (v) { return self.X(v); });
    return el('polyline', { class: cls, points: points(xs, z, function (v) { return v; },
      function (v) { return self.Y(v); }) }, this.svg);
  };

  // The operational limits (data.constraints): the approach cone's two
  // edges from the pad up to the scene's top, and a dashed line at each
  // trigger height above the pad, labelled.
  Scene.prototype.drawLimits = function (lim) {
    var w = Number(this.svg.getAttribute('width')), zTop = this.oy / this.s;
    var px = lim.pad_x_m, pz = lim.pad_z_m, self = this;
    if (lim.cone && zTop > pz) {
      [-1, 1].forEach(function (side) {
        el('line', { class: 'limit cone', 'data-side': side, x1: self.X(px), y1: self.Y(pz),
          x2: self.X(px + side * lim.cone.tan * (zTop - pz)), y2: self.Y(zTop) }, self.svg);
      });
    }
    [['tilt', 'start', 4], ['final_descent', 'end', w - 4]].forEach(function (k) {
      var o = lim[k[0]];
      if (!o) { return; }
      var y = self.Y(pz + o.below_m);
      el('line', { class: 'limit trigger', 'data-limit': k[0], x1: 0, x2: w, y1: y, y2: y }, self.svg);
      el('text', { class: 'limit-label', 'data-limit': k[0], x: k[2], y: y - 3, 'text-anchor': k[1] }, self.svg,
        limitText(k[0], o));
    });
  };

  // The vehicle in its own frame, in px: the centre of mass at the origin,
  // the nose up (−y); the group is turned by −θ, the nozzle by −δ.
  Scene.prototype.drawVehicle = function () {
    var v = this.vehicle, s = this.s;
    var r = v.radius_m * s, top = (v.length_m - v.cg_m) * s, bottom = v.cg_m * s;
    var cap = Math.min(2 * v.radius_m, 0.3 * v.length_m) * s;
    var g = el('g', { id: 'vehicle' }, this.svg);
    this.nozzle = el('g', { id: 'nozzle' }, g);
    this.plume = el('polygon', { class: 'plume', id: 'plume' }, this.nozzle);
    el('polygon', { class: 'nozzle', points: [[-0.35 * r, 0], [0.35 * r, 0], [0.6 * r, 0.5 * r],
      [-0.6 * r, 0.5 * r]].join(' ') }, this.nozzle);
    el('rect', { class: 'body', id: 'body', x: -r, y: -(top - cap), width: 2 * r, height: top - cap + bottom }, g);
    el('polygon', { class: 'nose', id: 'nose', points: [[-r, -(top - cap)], [0, -top], [r, -(top - cap)]].join(' ') }, g);
    this.tip = el('circle', { id: 'nose-tip', cx: 0, cy: -top, r: 0.01 }, g);
    this.g = g;
    this.bottom = bottom;
    this.r = r;
  };

  // Pose the vehicle: centre of mass at (x, z), pitch θ, nozzle δ, thrust T.
  Scene.prototype.pose = function (x, z, theta, delta, thrust) {
    var v = this.vehicle;
    // A trajectory with no number here (a failed integration): no vehicle
    // rather than an invalid transform.
    var finite = [x, z, theta, delta].every(isFinite);
    this.g.setAttribute('visibility', finite ? 'visible' : 'hidden');
    if (!finite) { return; }
    if (!isFinite(thrust)) { thrust = 0; }
    this.g.setAttribute('transform', 'translate(' + this.X(x) + ',' + this.Y(z) + ') rotate(' + (-theta * DEG) + ')');
    this.nozzle.setAttribute('transform', 'translate(0,' + this.bottom + ') rotate(' + (-delta * DEG) + ')');
    var len = 0.6 * v.length_m * this.s * Math.max(0, thrust / v.max_thrust_n);
    var r = this.r;
    this.plume.setAttribute('points', [[-0.55 * r, 0.5 * r], [0.55 * r, 0.5 * r], [0, 0.5 * r + len]].join(' '));
  };

  // ---- time-history charts ------------------------------------------------

  function Chart(parent, spec, t0, t1) {
    var w = 272, h = 128, l = 50, r = 14, top = 18, b = 20;
    this.spec = spec;
    this.svg = el('svg', { width: w, height: h, class: 'chart', 'data-key': spec.key }, parent);
    var arrays = spec.series.map(function (s) { return s.y; });
    (spec.bounds || []).forEach(function (bd) { arrays.push([bd.value]); });
    // An operational limit: ±its bound below any trigger (its least value).
    if (spec.limit) {
      var least = extent([spec.limit.bound])[0];
      arrays.push([least, -least]);
    }
    if (spec.nodes) { arrays.push(spec.nodes.y); }
    if (spec.zero) { arrays.push([0]); }
    var ey = extent(arrays), pad = 0.06 * (ey[1] - ey[0]);
    ey = [ey[0] - pad, ey[1] + pad];
    this.fx = function (t) { return l + (w - l - r) * (t - t0) / (t1 - t0 || 1); };
    this.fy = function (y) { return top + (h - top - b) * (ey[1] - y) / (ey[1] - ey[0]); };
    this.h = h; this.top = top; this.b = b;
    this.frame(spec, t0, t1, ey, w, l);
  }

  Chart.prototype.frame = function (spec, t0, t1, ey, w, l) {
    var self = this, h = this.h, b = this.b;
    (spec.bands || []).forEach(function (bd, i) {
      if (i % 2 === 1) {
        el('rect', { class: 'band', x: self.fx(bd[0]), y: self.top, width: self.fx(bd[1]) - self.fx(bd[0]),
          height: h - self.top - b }, self.svg);
      }
    });
    (spec.shades || []).forEach(function (sh) {
      el('rect', { class: sh.cls, x: self.fx(sh.t0), y: self.top, width: Math.max(0, self.fx(sh.t1) - self.fx(sh.t0)),
        height: h - self.top - b }, self.svg).appendChild(el('title', {}, null, sh.title));
    });
    if (spec.zero) { el('line', { class: 'zero', x1: l, x2: w - 14, y1: self.fy(0), y2: self.fy(0) }, this.svg); }
    el('line', { class: 'axis', x1: l, x2: l, y1: this.top, y2: h - b }, this.svg);
    el('line', { class: 'axis', x1: l, x2: w - 14, y1: h - b, y2: h - b }, this.svg);
    el('text', { class: 'title', x: l, y: 12 }, this.svg, spec.label);
    [ey[0], (ey[0] + ey[1]) / 2, ey[1]].forEach(function (v) {
      el('text', { x: l - 3, y: self.fy(v) + 3, 'text-anchor': 'end' }, self.svg, tick(v * (spec.scale || 1)));
    });
    [t0, (t0 + t1) / 2, t1].forEach(function (t) {
      el('text', { x: self.fx(t), y: h - 6, 'text-anchor': 'middle' }, self.svg, fmt(t, 1));
    });
    (spec.breaks || []).forEach(function (t) {
      el('line', { class: 'break', x1: self.fx(t), x2: self.fx(t), y1: self.top, y2: h - b }, self.svg);
    });
    (spec.marks || []).forEach(function (m) {
      el('line', { class: 'replan ' + m.cls, x1: self.fx(m.t), x2: self.fx(m.t), y1: h - b - 8, y2: h - b }, self.svg);
    });
    this.boundLines = (spec.bounds || []).map(function (bd) {
      return el('line', { class: 'bound', x1: l, x2: w - 14, y1: self.fy(bd.value), y2: self.fy(bd.value) }, self.svg);
    });
    if (spec.limit) { this.limitCurves(spec.limit, w, l); }
    spec.series.forEach(function (s) {
      el('polyline', { class: s.cls, points: points(s.t, s.y, self.fx, self.fy) }, self.svg);
    });
    if (spec.nodes) {
      spec.nodes.t.forEach(function (t, i) {
        el('circle', { class: 'node', cx: self.fx(t), cy: self.fy(spec.nodes.y[i]), r: 1.3 }, self.svg);
      });
    }
    this.cursor = el('line', { class: 'cursor', y1: this.top, y2: h - b }, this.svg);
  };

  // ±B(t) of an operational limit, clipped to the plot: a trigger's bound
  // leaves it upwards as the limit opens above its height.
  Chart.prototype.limitCurves = function (limit, w, l) {
    var self = this, id = 'clip-' + this.spec.key;
    var clip = el('clipPath', { id: id }, el('defs', {}, this.svg));
    el('rect', { x: l, y: this.top, width: w - 14 - l, height: this.h - this.top - this.b }, clip);
    [1, -1].forEach(function (sign) {
      var ys = limit.bound.map(function (v) { return v === null ? null : sign * v; });
      el('polyline', { class: 'limit', 'data-limit': limit.name, 'data-sign': sign, 'clip-path': 'url(#' + id + ')',
        points: points(limit.t, ys, self.fx, self.fy) }, self.svg);
    });
  };

  function tick(v) {
    var a = Math.abs(v);
    if (a >= 1e5) { return v.toExponential(2); }
    if (a >= 100) { return v.toFixed(0); }
    if (a >= 1) { return v.toFixed(1); }
    return v.toFixed(3);
  }

  // Move the cursor to t; light the bounds that are active there.
  Chart.prototype.update = function (t, active) {
    var x = this.fx(t);
    this.cursor.setAttribute('x1', x);
    this.cursor.setAttribute('x2', x);
    var any = false;
    (this.spec.bounds || []).forEach(function (bd, i) {
      var hot = active.indexOf(bd.name) >= 0;
      any = any || hot;
      this.boundLines[i].setAttribute('class', hot ? 'bound hot' : 'bound');
    }, this);
    this.svg.setAttribute('class', any ? 'chart active' : 'chart');
  };

  // ---- playback -----------------------------------------------------------

  function Player(parent, t0, t1, onTime) {
    var box = html('div', { class: 'controls' }, parent);
    var self = this;
    this.t0 = t0; this.t1 = t1; this.t = t0; this.onTime = onTime; this.playing = false;
    this.button = html('button', { id: 'play' }, box, 'play');
    this.slider = html('input', { id: 'slider', type: 'range', min: t0, max: t1, step: 'any', value: t0 }, box);
    this.speed = html('select', { id: 'speed' }, box);
    [0.25, 0.5, 1, 2, 5, 10].forEach(function (s) {
      var o = html('option', { value: s }, self.speed, s + '×');
      if (s === 1) { o.selected = true; }
    });
    this.label = html('span', { class: 'time', id: 'time' }, box);
    this.button.addEventListener('click', function () { self.toggle(); });
    this.slider.addEventListener('input', function () { self.pause(); self.set(Number(self.slider.value)); });
  }

  Player.prototype.set = function (t) {
    this.t = Math.min(this.t1, Math.max(this.t0, t));
    this.slider.value = this.t;
    this.label.textContent = 't = ' + fmt(this.t, 2) + ' s';
    this.onTime(this.t);
  };

  Player.prototype.toggle = function () { if (this.playing) { this.pause(); } else { this.play(); } };

  Player.prototype.play = function () {
    var self = this, last = null;
    if (this.t >= this.t1) { this.set(this.t0); }
    this.playing = true;
    this.button.textContent = 'pause';
    function frame(now) {
      if (!self.playing) { return; }
      if (last !== null) { self.set(self.t + (now - last) / 1000 * Number(self.speed.value)); }
      last = now;
      if (self.t >= self.t1) { self.pause(); return; }
      requestAnimationFrame(frame);
    }
    requestAnimationFrame(frame);
  };

  Player.prototype.pause = function () { this.playing = false; this.button.textContent = 'play'; };

  // ---- a solve ------------------------------------------------------------

  var STATES = [
    ['x_m', 'x [m]', 1], ['z_m', 'z [m]', 1], ['vx_mps', 'Vx [m/s]', 1], ['vz_mps', 'Vz [m/s]', 1],
    ['theta_rad', 'θ [deg]', DEG], ['pitch_rate_radps', 'w [deg/s]', DEG], ['mass_kg', 'm [kg]', 1],
    ['thrust_n', 'T [N]', 1], ['delta_rad', 'δ [deg]', DEG], ['gimbal_rate_radps', 'χ = dδ/dt [deg/s]', DEG]
  ];

  // Bounds of the problem on each column, named for the active list.
  function boundsOf(sc) {
    var v = sc.vehicle, d = v.max_gimbal_deg / DEG, c = v.max_gimbal_rate_degps / DEG;
    return {
      z_m: [{ name: 'ground z = 0', value: 0 }],
      mass_kg: [{ name: 'm = m_dry', value: v.dry_mass_kg }],
      thrust_n: [{ name: 'T = T_min', value: v.min_thrust_n }, { name: 'T = T_max', value: v.max_thrust_n }],
      delta_rad: [{ name: 'δ = −δ_max', value: -d }, { name: 'δ = +δ_max', value: d }],
      gimbal_rate_radps: [{ name: 'χ = −χ_max', value: -c }, { name: 'χ = +χ_max', value: c }]
    };
  }

  // The bounds met at t (within 0.2 % of the column's range).
  function activeAt(cols, bounds, t) {
    var names = [];
    Object.keys(bounds).forEach(function (key) {
      var bs = bounds[key];
      var span = Math.abs(bs[bs.length - 1].value - bs[0].value) || Math.abs(bs[0].value) || 1;
      var y = at(cols.t_s, cols[key], t);
      bs.forEach(function (b) { if (Math.abs(y - b.value) <= 2e-3 * span) { names.push(b.name); } });
    });
    return names;
  }

  function bandsOf(breaks, t0, t1) {
    var edges = [t0].concat(breaks, [t1]), bands = [];
    for (var i = 0; i + 1 < edges.length; i++) { bands.push([edges[i], edges[i + 1]]); }
    return bands;
  }

  // An operational limit as a phrase, from its data.constraints entry.
  function limitText(key, o) {
    if (key === 'cone') { return 'approach cone ' + fmt(o.half_angle_deg, 1) + '° from the vertical'; }
    if (key === 'pitch_rate') { return '|w| ≤ ' + fmt(o.max_degps, 1) + '°/s'; }
    if (key === 'tilt') { return '|θ| ≤ ' + fmt(o.max_deg, 1) + '° below ' + fmt(o.below_m, 1) + ' m'; }
    return '|Vx| ≤ ' + fmt(o.max_lateral_mps, 2) + ' m/s below ' + fmt(o.below_m, 1) + ' m';
  }

  // One line: each limit and its worst margin along the flight (≥ 0: held;
  // broken only beyond the path check's tolerance).
  function limitSummary(parent, lim) {
    var parts = ['cone', 'pitch_rate', 'tilt', 'final_descent'].filter(function (k) { return lim[k]; }).map(function (k) {
      var o = lim[k], w = o.worst;
      var m = w ? 'worst margin ' + fmt(w.margin, 2) + ' ' + w.unit + ' at t = ' + fmt(w.t_s, 2) + ' s' +
        (w.held ? '' : ' (broken)') : 'not measured';
      return limitText(k, o) + ': ' + m;
    });
    html('div', { class: 'limits', id: 'limits' }, parent, 'limits along the flight: ' + parts.join('; '));
  }

  // The operational limit drawn on the chart of column key, if any.
  function limitOn(lim, key) {
    for (var k in (lim || {})) {
      var o = lim[k];
      if (o && o.column === key && o.bound) { return { name: k, t: lim.t_s, bound: o.bound }; }
    }
    return null;
  }

  function kvTable(parent, rows) {
    var t = html('table', { class: 'kv' }, parent);
    rows.forEach(function (r) {
      var tr = html('tr', {}, t);
      html('td', {}, tr, r[0]);
      html('td', {}, tr, r[1]);
    });
    return t;
  }

  function legend(parent, items) {
    var d = html('div', { class: 'legend' }, parent);
    items.forEach(function (it) {
      var s = html('span', {}, d);
      html('span', { class: 'sw', style: 'background:' + it[0] }, s);
      s.appendChild(document.createTextNode(it[1]));
    });
  }

  function solveSummary(parent, sol) {
    var le = sol.landing_error, pr = sol.propagation || {};
    var mesh = sol.mesh || {};
    var rows = [
      ['status', sol.status + (sol.message ? ' (' + sol.message + ')' : '')],
      ['method', sol.method + ', N = ' + sol.nodes + ', ' + sol.intervals + ' interval(s)'],
      ['t_f', fmt(sol.tf_s, 3) + ' s'],
      ['final mass', fmt(sol.final_mass_kg, 1) + ' kg (fuel ' + fmt(sol.fuel_kg, 1) + ' kg)'],
      ['mesh error', mesh.max_relative_error !== undefined ? Number(mesh.max_relative_error).toExponential(1) : (mesh.error || '-')]
    ];
    if (le) {
      rows.push(['landing error (flown)', 'position ' + fmt(le.position_m, 3) + ' m, velocity ' + fmt(le.velocity_mps, 3) +
        ' m/s, pitch ' + fmt(le.pitch_rad * DEG, 3) + ' deg, rate ' + fmt(le.rate_radps * DEG, 3) + ' deg/s']);
    } else {
      rows.push(['landing error', 'not measured: ' + (pr.error || 'no re-integration')]);
    }
    kvTable(parent, rows).id = 'summary';
  }

  function meshTable(parent, sol) {
    var iv = (sol.mesh && sol.mesh.intervals) || [];
    if (!iv.length) { return; }
    var t = html('table', { class: 'kv', id: 'mesh' }, parent);
    var head = html('tr', {}, t);
    ['interval', 'points', 'span [s]', 'rel. error', 'worst state'].forEach(function (h) { html('th', {}, head, h); });
    iv.forEach(function (r) {
      var tr = html('tr', {}, t);
      [r.interval, r.points, fmt(r.t_start_s, 2) + '–' + fmt(r.t_end_s, 2), Number(r.relative_error).toExponential(1),
        r.worst_state].forEach(function (c) { html('td', {}, tr, String(c)); });
    });
  }

  // The switching functions of a polished answer's certificate
  // (optimality.switching), each over its largest |·|: S_T under the thrust
  // chart with the thrust arcs behind it (the minimum principle wants S_T < 0
  // on T_max, > 0 on T_min), S_δ under δ's. None for a raw answer.
  function switchingCharts(o) {
    var sw = o && o.switching;
    if (!sw) { return []; }
    var names = { upper: 'T = T_max', lower: 'T = T_min', free: 'T free (singular)' };
    var arcs = (o.thrust_arcs || []).map(function (a) {
      return { t0: a.t_start_s, t1: a.t_end_s, cls: 'arc ' + a.kind,
        title: names[a.kind] + ', t = ' + fmt(a.t_start_s, 2) + '–' + fmt(a.t_end_s, 2) + ' s' };
    });
    return [
      { key: 'switching_thrust', under: 'thrust_n', label: 'S_T = ∂H/∂T (÷ max |S_T|)', zero: true, shades: arcs,
        series: [{ cls: 'switching', t: sw.t_s, y: sw.thrust }] },
      { key: 'switching_delta', under: 'delta_rad', label: 'S_δ = ∂H/∂δ (÷ max |S_δ|)', zero: true,
        series: [{ cls: 'switching', t: sw.t_s, y: sw.delta }] }
    ];
  }

  function solveView(app, data) {
    var sol = data.plan.solution, dense = data.plan.dense, flown = data.flown;
    html('h1', {}, app, data.scenario.name + ': the flip and landing, N = ' + sol.nodes);
    var t0 = dense.t_s[0], t1 = dense.t_s[dense.t_s.length - 1];
    var extra = switchingCharts(sol.optimality);
    var show = { cols: dense, plan: dense, flown: flown, nodes: sol, breaks: data.plan.breaks_s, marks: [],
      limits: data.constraints, extraCharts: extra };
    var items = [['#1f77b4', 'plan (LGR interpolants, nodes dotted)'],
      ['#ff7f0e', 'flown (re-integrated from the plan\'s controls)'], ['#d62728', 'bounds (thick: active)']];
    if (extra.length) {
      items.push(['#8c564b', 'switching functions S_T, S_δ (certificate; shaded: T_max arcs red, T_min blue)']);
    }
    var view = buildTimeView(app, data.scenario, show, t0, t1, items);
    if (flown) {
      var n = flown.t_s.length - 1;
      el('circle', { class: 'landing', id: 'flown-touchdown', cx: view.scene.X(flown.x_m[n]),
        cy: view.scene.Y(flown.z_m[n]), r: 4 }, view.scene.svg);
    }
    solveSummary(view.side, sol);
    meshTable(view.side, sol);
    return view;
  }

  // The scene, the player, the charts and the side panel over [t0, t1]:
  // show.cols is what the vehicle is posed from, show.plan and show.flown
  // the curves drawn.
  function buildTimeView(app, sc, show, t0, t1, legendItems) {
    var bounds = boundsOf(sc);
    var view = { t: t0, cols: show.cols, bounds: bounds, active: [] }, lim = show.limits;
    view.player = new Player(app, t0, t1, function (t) { update(view, t); });
    legend(app, lim ? legendItems.concat([['#9467bd', 'operational limits (cone, trigger heights dashed, ±bounds)']]) : legendItems);
    if (lim) { limitSummary(app, lim); }
    var layout = html('div', { class: 'layout' }, app);
    var left = html('div', { class: 'panel side' }, layout);
    var paths = [{ x: show.plan.x_m, z: show.plan.z_m }];
    if (show.flown) { paths.push({ x: show.flown.x_m, z: show.flown.z_m }); }
    view.scene = new Scene(left, paths, sc.vehicle, 400);
    if (lim) { view.scene.drawLimits(lim); }
    (show.replanPaths || []).forEach(function (p) {
      if (p.x_m.length) { view.scene.path('replan-path ' + p.outcome, p.x_m, p.z_m); }
    });
    view.scene.path('plan', show.plan.x_m, show.plan.z_m);
    if (show.flown) { view.scene.path('flown', show.flown.x_m, show.flown.z_m); }
    (show.marks || []).forEach(function (m) {
      el('circle', { class: 'replan ' + m.cls, fill: 'none', cx: view.scene.X(at(show.cols.t_s, show.cols.x_m, m.t)),
        cy: view.scene.Y(at(show.cols.t_s, show.cols.z_m, m.t)), r: 3 }, view.scene.svg).appendChild(
        el('title', {}, null, m.title));
    });
    view.scene.drawVehicle();
    view.activeBox = html('div', { class: 'active-list', id: 'active' }, left);
    view.readout = html('div', { id: 'readout' }, left);
    view.side = left;
    var charts = html('div', { class: 'charts panel' }, layout);
    view.charts = STATES.filter(function (s) { return show.plan[s[0]]; }).map(function (s) {
      return new Chart(charts, chartSpec(s, show, bounds), t0, t1);
    });
    (show.extraCharts || []).forEach(function (spec) {
      var chart = new Chart(charts, spec, t0, t1);
      if (spec.under) { placeUnder(chart, view.charts, spec.under); }
      view.charts.push(chart);
    });
    view.charts.forEach(function (c) { clickToSeek(c, view.player, t0, t1); });
    return view;
  }

  // Put chart in the grid's column of the chart of key `under` (the state
  // charts fill the grid in order, CHART_COLUMNS a row): the grid then puts
  // it in the first free row below.
  function placeUnder(chart, charts, under) {
    var i = charts.findIndex(function (c) { return c.spec.key === under; });
    if (i >= 0) { chart.svg.style.gridColumn = String(i % CHART_COLUMNS + 1); }
  }

  function chartSpec(s, show, bounds) {
    var key = s[0], series = [];
    (show.replanPaths || []).forEach(function (p) {
      if (p[key] && p[key].length) { series.push({ cls: 'replan-path ' + p.outcome, t: p.t_s, y: p[key] }); }
    });
    series.push({ cls: 'plan', t: show.plan.t_s, y: show.plan[key] });
    if (show.flown && show.flown[key]) { series.push({ cls: 'flown', t: show.flown.t_s, y: show.flown[key] }); }
    var nodes = show.nodes && show.nodes[key] ? { t: show.nodes.t_s, y: show.nodes[key] } : null;
    var t0 = show.cols.t_s[0], t1 = show.cols.t_s[show.cols.t_s.length - 1];
    return { key: key, label: s[1], scale: s[2], series: series, nodes: nodes, bounds: bounds[key], limit: limitOn(show.limits, key),
      breaks: show.breaks, bands: bandsOf(show.breaks || [], t0, t1), marks: show.marks };
  }

  function clickToSeek(chart, player, t0, t1) {
    chart.svg.addEventListener('click', function (ev) {
      var box = chart.svg.getBoundingClientRect(), x = ev.clientX - box.left;
      var t = t0 + (x - chart.fx(t0)) / (chart.fx(t1) - chart.fx(t0)) * (t1 - t0);
      player.pause();
      player.set(t);
    });
  }

  function update(view, t) {
    var c = view.cols;
    var v = {};
    ['x_m', 'z_m', 'vx_mps', 'vz_mps', 'theta_rad', 'pitch_rate_radps', 'mass_kg', 'delta_rad', 'thrust_n']
      .forEach(function (k) { v[k] = c[k] ? at(c.t_s, c[k], t) : NaN; });
    if (!c.thrust_n) { v.thrust_n = at(c.t_s, c.thrust_cmd_n, t); }
    view.t = t;
    view.now = v;
    view.scene.pose(v.x_m, v.z_m, v.theta_rad, v.delta_rad, v.thrust_n);
    view.active = activeAt(c.thrust_n ? c : renameThrust(c), view.bounds, t);
    view.charts.forEach(function (ch) { ch.update(t, view.active); });
    view.activeBox.textContent = view.active.length ? 'active: ' + view.active.join(', ') : 'no bound active';
    view.readout.textContent = 'x ' + fmt(v.x_m, 1) + ' m, z ' + fmt(v.z_m, 1) + ' m, θ ' + fmt(v.theta_rad * DEG, 1) +
      '°, δ ' + fmt(v.delta_rad * DEG, 2) + '°, T ' + fmt(v.thrust_n / 1e6, 3) + ' MN, m ' + fmt(v.mass_kg, 0) + ' kg';
  }

  // A flight's trace names its thrust thrust_cmd_n and gimbal rate
  // gimbal_rate_cmd_radps: the same bounds apply.
  function renameThrust(c) {
    var r = {};
    for (var k in c) { r[k] = c[k]; }
    r.thrust_n = c.thrust_cmd_n;
    r.gimbal_rate_radps = c.gimbal_rate_cmd_radps;
    return r;
  }

  // ---- a flight -----------------------------------------------------------

  function replanMarks(replans) {
    return replans.map(function (r) {
      return { t: r.time_s, cls: r.outcome, title: 't = ' + fmt(r.time_s, 2) + ' s: ' + r.status + ', ' + r.outcome +
        ', ' + fmt(r.solve_ms, 1) + ' ms, ' + r.iterations + ' iterations' + (r.reason ? ' (' + r.reason + ')' : '') };
    });
  }

  function flightView(app, data) {
    var f = data.flight, trace = renameThrust(data.trace), plan = data.plan.dense;
    html('h1', {}, app, data.scenario.name + ': closed-loop flight, seed ' + f.seed + ', run ' + f.run + ': ' + f.outcome_name);
    var t0 = trace.t_s[0], t1 = trace.t_s[trace.t_s.length - 1];
    var marks = replanMarks(f.replans || []);
    var show = { cols: trace, plan: trace, flown: plan, breaks: [], marks: marks, replanPaths: data.replan_paths,
      limits: data.constraints, extraCharts: [
      { key: 'wind_mps', label: 'wind [m/s] (● re-plan estimate)', series: [{ cls: 'plan', t: trace.t_s, y: trace.wind_mps }],
        nodes: { t: marks.map(function (m) { return m.t; }), y: (f.replans || []).map(function (r) { return r.wind_estimate_mps; }) }, marks: marks },
      { key: 'solve_ms', label: 're-plan solve time [ms]', series: [],
        nodes: { t: marks.map(function (m) { return m.t; }), y: (f.replans || []).map(function (r) { return r.solve_ms; }) }, marks: marks }
    ] };
    var view = buildTimeView(app, data.scenario, show, t0, t1, [['#1f77b4', 'flown (plant, closed loop)'],
      ['#ff7f0e', 'first plan'], ['#2ca02c', 're-plans: markers and their plans, thin (red: failed or missed)'], ['#d62728', 'bounds (thick: active)']]);
    verdict(view.side, f);
    replanTable(view.side, f.replans || []);
    return view;
  }

  function verdict(parent, f) {
    var o = f.outcome || {}, td = o.touchdown || o.Touchdown || o;
    var rows = [['outcome', f.outcome_name], ['fuel', fmt(f.fuel_kg, 1) + ' kg'],
      ['first plan', f.first_plan.status + (f.first_plan.nominal ? ' (nominal scenario\'s)' : '') + ', t_f ' + fmt(f.first_plan.tf_s, 2) + ' s']];
    if (td.x_error_m !== undefined) {
      rows.push(['touchdown', 't = ' + fmt(td.time_s, 2) + ' s, x ' + fmt(td.x_error_m, 3) + ' m, Vz ' + fmt(td.vertical_velocity_mps, 3) +
        ' m/s, Vx ' + fmt(td.horizontal_velocity_mps, 3) + ' m/s, pitch ' + fmt(td.pitch_error_deg, 2) + ' deg']);
    }
    kvTable(parent, rows).id = 'verdict';
  }

  function replanTable(parent, replans) {
    var box = html('div', { class: 'scroll' }, parent);
    var t = html('table', { class: 'kv', id: 'replans' }, box);
    var head = html('tr', {}, t);
    ['t [s]', 'status', 'outcome', 'ms', 'iter.', 'wind est.'].forEach(function (h) { html('th', {}, head, h); });
    replans.forEach(function (r) {
      var tr = html('tr', {}, t);
      [fmt(r.time_s, 2), r.status, r.outcome, fmt(r.solve_ms, 1), r.iterations, fmt(r.wind_estimate_mps, 2)]
        .forEach(function (c) { html('td', {}, tr, String(c)); });
    });
  }

  // ---- a campaign ---------------------------------------------------------

  function Scatter(parent, id, label, xr, yr) {
    var w = 420, h = 320, l = 48, b = 30, r = 10, top = 20;
    // The axes' ranges and the plot box [left, top, right, bottom] in px,
    // for whoever checks where a run is drawn.
    this.svg = el('svg', { width: w, height: h, class: 'scatter', id: id, 'data-xr': xr.join(','),
      'data-yr': yr.join(','), 'data-box': [l, top, w - r, h - b].join(',') }, parent);
    this.fx = function (x) { return l + (w - l - r) * (x - xr[0]) / (xr[1] - xr[0]); };
    this.fy = function (y) { return top + (h - top - b) * (yr[1] - y) / (yr[1] - yr[0]); };
    el('text', { x: l, y: 13, class: 'title' }, this.svg, label[0]);
    el('line', { class: 'axis', x1: l, x2: w - r, y1: h - b, y2: h - b }, this.svg);
    el('line', { class: 'axis', x1: l, x2: l, y1: top, y2: h - b }, this.svg);
    el('text', { x: (l + w) / 2, y: h - 4, 'text-anchor': 'middle' }, this.svg, label[1]);
    var self = this;
    [xr[0], (xr[0] + xr[1]) / 2, xr[1]].forEach(function (v) {
      el('text', { x: self.fx(v), y: h - b + 12, 'text-anchor': 'middle' }, self.svg, tick(v));
    });
    [yr[0], (yr[0] + yr[1]) / 2, yr[1]].forEach(function (v) {
      el('text', { x: l - 3, y: self.fy(v) + 3, 'text-anchor': 'end' }, self.svg, tick(v));
    });
  }

  Scatter.prototype.box = function (cls, x0, x1, y0, y1) {
    el('rect', { class: cls, x: this.fx(x0), y: this.fy(y1), width: this.fx(x1) - this.fx(x0), height: this.fy(y0) - this.fy(y1) }, this.svg);
  };

  function symmetric(values, limit) {
    var m = limit;
    values.forEach(function (v) { if (v !== null && isFinite(v)) { m = Math.max(m, Math.abs(v)); } });
    return [-1.1 * m, 1.1 * m];
  }

  function campaignView(app, data) {
    var s = data.summary, lim = data.limits, cols = data.columns;
    var idx = {};
    cols.forEach(function (c, i) { idx[c] = i; });
    var rows = data.rows;
    var col = function (name) { return rows.map(function (r) { return r[idx[name]]; }); };
    html('h1', {}, app, 'Monte Carlo campaign: ' + s.runs + ' runs, seed ' + s.seed);
    kvTable(app, [['within spec', s.in_spec + ' of ' + s.runs + ' (' + fmt(100 * s.in_spec_fraction, 1) + ' %)'],
      ['failures', String(s.failures)], ['outcomes', JSON.stringify(s.outcomes)]]).id = 'campaign-summary';
    legend(app, [['#2ca02c', 'landed'], ['#ff7f0e', 'hard landing'], ['#d62728', 'crash'], ['#7f7f7f', 'no touchdown'],
      ['rgba(44,160,44,0.4)', 'spec'], ['#d62728', 'survival (crash) limits']]);
    var layout = html('div', { class: 'layout' }, app);
    var x = col('x_error_m'), vz = col('vertical_velocity_mps'), vx = col('horizontal_velocity_mps');
    var xr = symmetric(x, lim.landed_position_m);
    var a = new Scatter(layout, 'scatter-x', ['touchdown position and vertical speed', 'x error [m] (|vertical speed| [m/s] up)'],
      xr, [0, 1.1 * Math.max(lim.crash_vertical_speed_mps, maxAbs(vz))]);
    a.box('spec', -lim.landed_position_m, lim.landed_position_m, 0, lim.landed_speed_mps);
    a.box('survival', xr[0], xr[1], 0, lim.crash_vertical_speed_mps);
    var b = new Scatter(layout, 'scatter-v', ['touchdown velocity', 'horizontal velocity [m/s] (|vertical| [m/s] up)'],
      symmetric(vx, lim.crash_horizontal_speed_mps), [0, 1.1 * Math.max(lim.crash_vertical_speed_mps, maxAbs(vz))]);
    b.box('survival', -lim.crash_horizontal_speed_mps, lim.crash_horizontal_speed_mps, 0, lim.crash_vertical_speed_mps);
    // Speed at most the spec: the half disc above |vertical| = 0.
    var cr = b.fx(lim.landed_speed_mps) - b.fx(0), cy = b.fy(0), cx = b.fx(0);
    el('path', { class: 'spec', d: 'M' + (cx - cr) + ',' + cy + ' A' + cr + ',' + (b.fy(0) - b.fy(lim.landed_speed_mps)) +
      ' 0 0 1 ' + (cx + cr) + ',' + cy + ' Z' }, b.svg);
    var side = html('div', { class: 'panel', id: 'run-panel' }, layout);
    html('div', {}, side, 'Click a run to see its row.');
    var view = { kind: 'campaign', rows: rows, idx: idx, dots: [], side: side, cmd: data.sim_command, cols: cols, scatters: [a, b] };
    rows.forEach(function (r, i) {
      var o = r[idx.outcome], cls = ['landed', 'hard_landing', 'crash'].indexOf(o) >= 0 ? o : 'other';
      var pair = [dot(a, x[i], Math.abs(vz[i]), cls, i, view), dot(b, vx[i], Math.abs(vz[i]), cls, i, view)];
      view.dots.push(pair);
    });
    return view;
  }

  function maxAbs(v) {
    return v.reduce(function (m, y) { return y !== null && isFinite(y) ? Math.max(m, Math.abs(y)) : m; }, 0);
  }

  function dot(sc, x, y, cls, i, view) {
    if (x === null || y === null || !isFinite(x) || !isFinite(y)) { return null; }
    var d = el('circle', { class: 'dot ' + cls, cx: sc.fx(x), cy: sc.fy(y), r: 3.2, 'data-run': view.rows[i][view.idx.run] }, sc.svg);
    d.addEventListener('click', function () { selectRun(view, i); });
    return d;
  }

  function selectRun(view, i) {
    if (view.selected !== undefined) { view.dots[view.selected].forEach(function (d) { if (d) { d.classList.remove('selected'); } }); }
    view.selected = i;
    view.dots[i].forEach(function (d) { if (d) { d.classList.add('selected'); } });
    var r = view.rows[i], run = r[view.idx.run];
    view.side.textContent = '';
    html('h1', {}, view.side, 'run ' + run);
    kvTable(view.side, view.cols.map(function (c, k) {
      return [c, typeof r[k] === 'number' ? String(r[k]) : String(r[k])];
    })).id = 'run-row';
    html('div', {}, view.side, 'Fly it again:');
    html('pre', { class: 'cmd', id: 'run-command' }, view.side, view.cmd + ' --run ' + run + ' --out run-' + run);
  }

  // ---- start --------------------------------------------------------------

  function start() {
    var data = JSON.parse(document.getElementById('bellyflop-data').textContent);
    var app = document.getElementById('app');
    app.textContent = '';
    var view;
    if (data.kind === 'campaign') {
      view = campaignView(app, data);
    } else {
      view = data.kind === 'flight' ? flightView(app, data) : solveView(app, data);
      view.player.set(view.player.t0);
    }
    window.viewer = api(data, view);
    // The second frame callback runs once the first frame is drawn.
    requestAnimationFrame(function () {
      requestAnimationFrame(function () { window.viewer.firstFrameMs = performance.now(); });
    });
  }

  function api(data, view) {
    var scene = view.scene;
    return {
      kind: data.kind,
      loadMs: performance.now(),
      setTime: function (t) { view.player.pause(); view.player.set(t); return view.t; },
      play: function () { view.player.play(); },
      pause: function () { view.player.pause(); },
      select: function (run) {
        var i = view.rows.findIndex(function (r) { return r[view.idx.run] === run; });
        if (i >= 0) { selectRun(view, i); }
        return i;
      },
      state: function () {
        if (!scene) { return { kind: data.kind, selected: view.selected }; }
        return { kind: data.kind, t: view.t, now: view.now, active: view.active,
          scale: scene.s, ox: scene.ox, oy: scene.oy, t0: view.player.t0, t1: view.player.t1 };
      }
    };
  }

  start();
}());
