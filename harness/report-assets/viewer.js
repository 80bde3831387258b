// scanbench report: the 3D viewer (harness/src/results/report_viewer.h writes its data).
// Loaded as a module through the page's import map (three.js inlined as blob: URLs); renders on
// demand (no animation loop). Per dataset group: one canvas, one viewport per method, one
// camera pose shared by every view (synchronised on each change).
//
// Test hooks (window.scanbenchViewer, and the page's #hash, key=value pairs joined by &):
//   shade=0        no lighting and no eye-dome lighting: pixels are colour-map entries
//   cam=az,el,d    camera at azimuth az and elevation el (degrees) around the ground truth's
//                  centre, at d x its diagonal, in every group
//   pick=g,v,k     pick point k (index into the view's shown points) of view v of group g
//   frames=N       time N renders of group 0 (status "frame_ms")
//   all=1          build every group at once (else one per task after the load event)
//   truth=1, scan=1, outliers=1   show these at start
//   point=i        show sweep point i (the slider's position)
//   colour=signed  colour by the signed error (the diverging map) from the start
//   click=g,x,y    after building, send group g's canvas a pointer down and up at CSS pixel
//                  (x, y) of the canvas (the mouse's path to a pick)
//   toggle=key     after building, click the checkbox of key (truth, scan, outliers) in every
//                  group (the user's path to a toggle)
// The status (JSON in #sb-viewer-status) lists per group and view the canvas rectangles and
// camera matrices, the pick, the timing (frame_ms; ready_ms: from navigation to the viewer
// drawn), resources the page loaded and any error.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const statusEl = document.getElementById('sb-viewer-status');
const status = { ready: false, errors: [], groups: [] };
const writeStatus = () => { statusEl.textContent = JSON.stringify(status); };
window.addEventListener('error', (e) => { status.errors.push(String(e.message)); writeStatus(); });
document.addEventListener('securitypolicyviolation', (e) => {
  status.errors.push('CSP: ' + e.blockedURI); writeStatus();
});

const opts = {};
for (const kv of decodeURIComponent(location.hash.slice(1)).split('&')) {
  const [k, v] = kv.split('=');
  if (k) opts[k] = v === undefined ? '1' : v;
}
const shade = opts.shade !== '0';
const colourMode = opts.colour === 'signed' ? 'signed' : 'magnitude';

function decode(b64, Type) {
  const bin = atob(b64);
  const u8 = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; ++i) u8[i] = bin.charCodeAt(i);
  return new Type(u8.buffer);
}

THREE.ColorManagement.enabled = false;  // colours are written as given (sRGB bytes)
const data = JSON.parse(document.getElementById('sb-viewer-data').textContent);
data.groups = [];  // each parsed from its own element when built
function texture(table) {
  const bytes = new Uint8Array(256 * 4);
  table.forEach((c, i) => { bytes.set([c[0], c[1], c[2], 255], 4 * i); });
  const t = new THREE.DataTexture(bytes, 256, 1, THREE.RGBAFormat);
  t.magFilter = t.minFilter = THREE.NearestFilter;
  t.wrapS = t.wrapT = THREE.ClampToEdgeWrapping;
  t.needsUpdate = true;
  return t;
}
const cmaps = { magnitude: texture(data.colormap), signed: texture(data.colormap_signed) };

// Colour: viridis entry floor(256 t), t = |E| / saturation (the texture's nearest texel); with
// signed on, the diverging map's entry at t = (1 + E / saturation) / 2, clamped; or a flat
// colour. Lighting from the normals (headlight, two-sided) when shading is on.
const vertexShader = `
  uniform float size, errScale, signedMode;
  attribute vec3 nrm;
  attribute float err;
  varying float vT, vLight;
  void main() {
    vec4 mv = modelViewMatrix * vec4(position, 1.0);
    gl_Position = projectionMatrix * mv;
    gl_PointSize = size;
    vT = signedMode > 0.5 ? clamp(0.5 + 0.5 * err * errScale, 0.0, 1.0)
                          : clamp(abs(err) * errScale, 0.0, 1.0);
    vLight = 1.0;
  #ifdef HAS_NORMALS
    vLight = 0.3 + 0.7 * abs(dot(normalize(normalMatrix * nrm), normalize(-mv.xyz)));
  #endif
  }`;
