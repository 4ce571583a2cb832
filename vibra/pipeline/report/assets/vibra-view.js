/* vibra's interactive views (vibra/_results/display.py writes the HTML and the data; BSD-3-Clause, as vibra).
 *
 * vibra3d.start(root) starts the view inside the element `root`: its data is the JSON of the
 * `script.view-data` inside it; everything it touches is found inside `root`, so two views on one
 * page never collide. Two kinds:
 *   "modes":   sites, bonds and per mode one displacement per site; 3Dmol.js makes the frames
 *              (model.vibrate) and plays them back and forth; a mode menu and an amplitude slider.
 *   "crystal": a band structure drawn as SVG; clicking a point (q, branch) animates that branch on
 *              a supercell: frames of Re[u_j exp(2 pi i q.(R + x_j)) exp(-i phi)], phi over one
 *              period (u = e / sqrt(m), phonopy's phase); an imaginary mode (negative frequency) is
 *              drawn as its static pattern growing from rest, s Re[u ...], s from 0 to 1.
 * After start, root.vibra holds the viewer and, for a crystal, pick(point, branch), where(point,
 * branch) and frames (the positions of the last animation), which the browser tests read.
 */
(function () {
  "use strict";
  var STYLES = {  // a chain's masses: one colour per distinct mass (lightest carbon grey, then red, blue ...)
    molecule: {stick: {radius: 0.12}, sphere: {scale: 0.24}},
    network: {sphere: {radius: 0.9}, stick: {radius: 0.3, color: "#8a9bb0"}},
    chain: {sphere: {radius: 0.7}, stick: {radius: 0.12, color: "#999999"}},
    crystal: {sphere: {scale: 0.3}, stick: {radius: 0.1}}
  };
  var SVG = "http://www.w3.org/2000/svg";

  function make3d(box) {
    if (typeof $3Dmol === "undefined" || !$3Dmol.createViewer) {
      box.textContent = "The 3-D view needs 3Dmol-min.js (vibra's report: assets/ next to this page).";
      return null;
    }
    var viewer = $3Dmol.createViewer(box, {backgroundColor: "white", antialias: true, minimumZoomToDistance: 1});
    if (!viewer) box.textContent = "The 3-D view needs WebGL, which this browser does not offer.";
    return viewer;
  }

  // ------------------------------------------------------------------ normal modes
  function startModes(root, data) {
    var box = root.querySelector(".view3d");
    var menu = root.querySelector(".view-mode");
    var amplitude = root.querySelector(".view-amplitude");
    var button = root.querySelector(".view-play");
    var running = true;
    var viewer = make3d(box);
    if (!viewer) return {viewer: null};
    function xyz(k) {
      var vectors = data.modes[k].vectors, lines = [String(data.positions.length), data.modes[k].label];
      for (var i = 0; i < data.positions.length; i++) {
        var p = data.positions[i], v = vectors[i];
        lines.push([data.elements[i], p[0], p[1], p[2], v[0], v[1], v[2]].join(" "));
      }
      return lines.join("\n");
    }
    function show(frame) {
      viewer.stopAnimate();
      viewer.removeAllModels();
      var model = viewer.addModel(xyz(Number(menu.value)), "xyz", {assignBonds: false});
      var atoms = model.selectedAtoms({});
      atoms.forEach(function (atom, i) { atom.index = i; atom.bonds = []; atom.bondOrder = []; });
      data.bonds.forEach(function (b) {
        atoms[b[0]].bonds.push(b[1]); atoms[b[0]].bondOrder.push(1);
        atoms[b[1]].bonds.push(b[0]); atoms[b[1]].bondOrder.push(1);
      });
      var style = JSON.parse(JSON.stringify(STYLES[data.style] || STYLES.network));
      if (data.style === "network") {  // colour each residue by how far it moves, still to most (blue to red)
        var largest = 0;
        atoms.forEach(function (atom) {
          atom.b = Math.hypot(atom.dx, atom.dy, atom.dz);
          largest = Math.max(largest, atom.b);
        });
        style.sphere.colorscheme = {prop: "b", gradient: "rwb", min: largest || 1, max: 0};
      }
      model.setStyle({}, style);
      model.vibrate(10, Number(amplitude.value), true);
      if (frame) {  // fit, with room for the motion (a chain: fit its length to the box's width)
        var wide = data.style === "chain" ? 0.9 * box.clientWidth / Math.max(box.clientHeight, 1) : 0;
        viewer.zoomTo();
        viewer.zoom(wide || (data.style === "network" ? 1.2 : 0.75));
      }
      viewer.render();
      if (running) viewer.animate({loop: "backAndForth", interval: 50});
    }
    menu.addEventListener("change", function () { show(false); });
    amplitude.addEventListener("input", function () { show(false); });
    button.addEventListener("click", function () {
      running = !running;
      button.textContent = running ? "pause" : "play";
      show(false);
    });
    show(true);
    return {viewer: viewer};
  }

  // ------------------------------------------------------------------ crystals
  function crystalFrames(data, point, branch) {
    // positions (n_frames x n_atoms x 3) of the supercell animation; the same sums as
    // vibra.crystals.animation.frame_positions, which the tests compare with phonopy's modulation
    var cell = data.cell, n = point.repeats, u = point.vectors[branch], q = point.q;
    var imaginary = data.bands.values[point.index][branch] < 0;
    var rest = [], amp = [];
    for (var a = 0; a < n[0]; a++) for (var b = 0; b < n[1]; b++) for (var c = 0; c < n[2]; c++) {
      for (var j = 0; j < data.fractional.length; j++) {
        var f = [a + data.fractional[j][0], b + data.fractional[j][1], c + data.fractional[j][2]];
        var angle = 2 * Math.PI * (q[0] * f[0] + q[1] * f[1] + q[2] * f[2]);
        var cos = Math.cos(angle), sin = Math.sin(angle), z = [];
        for (var k = 0; k < 3; k++) {
          var re = u[6 * j + 2 * k], im = u[6 * j + 2 * k + 1];
          z.push([re * cos - im * sin, re * sin + im * cos]);
        }
        rest.push([0, 1, 2].map(function (x) { return f[0] * cell[0][x] + f[1] * cell[1][x] + f[2] * cell[2][x]; }));
        amp.push(z);
      }
    }
    var turn = 0;
    if (imaginary) {  // the global phase that makes the pattern's real part largest: -arg(sum A^2) / 2
      var sre = 0, sim = 0;
      amp.forEach(function (z) { z.forEach(function (w) { sre += w[0] * w[0] - w[1] * w[1]; sim += 2 * w[0] * w[1]; }); });
      turn = -Math.atan2(sim, sre) / 2;
    }
    var frames = [], count = data.frames;
    for (var t = 0; t < count; t++) {
      var phi = 2 * Math.PI * t / count, s = count > 1 ? t / (count - 1) : 1;
      frames.push(rest.map(function (r, i) {
        return [0, 1, 2].map(function (x) {
          var w = amp[i][x];
          if (imaginary) return r[x] + data.scale * s * (w[0] * Math.cos(turn) - w[1] * Math.sin(turn));
          return r[x] + data.scale * (w[0] * Math.cos(phi) + w[1] * Math.sin(phi));
        });
      }));
    }
    return {frames: frames, imaginary: imaginary};
  }

  function startCrystal(root, data) {
    var box = root.querySelector(".view3d"), holder = root.querySelector(".bands");
    var picked = root.querySelector(".picked");
    var bands = data.bands, api = {viewer: make3d(box), frames: null};
    var width = Math.min(Math.max(holder.clientWidth, 320), 900), height = 300;
    var left = 58, right = 12, top = 10, bottom = 30;
    var x0 = bands.x[0], x1 = bands.x[bands.x.length - 1] || 1;
    var low = 0, high = 0;
    bands.values.forEach(function (row) { row.forEach(function (v) { low = Math.min(low, v); high = Math.max(high, v); }); });
    high = high > 0 ? high * 1.05 : 1;
    low = low < 0 ? low * 1.05 : 0;
    function px(x) { return left + (x - x0) / ((x1 - x0) || 1) * (width - left - right); }
    function py(v) { return top + (high - v) / (high - low) * (height - top - bottom); }
    function node(name, attributes, text) {
      var element = document.createElementNS(SVG, name);
      Object.keys(attributes).forEach(function (key) { element.setAttribute(key, attributes[key]); });
      if (text !== undefined) element.textContent = text;
      return element;
    }
    var svg = node("svg", {width: width, height: height, viewBox: "0 0 " + width + " " + height,
                           style: "cursor:crosshair;font:11px sans-serif;background:white"});
    var step = Math.pow(10, Math.floor(Math.log10((high - low) / 5)));
    if ((high - low) / step > 12) step *= 2;
    if ((high - low) / step > 12) step *= 2.5;
    for (var tick = Math.ceil(low / step) * step; tick <= high; tick += step) {
      svg.appendChild(node("line", {x1: left, x2: width - right, y1: py(tick), y2: py(tick),
                                    stroke: Math.abs(tick) < step / 2 ? "#888" : "#eee"}));
      svg.appendChild(node("text", {x: left - 4, y: py(tick) + 4, "text-anchor": "end"}, String(+tick.toPrecision(4))));
    }
    svg.appendChild(node("text", {x: 12, y: height / 2, transform: "rotate(-90 12 " + height / 2 + ")",
                                  "text-anchor": "middle"}, "frequency (" + data.unit + ")"));
    bands.labels.forEach(function (label) {
      var x = px(bands.x[label[0]]);
      svg.appendChild(node("line", {x1: x, x2: x, y1: top, y2: height - bottom, stroke: "#bbb"}));
      svg.appendChild(node("text", {x: x, y: height - bottom + 14, "text-anchor": "middle"}, label[1]));
    });
    var starts = [0].concat(bands.breaks, [bands.x.length]);
    for (var b = 0; b < bands.values[0].length; b++) {
      for (var r = 0; r + 1 < starts.length; r++) {
        var points = [];
        for (var k = starts[r]; k < starts[r + 1]; k++) points.push(px(bands.x[k]) + "," + py(bands.values[k][b]));
        svg.appendChild(node("polyline", {points: points.join(" "), fill: "none", stroke: "#1f5fa8", "stroke-width": 1.5}));
      }
    }
    var marker = node("circle", {r: 5, fill: "#d62728", stroke: "white", "stroke-width": 1.5, visibility: "hidden"});
    svg.appendChild(marker);
    holder.appendChild(svg);

    api.where = function (p, branch) {  // client coordinates of point p, branch `branch`
      var rect = svg.getBoundingClientRect(), k = data.points[p].index;
      return [rect.left + px(bands.x[k]), rect.top + py(bands.values[k][branch])];
    };
    api.pick = function (p, branch) {
      var point = data.points[p], k = point.index, value = bands.values[k][branch];
      marker.setAttribute("cx", px(bands.x[k]));
      marker.setAttribute("cy", py(value));
      marker.setAttribute("visibility", "visible");
      var made = crystalFrames(data, point, branch);
      api.frames = made.frames;
      api.picked = [p, branch];
      var q = point.q.map(function (x) { return +x.toFixed(4); }).join(", ");
      picked.textContent = "Branch " + branch + " at q = (" + q + ") on " + point.repeats.join(" x ") + " cells: " +
        (made.imaginary ? "imaginary, " + (-value).toPrecision(4) + "i " + data.unit +
         ", drawn as its static displacement pattern growing from rest (an unstable mode does not oscillate)"
         : value === 0 ? "zero frequency (a uniform translation or a mode the springs do not hold), drawn as one cycle"
         : value.toPrecision(4) + " " + data.unit + ", one period of the oscillation");
      if (!api.viewer) return;
      var text = made.frames.map(function (frame, t) {
        var lines = [String(frame.length), "frame " + t];
        frame.forEach(function (r, i) {
          lines.push([data.elements[i % data.elements.length], r[0].toFixed(4), r[1].toFixed(4), r[2].toFixed(4)].join(" "));
        });
        return lines.join("\n");
      }).join("\n");
      api.viewer.stopAnimate();
      api.viewer.removeAllModels();
      var model = api.viewer.addModelsAsFrames(text, "xyz");
      model.setStyle({}, STYLES.crystal);
      api.viewer.zoomTo();
      api.viewer.render();
      api.viewer.animate({loop: made.imaginary ? "backAndForth" : "forward", interval: 60});
    };
    svg.addEventListener("click", function (event) {
      var rect = svg.getBoundingClientRect(), mx = event.clientX - rect.left, my = event.clientY - rect.top;
      var best = 0, gap = Infinity;
      data.points.forEach(function (point, p) {
        var d = Math.abs(px(bands.x[point.index]) - mx);
        if (d < gap) { gap = d; best = p; }
      });
      var row = bands.values[data.points[best].index], branch = 0;
      for (var c = 1; c < row.length; c++) if (Math.abs(py(row[c]) - my) < Math.abs(py(row[branch]) - my)) branch = c;
      api.pick(best, branch);
    });
    api.pick(data.start[0], data.start[1]);
    return api;
  }

  window.vibra3d = {
    start: function (root) {
      var data = JSON.parse(root.querySelector("script.view-data").textContent);
      root.vibra = data.kind === "crystal" ? startCrystal(root, data) : startModes(root, data);
      return root.vibra;
    },
    crystalFrames: crystalFrames
  };
})();
