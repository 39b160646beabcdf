/* pq-ghserver comparison report: the interactive 3D views.
 *
 * A classic script (no ES modules): it works from a file:// page, where Chromium refuses module scripts, and from
 * any server, whatever MIME type it gives .js files. Each <div class="viewer3d" data-view=ID data-src=FILE> starts
 * when it is scrolled into view (or clicked): the joined three.js (viewer/three.js, window.PQ_THREE) and the
 * view's data (FILE, a script calling PQViewer.add(ID, data)) are loaded by <script> elements, then a WebGL
 * canvas draws the mesh coloured per face. At most MAX_LIVE views hold a WebGL context at once (browsers allow
 * about 16): the least recently used one is paused, keeping a still picture, and resumes on a click or when it is
 * scrolled into view again.
 */
(function () {
  "use strict";

  // matplotlib's viridis at 17 stops (the report's pictures use the same map); CONSTANT is its middle
  var VIRIDIS = ["#440154", "#48186a", "#472d7b", "#424086", "#3b528b", "#33638d", "#2c728e", "#26828e", "#21918c",
    "#1fa088", "#28ae80", "#3fbc73", "#5ec962", "#84d44b", "#addc30", "#d8e219", "#fde725"];
  var CONSTANT = "#21918c";
  var MAX_LIVE = 6;

  var script = document.currentScript;
  var THREE_SRC = (script && script.getAttribute("data-three")) || "viewer/three.js";

  var scripts = {};  // src -> Promise
  function loadScript(src) {
    if (!scripts[src]) {
      scripts[src] = new Promise(function (resolve, reject) {
        var s = document.createElement("script");
        s.src = src;
        s.async = true;
        s.onload = function () { resolve(); };
        s.onerror = function () { delete scripts[src]; reject(new Error("could not load " + src)); };
        document.head.appendChild(s);
      });
    }
    return scripts[src];
  }

  function loadThree() {
    return loadScript(THREE_SRC).then(function () {
      if (!window.PQ_THREE) { throw new Error(THREE_SRC + " did not define PQ_THREE"); }
      return window.PQ_THREE;
    });
  }

  function decode(b64, Type) {
    var bin = atob(b64);
    var bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) { bytes[i] = bin.charCodeAt(i); }
    return new Type(bytes.buffer);
  }

  var rgbCache = {};
  function hexToRgb(hex) {
    if (!rgbCache[hex]) {
      var n = parseInt(hex.slice(1), 16);
      rgbCache[hex] = [(n >> 16 & 255) / 255, (n >> 8 & 255) / 255, (n & 255) / 255];
    }
    return rgbCache[hex];
  }

  // sRGB colour of t in [0, 1] on viridis (linear between the stops)
  function viridis(t) {
    t = Math.min(Math.max(t, 0), 1) * (VIRIDIS.length - 1);
    var i = Math.min(Math.floor(t), VIRIDIS.length - 2), f = t - i;
    var a = hexToRgb(VIRIDIS[i]), b = hexToRgb(VIRIDIS[i + 1]);
    return [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f];
  }

  function srgbToLinear(c) {
    return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
  }

  var live = [];  // views holding a WebGL context, least recently used first
  var views = {};  // id -> View

  function touch(view) {
    var i = live.indexOf(view);
    if (i >= 0) { live.splice(i, 1); }
    live.push(view);
    while (live.length > MAX_LIVE) { live.shift().pause(); }
  }

  function View(el) {
    this.el = el;
    this.id = el.getAttribute("data-view");
    this.src = el.getAttribute("data-src");
    this.stage = el.getAttribute("data-stage");
    this.metricSelect = el.querySelector(".v-metric");
    this.edgesBox = el.querySelector(".v-edges");
    this.host = el.querySelector(".v-canvas");
    this.legend = el.querySelector(".v-legend");
    this.still = null;
    this.setState("idle");
    var self = this;
    this.metricSelect.addEventListener("change", function () { self.recolour(); });
    this.edgesBox.addEventListener("change", function () {
      if (self.edges) { self.edges.visible = self.edgesBox.checked; self.render(); }
    });
    Array.prototype.forEach.call(el.querySelectorAll(".v-stages input"), function (input) {
      input.addEventListener("change", function () { if (input.checked) { self.setStage(input.value); } });
    });
    el.querySelector(".v-reset").addEventListener("click", function () { self.resetCamera(); });
    this.host.addEventListener("click", function (ev) {
      if (ev.target.closest && ev.target.closest(".v-start")) { self.start(); }
    });
    this.host.addEventListener("pointerdown", function () { if (self.state === "ready") { touch(self); } });
  }

  View.prototype.setState = function (state, message) {
    this.state = state;
    this.el.setAttribute("data-state", state);
    if (message) { this.el.setAttribute("data-message", message); }
  };

  View.prototype.start = function () {
    var self = this;
    if (this.state === "loading" || this.state === "ready") { return this.ready; }
    this.setState("loading");
    this.ready = loadThree().then(function (T) {
      return (PQViewer.data[self.id] ? Promise.resolve() : loadScript(self.src)).then(function () {
        var data = PQViewer.data[self.id];
        if (!data) { throw new Error(self.src + " holds no data for " + self.id); }
        self.build(T, data);
        self.setState("ready");
        touch(self);
      });
    }).catch(function (err) {
      self.setState("error", String(err && err.message || err));
      self.host.textContent = "3D view unavailable: " + (err && err.message || err);
    });
    return this.ready;
  };

  View.prototype.geometryOf = function (stage) {
    if (this.geometries[stage]) { return this.geometries[stage]; }
    var T = this.T, d = this.data, st = d.stages[stage];
    var topo = st.same_faces ? d.stages[st.same_faces] : st;
    var V = decode(st.V, Float32Array);
    var F = decode(topo.F, Uint32Array), sizes = decode(topo.sizes, Uint16Array), k = topo.k;
    var m = sizes.length, ntri = 0, f, c;
    for (f = 0; f < m; f++) { ntri += Math.max(sizes[f] - 2, 0); }
    var pos = new Float32Array(ntri * 9), triFace = new Uint32Array(ntri), t = 0;
    var edgeKeys = new Set(), edges = [], n = V.length / 3;
    for (f = 0; f < m; f++) {
      var base = f * k, s = sizes[f];
      for (c = 2; c < s; c++) {  // fan: corner 0 with consecutive corner pairs
        var tri = [F[base], F[base + c - 1], F[base + c]];
        for (var j = 0; j < 3; j++) {
          var v = tri[j] * 3, o = t * 9 + j * 3;
          pos[o] = V[v]; pos[o + 1] = V[v + 1]; pos[o + 2] = V[v + 2];
        }
        triFace[t++] = f;
      }
      for (c = 0; c < s; c++) {  // the panel's outline (not the fan's diagonals)
        var a = F[base + c], b = F[base + (c + 1) % s];
        var key = a < b ? a * n + b : b * n + a;
        if (a !== b && !edgeKeys.has(key)) { edgeKeys.add(key); edges.push(a, b); }
      }
    }
    var epos = new Float32Array(edges.length * 3);
    for (var e = 0; e < edges.length; e++) {
      epos[e * 3] = V[edges[e] * 3]; epos[e * 3 + 1] = V[edges[e] * 3 + 1]; epos[e * 3 + 2] = V[edges[e] * 3 + 2];
    }
    var g = new T.BufferGeometry();
    g.setAttribute("position", new T.BufferAttribute(pos, 3));
    g.setAttribute("color", new T.BufferAttribute(new Float32Array(ntri * 9), 3));
    g.computeVertexNormals();  // non-indexed: one normal per triangle, flat panels
    var ge = new T.BufferGeometry();
    ge.setAttribute("position", new T.BufferAttribute(epos, 3));
    this.geometries[stage] = { mesh: g, edges: ge, triFace: triFace, faces: m };
    return this.geometries[stage];
  };

  View.prototype.build = function (T, data) {
    this.T = T;
    this.data = data;
    this.geometries = {};
    var w = Math.max(this.host.clientWidth, 1), h = Math.max(this.host.clientHeight, 1);
    var renderer = new T.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    renderer.setSize(w, h, false);
    this.renderer = renderer;
    this.host.replaceChildren(renderer.domElement);
    var scene = new T.Scene();
    scene.background = new T.Color(0xf4f4f4);
    var r = data.radius > 0 ? data.radius : 1;
    var camera = new T.PerspectiveCamera(30, w / h, r / 100, r * 100);
    camera.up.set(0, 0, 1);
    scene.add(new T.HemisphereLight(0xffffff, 0x8a8a8a, 2.2));
    var light = new T.DirectionalLight(0xffffff, 1.0);
    light.position.set(0.4, 0.6, 1.0);
    camera.add(light);  // a head light: the lit side is the side looked at
    scene.add(camera);
    this.material = new T.MeshLambertMaterial({ vertexColors: true, side: T.DoubleSide, polygonOffset: true,
      polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
    this.lineMaterial = new T.LineBasicMaterial({ color: 0x222222, transparent: true, opacity: 0.55 });
    this.mesh = new T.Mesh(new T.BufferGeometry(), this.material);
    this.edges = new T.LineSegments(new T.BufferGeometry(), this.lineMaterial);
    this.edges.visible = this.edgesBox.checked;
    scene.add(this.mesh);
    scene.add(this.edges);
    this.scene = scene;
    this.camera = camera;
    var controls = new T.OrbitControls(camera, renderer.domElement);
    controls.screenSpacePanning = true;
    controls.minDistance = r / 50;
    controls.maxDistance = r * 40;
    var self = this;
    controls.addEventListener("change", function () { self.render(); });
    this.controls = controls;
    this.resizer = new ResizeObserver(function () { self.resize(); });
    this.resizer.observe(this.host);
    this.setStage(this.stage || Object.keys(data.stages)[0]);
    this.resetCamera();
  };

  View.prototype.resetCamera = function () {
    if (!this.camera) { return; }
    var d = this.data, r = d.radius > 0 ? d.radius : 1;
    var el = d.camera[0] * Math.PI / 180, az = d.camera[1] * Math.PI / 180;
    var dist = r / Math.sin(this.camera.fov * Math.PI / 360) * 0.9;
    var dir = new this.T.Vector3(Math.cos(el) * Math.cos(az), Math.cos(el) * Math.sin(az), Math.sin(el));
    this.camera.position.copy(dir).multiplyScalar(dist);
    this.controls.target.set(0, 0, 0);
    this.controls.update();
    if (d.half) {  // frame the box (not its sphere): scale the distance until its corners fill ~85% of the view
      for (var it = 0; it < 3; it++) {
        this.camera.updateMatrixWorld();
        var reach = 0;
        for (var c = 0; c < 8; c++) {
          var p = new this.T.Vector3(c & 1 ? d.half[0] : -d.half[0], c & 2 ? d.half[1] : -d.half[1],
            c & 4 ? d.half[2] : -d.half[2]).project(this.camera);
          reach = Math.max(reach, Math.abs(p.x), Math.abs(p.y));
        }
        if (!(reach > 0 && reach < 100)) { break; }
        dist *= Math.min(Math.max(reach / 0.85, 0.3), 3);
        this.camera.position.copy(dir).multiplyScalar(dist);
        this.controls.update();
      }
    }
    this.render();
  };

  View.prototype.setStage = function (stage) {
    if (!this.data.stages[stage]) { return; }
    this.stage = stage;
    this.el.setAttribute("data-stage", stage);
    if (!this.renderer) { return; }
    var g = this.geometryOf(stage);
    this.mesh.geometry = g.mesh;
    this.edges.geometry = g.edges;
    this.recolour();
  };

  View.prototype.recolour = function () {
    var key = this.metricSelect.value;
    var metric = this.data.metrics[key], st = metric && metric.stages[this.stage];
    if (!this.renderer || !st) { return; }
    var g = this.geometryOf(this.stage);
    var values = decode(st.values, Float32Array);
    var lo = Infinity, hi = -Infinity, i;
    for (i = 0; i < values.length; i++) {
      if (values[i] < lo) { lo = values[i]; }
      if (values[i] > hi) { hi = values[i]; }
    }
    var span = hi > lo ? hi - lo : 1;
    var faceRgb = new Float32Array(values.length * 3);
    for (i = 0; i < values.length; i++) {
      var rgb = st.constant ? hexToRgb(CONSTANT) : viridis((values[i] - lo) / span);
      faceRgb[i * 3] = srgbToLinear(rgb[0]);
      faceRgb[i * 3 + 1] = srgbToLinear(rgb[1]);
      faceRgb[i * 3 + 2] = srgbToLinear(rgb[2]);
    }
    var colours = g.mesh.getAttribute("color").array;
    for (var t = 0; t < g.triFace.length; t++) {
      var f = g.triFace[t] * 3;
      for (var j = 0; j < 3; j++) {
        var o = t * 9 + j * 3;
        colours[o] = faceRgb[f]; colours[o + 1] = faceRgb[f + 1]; colours[o + 2] = faceRgb[f + 2];
      }
    }
    g.mesh.getAttribute("color").needsUpdate = true;
    this.showLegend(metric, st);
    this.render();
  };

  View.prototype.showLegend = function (metric, st) {
    var parts = [];
    var name = document.createElement("b");
    name.textContent = metric.title + " (" + metric.unit + "), " + this.stage + ":";
    parts.push(name);
    if (st.constant) {
      var sw = document.createElement("span");
      sw.className = "v-swatch";
      var text = document.createElement("span");
      text.className = "v-constant";
      text.textContent = st.constant;
      parts.push(sw, text);
    } else {
      var lo = document.createElement("span"), ramp = document.createElement("span"),
        hi = document.createElement("span");
      lo.className = "v-lo"; lo.textContent = st.lo;
      ramp.className = "v-ramp";
      hi.className = "v-hi"; hi.textContent = st.hi;
      parts.push(lo, ramp, hi);
    }
    this.legend.replaceChildren.apply(this.legend, parts);
  };

  View.prototype.resize = function () {
    if (!this.renderer) { return; }
    var w = Math.max(this.host.clientWidth, 1), h = Math.max(this.host.clientHeight, 1);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.render();
  };

  View.prototype.render = function () {
    if (this.renderer) { this.renderer.render(this.scene, this.camera); }
  };

  // give the WebGL context back, keeping a still picture; a click (or scrolling here again) resumes
  View.prototype.pause = function () {
    if (!this.renderer) { return; }
    var url = null;
    try { this.render(); url = this.renderer.domElement.toDataURL("image/png"); } catch (e) { url = null; }
    this.resizer.disconnect();
    this.controls.dispose();
    for (var s in this.geometries) { this.geometries[s].mesh.dispose(); this.geometries[s].edges.dispose(); }
    this.material.dispose();
    this.lineMaterial.dispose();
    this.renderer.dispose();
    this.renderer.forceContextLoss();
    this.renderer = null;
    this.geometries = {};
    var button = document.createElement("button");
    button.type = "button";
    button.className = "v-start";
    if (url) { var img = document.createElement("img"); img.alt = ""; img.src = url; button.appendChild(img); }
    var label = document.createElement("span");
    label.textContent = "3D view paused (browsers allow a few at a time): click to resume";
    button.appendChild(label);
    this.host.replaceChildren(button);
    this.setState("paused");
  };

  var PQViewer = window.PQViewer = {
    data: {},
    views: views,
    live: live,
    MAX_LIVE: MAX_LIVE,
    add: function (id, data) { this.data[id] = data; },
    start: function (id) { return views[id] ? views[id].start() : Promise.reject(new Error("no view " + id)); }
  };

  function init() {
    var els = document.querySelectorAll(".viewer3d[data-view]");
    Array.prototype.forEach.call(els, function (el) { var v = new View(el); views[v.id] = v; });
    if (!("IntersectionObserver" in window)) { return; }  // a click still starts a view
    var observer = new IntersectionObserver(function (entries) {
      entries.forEach(function (entry) {
        var v = views[entry.target.getAttribute("data-view")];
        if (entry.isIntersecting && v && (v.state === "idle" || v.state === "paused")) { v.start(); }
      });
    }, { rootMargin: "50px 0px" });
    Array.prototype.forEach.call(els, function (el) { observer.observe(el); });
  }

  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", init);
  } else {
    init();
  }
})();