const fragmentShader = `
  uniform sampler2D cmap;
  uniform vec3 flatColor;
  varying float vT, vLight;
  void main() {
  #ifdef IS_POINTS
    vec2 d = gl_PointCoord - 0.5;
    if (dot(d, d) > 0.25) discard;
  #endif
  #ifdef HAS_ERR
    vec3 c = texture2D(cmap, vec2(vT, 0.5)).rgb;
  #else
    vec3 c = flatColor;
  #endif
    gl_FragColor = vec4(c * vLight, 1.0);
  }`;

function material(cloud, isPoints, size, flat) {
  const defines = {};
  if (isPoints) defines.IS_POINTS = '';
  if (cloud.err) defines.HAS_ERR = '';
  if (shade && (cloud.nrm || !isPoints)) defines.HAS_NORMALS = '';
  return new THREE.ShaderMaterial({
    defines, vertexShader, fragmentShader,
    uniforms: {
      cmap: { value: cmaps[colourMode] }, size: { value: size },
      signedMode: { value: colourMode === 'signed' ? 1 : 0 },
      errScale: { value: cloud.err ? cloud.err_scale / data.groups[cloud.group].saturation : 0 },
      flatColor: { value: new THREE.Color(flat || 0x999999) },
    },
    side: THREE.DoubleSide,
  });
}

/// Geometry of a cloud (positions in [0,1]^3 of the group's cube; the object scales them).
function geometry(cloud) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(decode(cloud.pos, Uint16Array), 3, true));
  if (cloud.err) g.setAttribute('err', new THREE.BufferAttribute(decode(cloud.err, Int16Array), 1, false));
  if (cloud.nrm) g.setAttribute('nrm', new THREE.BufferAttribute(decode(cloud.nrm, Int8Array), 3, true));
  if (cloud.tri || cloud.tri16) {
    g.setIndex(new THREE.BufferAttribute(cloud.tri16 ? decode(cloud.tri16, Uint16Array) : decode(cloud.tri, Uint32Array), 1));
    g.computeVertexNormals();
    g.setAttribute('nrm', g.getAttribute('normal'));
  }
  if (!cloud.err) g.setAttribute('err', new THREE.BufferAttribute(new Int16Array(cloud.count), 1));
  if (!g.getAttribute('nrm')) g.setAttribute('nrm', new THREE.BufferAttribute(new Int8Array(3 * cloud.count), 3, true));
  return g;
}

function object(cloud, gd, size, flat) {
  const geo = geometry(cloud);
  const isPoints = cloud.kind !== 'mesh';
  const obj = isPoints ? new THREE.Points(geo, material(cloud, true, size, flat))
                       : new THREE.Mesh(geo, material(cloud, false, size, flat));
  obj.position.fromArray(gd.lo);
  obj.scale.setScalar(gd.size);
  obj.frustumCulled = false;
  return obj;
}

// Eye-dome lighting (Boucheny 2009): darkens a pixel by how much nearer its neighbours are, on
// log depth; background neighbours count as 0.005 log2 units nearer (a light outline that
// leaves a lone point its colour).
const edlShader = {
  uniforms: { tColor: { value: null }, tDepth: { value: null }, texel: { value: new THREE.Vector2() },
              near: { value: 1 }, far: { value: 100 }, strength: { value: 1.2 } },
  vertexShader: 'varying vec2 vUv; void main(){ vUv = uv; gl_Position = vec4(position.xy, 0.0, 1.0); }',
  fragmentShader: `
    uniform sampler2D tColor, tDepth; uniform vec2 texel; uniform float near, far, strength;
    varying vec2 vUv;
    float logz(float d) { return log2(near * far / (far - d * (far - near))); }
    void main() {
      vec4 c = texture2D(tColor, vUv);
      float d0 = texture2D(tDepth, vUv).x;
      if (d0 >= 1.0) { gl_FragColor = c; return; }
      float l0 = logz(d0), sum = 0.0;
      for (int i = 0; i < 8; ++i) {
        float a = float(i) * 0.785398;
        float d = texture2D(tDepth, vUv + 1.5 * texel * vec2(cos(a), sin(a))).x;
        float l = d >= 1.0 ? l0 - 0.005 : logz(d);
        sum += max(0.0, l0 - l);
      }
      gl_FragColor = vec4(c.rgb * exp(-sum / 8.0 * 60.0 * strength), 1.0);
    }`,
};

class GroupViewer {
  constructor(root, gd, gi) {
    this.gd = gd; this.gi = gi; this.root = root; this.colour = colourMode;
    // One panel (viewport) per variant; a swept variant's sweep points share its panel and the
    // slider picks which one shows (index i: each variant's i-th point, or its last).
    const byVariant = new Map();
    gd.views.forEach((v, i) => {
      const key = v.variant === undefined ? v.label : v.variant;
      if (!byVariant.has(key)) byVariant.set(key, []);
      byVariant.get(key).push(i);
    });
    this.panels = [...byVariant.values()].map((members) => ({ members }));
    const n = this.panels.length;
    this.cols = Math.min(3, n);
    this.rows = Math.ceil(n / this.cols);
    const avail = Math.max(600, Math.min(1350, root.clientWidth || 1200));
    this.vw = Math.floor(avail / this.cols);
    this.vh = Math.round(this.vw * (this.cols === 1 ? 0.6 : 0.8));
    this.W = this.cols * this.vw; this.H = this.rows * this.vh;
    this.canvas = root.querySelector('canvas');
    const stage = root.querySelector('.sb-stage');
    stage.style.position = 'relative';
    stage.style.width = this.W + 'px';
    this.canvas.style.width = this.W + 'px';
    this.canvas.style.height = this.H + 'px';
    this.canvas.style.display = 'block';
    this.canvas.style.border = '1px solid #ccc';
    this.renderer = new THREE.WebGLRenderer({ canvas: this.canvas, antialias: false, preserveDrawingBuffer: true });
    this.dpr = Math.min(window.devicePixelRatio || 1, 2);
    this.renderer.setPixelRatio(this.dpr);
    this.renderer.setSize(this.W, this.H, false);
    this.renderer.autoClear = false;
    this.renderer.setClearColor(0xffffff, 1);
    const r = gd.diagonal;
    this.master = new THREE.PerspectiveCamera(30, this.vw / this.vh, 0.01 * r, 30 * r);
    this.center = new THREE.Vector3().fromArray(gd.center);
    this.setPose(35, 20, 1.9);
    this.controls = new OrbitControls(this.master, this.canvas);
    this.controls.target.copy(this.center);
    this.controls.maxDistance = 10 * r;
    this.controls.update();
    this.controls.addEventListener('change', () => this.render());

    // Point size: about 1.5 x the screen spacing of a surface's visible half filling a quarter
    // of the view, so that splats close up (2 to 8 pixels).
    const most = Math.max(1, ...gd.views.map((v) => v.count));
    const size = Math.max(2, Math.min(8, Math.round(1.5 * Math.sqrt(this.vw * this.vh / 4 / (most / 2))))) * this.dpr;
    this.views = [];
    this.panels.forEach((panel, pi) => {
      panel.scene = new THREE.Scene();
      panel.cam = this.master.clone();
      panel.x = (pi % this.cols) * this.vw;
      panel.y = Math.floor(pi / this.cols) * this.vh;
      panel.extras = {};
      for (const [key, flat, s] of [['truth', 0xc8c8c8, size], ['scan', 0x8c8c8c, size],
                                     ['outliers', 0xd01c8b, size + this.dpr]]) {
        if (!gd[key]) continue;
        gd[key].group = gi;
        const o = object(gd[key], gd, s, flat);
        o.visible = opts[key] === '1';
        panel.scene.add(o);
        panel.extras[key] = o;
      }
      panel.label = document.createElement('div');
      panel.label.style.cssText = `position:absolute;left:${panel.x + 6}px;top:${panel.y + 4}px;` +
        'font-size:12px;background:rgba(255,255,255,0.8);padding:1px 4px;pointer-events:none';
      stage.appendChild(panel.label);
      for (const vi of panel.members) {
        const v = gd.views[vi];
        v.group = gi;
        const out = object(v, gd, size);
        panel.scene.add(out);
        this.views[vi] = { data: v, out, panel };
      }
    });
    this.show(Number(opts.point || 0));
    this.controlsUi(root.querySelector('.sb-controls'));
    this.setColour(this.colour);
    if (shade) {
      const w = this.W * this.dpr, h = this.H * this.dpr;
      this.target = new THREE.WebGLRenderTarget(w, h, { depthTexture: new THREE.DepthTexture(w, h) });
      this.post = new THREE.ShaderMaterial({
        uniforms: THREE.UniformsUtils.clone(edlShader.uniforms),
        vertexShader: edlShader.vertexShader, fragmentShader: edlShader.fragmentShader,
        depthTest: false, depthWrite: false });
      this.post.uniforms.tColor.value = this.target.texture;
      this.post.uniforms.tDepth.value = this.target.depthTexture;
      this.post.uniforms.texel.value.set(1 / w, 1 / h);
      this.post.uniforms.near.value = this.master.near;
      this.post.uniforms.far.value = this.master.far;
      this.postScene = new THREE.Scene();
      const quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), this.post);
      quad.frustumCulled = false;
      this.postScene.add(quad);
      this.postCam = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
    }
    this.pickInfo = root.querySelector('.sb-pick');
    this.canvas.addEventListener('pointerdown', (e) => { this.down = [e.clientX, e.clientY]; });
    this.canvas.addEventListener('pointerup', (e) => {
      if (!this.down || Math.hypot(e.clientX - this.down[0], e.clientY - this.down[1]) > 3) return;
      const rc = this.canvas.getBoundingClientRect();
      this.pickAt(e.clientX - rc.left, e.clientY - rc.top);
    });
  }

  controlsUi(el) {
    const add = (key, text) => {
      if (!this.gd[key]) return;
      const l = document.createElement('label');
      l.style.marginRight = '1em';
      const c = document.createElement('input');
      c.type = 'checkbox';
      c.className = 'sb-toggle-' + key;
      c.checked = opts[key] === '1';
      c.addEventListener('change', () => {
        for (const p of this.panels) p.extras[key].visible = c.checked;
        this.render();
      });
      l.append(c, ' ' + text + ` (${this.gd[key].total.toLocaleString('en')})`);
      el.appendChild(l);
    };
    const sel = document.createElement('select');
    sel.className = 'sb-colour';
    for (const [value, text] of [['magnitude', 'colour: |E| (viridis)'],
                                 ['signed', 'colour: signed E (cool-warm: - inside, + outside)']]) {
      const o = document.createElement('option');
      o.value = value; o.textContent = text;
      sel.appendChild(o);
    }
    sel.value = this.colour;
    sel.style.marginRight = '1em';
    sel.addEventListener('change', () => { this.setColour(sel.value); this.render(); });
    el.appendChild(sel);
    add('truth', 'ground truth');
    add('scan', 'noisy scan');
    add('outliers', "scan's outliers");
    const points = Math.max(...this.panels.map((p) => p.members.length));
    if (points > 1) {
      const l = document.createElement('label');
      l.style.marginRight = '1em';
      const r = document.createElement('input');
      r.type = 'range'; r.min = 0; r.max = points - 1; r.step = 1; r.value = this.point;
      r.className = 'sb-sweep';
      r.addEventListener('input', () => { this.show(Number(r.value)); this.render(); });
      l.append('sweep point ', r);
      el.appendChild(l);
    }
    const reset = document.createElement('button');
    reset.textContent = 'reset view';
    reset.addEventListener('click', () => { this.setPose(35, 20, 1.9); this.controls.update(); this.render(); });
    el.appendChild(reset);
  }

  /// Colours every view by `mode` (magnitude or signed) and shows that mode's colour bar.
  setColour(mode) {
    this.colour = mode;
    for (const v of this.views) {
      v.out.material.uniforms.cmap.value = cmaps[mode];
      v.out.material.uniforms.signedMode.value = mode === 'signed' ? 1 : 0;
    }
    for (const bar of this.root.querySelectorAll('.colour-bar'))
      bar.style.display = bar.classList.contains(mode) ? '' : 'none';
  }

  /// Shows sweep point i of every panel (its last when it has fewer) and labels the panels.
  show(i) {
    this.point = Math.max(0, i);
    for (const p of this.panels) {
      p.shown = p.members[Math.min(this.point, p.members.length - 1)];
      for (const vi of p.members) this.views[vi].out.visible = vi === p.shown;
      const v = this.gd.views[p.shown];
      p.label.textContent = `${v.label}: ${v.count.toLocaleString('en')} of ${v.total.toLocaleString('en')} ` +
        (v.kind === 'mesh' ? 'vertices' : 'points') + (v.note ? ` (${v.note})` : '') +
        (p.members.length > 1 ? ` [sweep point ${Math.min(this.point, p.members.length - 1) + 1} of ${p.members.length}]` : '');
    }
  }

  setPose(azDeg, elDeg, dist) {
    const az = THREE.MathUtils.degToRad(azDeg), el = THREE.MathUtils.degToRad(elDeg);
    const d = dist * this.gd.diagonal;
    this.master.position.set(this.center.x + d * Math.cos(el) * Math.sin(az), this.center.y + d * Math.sin(el),
                             this.center.z + d * Math.cos(el) * Math.cos(az));
    this.master.up.set(0, 1, 0);
    this.master.lookAt(this.center);
    if (this.controls) this.controls.target.copy(this.center);
  }

  /// Viewport and scissor (CSS px, y up) on the canvas or, with shading, on the render target
  /// (device px: a render target keeps its own viewport).
  region(x, y, w, h, scissor) {
    const rr = this.renderer, t = this.target;
    if (t) {
      const s = this.dpr;
      t.viewport.set(x * s, y * s, w * s, h * s);
      if (scissor) t.scissor.set((x + 1) * s, (y + 1) * s, (w - 2) * s, (h - 2) * s);
      t.scissorTest = scissor;
      rr.setRenderTarget(t);
    } else {
      rr.setRenderTarget(null);
      rr.setViewport(x, y, w, h);
      if (scissor) rr.setScissor(x + 1, y + 1, w - 2, h - 2);
      rr.setScissorTest(scissor);
    }
  }

  render() {
    const rr = this.renderer;
    this.region(0, 0, this.W, this.H, false);
    rr.clear();
    for (const p of this.panels) {
      p.cam.position.copy(this.master.position);
      p.cam.quaternion.copy(this.master.quaternion);
      p.cam.aspect = this.vw / this.vh;
      p.cam.updateProjectionMatrix();
      p.cam.updateMatrixWorld(true);
      this.region(p.x, this.H - p.y - this.vh, this.vw, this.vh, true);
      rr.render(p.scene, p.cam);
    }
    if (this.target) {
      rr.setRenderTarget(null);
      rr.setScissorTest(false);
      rr.setViewport(0, 0, this.W, this.H);
      rr.render(this.postScene, this.postCam);
    }
  }

  /// The shown point under canvas pixel (x, y) (CSS px) of the view there: nearest on screen
  /// within 8 px, then nearest to the camera.
  pickAt(x, y) {
    const p = this.panels.find((w) => x >= w.x && x < w.x + this.vw && y >= w.y && y < w.y + this.vh);
    if (!p) return null;
    const v = this.views[p.shown];
    const pos = v.out.geometry.getAttribute('position');
    const q = new THREE.Vector3();
    let best = -1, bestD = 64, bestZ = Infinity;
    for (let k = 0; k < pos.count; ++k) {
      q.fromBufferAttribute(pos, k).applyMatrix4(v.out.matrixWorld).project(p.cam);
      if (q.z < -1 || q.z > 1) continue;
      const sx = p.x + (q.x + 1) / 2 * this.vw, sy = p.y + (1 - q.y) / 2 * this.vh;
      const d = (sx - x) ** 2 + (sy - y) ** 2;
      if (d < bestD - 1e-9 || (d <= bestD && q.z < bestZ)) { best = k; bestD = d; bestZ = q.z; }
    }
    return best < 0 ? null : this.pick(p.shown, best);
  }

  /// Point k of view vi: its index in the output file, error and coordinates (mesh units, the
  /// ground truth's frame plus its origin).
  pick(vi, k) {
    const v = this.views[vi], d = v.data, gd = this.gd;
    const pos = v.out.geometry.getAttribute('position');
    const xyz = [0, 1, 2].map((a) => gd.lo[a] + pos.getComponent(k, a) * gd.size + gd.origin[a]);
    const err = v.out.geometry.getAttribute('err').getX(k) * (d.err_scale || 0);
    const index = Math.floor(k * d.total / d.count);
    const p = v.panel, q = new THREE.Vector3().fromBufferAttribute(pos, k).applyMatrix4(v.out.matrixWorld).project(p.cam);
    const screen = [p.x + (q.x + 1) / 2 * this.vw, p.y + (1 - q.y) / 2 * this.vh];  // CSS px of the canvas
    const res = { group: this.gi, view: vi, job: d.job, k, index, error: err, error_rel: err / gd.diagonal, xyz, screen };
    const fmt = (x) => Number(x).toPrecision(4);
    this.pickInfo.textContent = `${d.label}, point ${index} of ${d.total}: ` +
      (d.kind === 'mesh' ? 'signed distance ' : 'E = ') + `${fmt(err)} (${fmt(err / gd.diagonal)} x diagonal; ` +
      `colour saturates at ${fmt(gd.saturation)}) at (${xyz.map(fmt).join(', ')})`;
    status.pick = res;
    writeStatus();
    return res;
  }

  /// Milliseconds per frame over n renders, each finished (readPixels waits for the GPU).
  time(n) {
    const px = new Uint8Array(4), gl = this.renderer.getContext();
    this.render();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    const t0 = performance.now();
    for (let i = 0; i < n; ++i) {
      this.setPose(35 + 360 * i / n, 20, 1.9);
      this.render();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    }
    return (performance.now() - t0) / n;
  }

  describe() {
    const rc = this.canvas.getBoundingClientRect();
    const extras = {};
    for (const key of Object.keys(this.panels[0].extras))
      extras[key] = this.panels.map((p) => p.extras[key].visible);
    return {
      label: this.gd.label, colour: this.colour, extras,
      rect: [rc.left, rc.top, rc.width, rc.height],
      views: this.views.map((v) => ({
        label: v.data.label, count: v.data.count, total: v.data.total, shown: v.out.visible,
        rect: [rc.left + v.panel.x, rc.top + v.panel.y, this.vw, this.vh],
        camera: v.panel.cam.matrixWorld.elements.map((x) => Math.round(x * 1e6) / 1e6),
      })),
    };
  }
}

// The page opens without waiting for WebGL: after the load event the groups are built and drawn
// one per task, a group whose canvas comes within a screen of the window first; all=1 in the
// hash builds every group at once, before the status says ready.
const viewers = [];
const roots = [...document.querySelectorAll('.sb-viewer')];
function build(root) {
  const gi = Number(root.dataset.group);
  if (viewers[gi]) return viewers[gi];
  data.groups[gi] = JSON.parse(document.getElementById('sb-viewer-group-' + gi).textContent);
  const v = new GroupViewer(root, data.groups[gi], gi);
  viewers[gi] = v;
  if (opts.cam) {
    const [az, el, d] = opts.cam.split(',').map(Number);
    v.setPose(az, el, d);
    v.controls.update();
  }
  v.render();
  status.groups[gi] = v.describe();
  status.built_ms[gi] = performance.now();
  status.points[gi] = v.views.reduce((s, w) => s + w.data.count, 0);
  return v;
}
function guarded(f) {
  try { f(); } catch (e) { status.errors.push(String(e && e.stack || e)); }
  writeStatus();
}
status.points = [];
status.built_ms = [];
guarded(() => {
  if (opts.all === '1') {
    roots.forEach(build);
  } else {
    // After the page has loaded: one group per task in page order (the page stays responsive),
    // a group coming near the window first.
    const queue = [...roots];
    const next = () => guarded(() => {
      const r = queue.shift();
      if (!r) return;
      build(r);
      setTimeout(next, 0);
    });
    if ('IntersectionObserver' in window) {
      const io = new IntersectionObserver((entries) => guarded(() => {
        for (const e of entries) {
          if (!e.isIntersecting) continue;
          io.unobserve(e.target);
          build(e.target);
        }
      }), { rootMargin: '100% 0px' });
      roots.forEach((r) => io.observe(r));
    }
    const start = () => setTimeout(next, 0);
    if (document.readyState === 'complete') start(); else window.addEventListener('load', start);
  }
  if (opts.toggle) {
    roots.forEach((r) => {
      const v = build(r);
      const box = r.querySelector('.sb-toggle-' + opts.toggle);
      if (box) box.click();
      status.groups[v.gi] = v.describe();
    });
  }
  if (opts.click) {
    const [g, x, y] = opts.click.split(',').map(Number);
    const v = build(roots[g]), rc = v.canvas.getBoundingClientRect();
    const at = { clientX: rc.left + x, clientY: rc.top + y, bubbles: true, pointerId: 1, isPrimary: true, button: 0 };
    v.canvas.dispatchEvent(new PointerEvent('pointerdown', at));
    v.canvas.dispatchEvent(new PointerEvent('pointerup', at));
    status.clicked = status.pick || null;
  }
  if (opts.pick) {
    const [g, v, k] = opts.pick.split(',').map(Number);
    build(roots[g]).pick(v, k);
  }
  if (opts.frames) status.frame_ms = build(roots[0]).time(Number(opts.frames));
  status.resources = performance.getEntriesByType('resource').map((e) => e.name);
  status.ready = true;
  status.ready_ms = performance.now();  // since the navigation started
});
window.scanbenchViewer = {
  viewers, status, build: (g) => build(roots[g]),
  render: () => viewers.forEach((v) => v && v.render()),
};
