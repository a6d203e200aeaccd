// fogcli tune: the page. No build step, no library: the server renders, the page asks.
"use strict";
const TOKEN = new URLSearchParams(location.search).get("token") || "";
const $ = (id) => document.getElementById(id);
const ov = { medium: {}, render: {} };   // what the page changed, as config sections
let lights = null;                      // the lights list once the page touches it
let st = null;                          // the server's state
let busy = false, pending = null, frames = 0;

async function api(path, body) {
  const opt = { headers: { "X-Fogcli-Token": TOKEN } };
  if (body !== undefined) {
    opt.method = "POST";
    opt.headers["Content-Type"] = "application/json";
    opt.body = JSON.stringify(body);
  }
  const r = await fetch(path, opt);
  if (!r.ok) {
    let msg = r.status + " " + r.statusText;
    try { msg = (await r.json()).error || msg; } catch (e) { /* not JSON */ }
    throw new Error(msg);
  }
  return r;
}

function status(text, error) {
  $("status").textContent = text;
  $("status").className = error ? "error" : "";
}

function overrides() {
  const o = {};
  if (Object.keys(ov.medium).length) o.medium = ov.medium;
  if (Object.keys(ov.render).length) o.render = ov.render;
  if (lights !== null) o.lights = lights;
  return o;
}

// visibility: a log slider over 2 % to 5000 % of the median depth
const VIS_LO = Math.log(2), VIS_HI = Math.log(5000);
const visToSlider = (p) => Math.round((Math.log(p) - VIS_LO) / (VIS_HI - VIS_LO) * 1000);
const sliderToVis = (v) => Math.exp(VIS_LO + (VIS_HI - VIS_LO) * v / 1000);
const AMB_LO = Math.log(1e-4), AMB_HI = Math.log(100);
const ambToSlider = (a) => Math.round((Math.log(Math.max(a, 1e-4)) - AMB_LO) / (AMB_HI - AMB_LO) * 1000);
const sliderToAmb = (v) => Math.exp(AMB_LO + (AMB_HI - AMB_LO) * v / 1000);
const fmt = (x) => Math.abs(x) >= 1000 ? String(Math.round(x)) : String(Number(Number(x).toPrecision(3)));

function srgbToLinear(c) { return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4); }

function showControls() {
  $("preset").innerHTML = "";
  for (const p of st.presets) {
    const o = document.createElement("option");
    o.value = o.textContent = p;
    $("preset").appendChild(o);
  }
  $("preset").value = st.preset;
  const vis = parseFloat(st.visibility);
  $("visibility").value = visToSlider(vis);
  $("visibility-out").textContent = fmt(vis) + " % (" + fmt(vis / 100 * st.median_depth) + " m)";
  $("albedo").value = st.albedo; $("albedo-out").textContent = fmt(st.albedo);
  $("asymmetry").value = st.asymmetry; $("asymmetry-out").textContent = fmt(st.asymmetry);
  const auto = st.ambient === "auto";
  $("ambient-auto").checked = auto;
  const amb = auto ? 0 : Math.max(...st.ambient);
  $("ambient").value = ambToSlider(amb); $("ambient-out").textContent = auto ? "auto" : fmt(amb);
  const exp = st.density.find((d) => d.type === "exponential");
  $("height-on").checked = !!exp;
  if (exp) { $("falloff").value = exp.falloff; $("height").value = exp.offset[1]; }
  const noise = st.density.find((d) => d.type === "noise");
  $("noise-on").checked = !!noise;
  if (noise) { $("amplitude").value = noise.amplitude; $("scale").value = scaleToSlider(noise.scale); }
  for (let i = 0; i < 3; i++) {
    $("abs-" + i).value = Number(st.absorption[i].toPrecision(4));
    $("sca-" + i).value = Number(st.scattering[i].toPrecision(4));
  }
  readControls();
  $("border").value = st.border;
  if (lights === null) showLights(st.lights); else showLights(lights);
}

function showLights(list) {
  const ol = $("lights");
  ol.innerHTML = "";
  list.forEach((l, i) => {
    const li = document.createElement("li");
    if (l.type !== "point") { li.textContent = l.type + " light (from the config)"; ol.appendChild(li); return; }
    const p = l.position.map(fmt).join(", ");
    li.innerHTML = `point at (${p}) m <button data-i="${i}">remove</button>
      <label>Intensity <output>${fmt(l.intensity[0])}</output>
      <input type="range" min="0" max="1000" step="1" data-i="${i}" class="intensity"></label>`;
    const r = li.querySelector("input");
    const base = l._base || l.intensity[0];
    l._base = base;
    r.value = Math.round((Math.log(l.intensity[0] / base) / Math.log(100) + 1) * 500);
    r.addEventListener("input", () => {
      const v = base * Math.pow(100, r.value / 500 - 1);
      l.intensity = [v, v, v].map((x) => Number(x.toPrecision(4)));
      li.querySelector("output").textContent = fmt(l.intensity[0]);
      changed(false);
    });
    r.addEventListener("change", () => changed(true));
    li.querySelector("button").addEventListener("click", () => {
      list.splice(i, 1); lights = list; showLights(list); changed(true);
    });
    ol.appendChild(li);
  });
}

function lightsForServer() {
  return lights.map((l) => { const c = Object.assign({}, l); delete c._base; return c; });
}

function readControls() {
  const vis = sliderToVis(+$("visibility").value);
  $("visibility-out").textContent = fmt(vis) + " % (" + fmt(vis / 100 * st.median_depth) + " m)";
  $("albedo-out").textContent = fmt($("albedo").value);
  $("asymmetry-out").textContent = fmt($("asymmetry").value);
  $("falloff-out").textContent = fmt($("falloff").value);
  $("height-out").textContent = fmt($("height").value);
  $("amplitude-out").textContent = fmt($("amplitude").value);
  $("scale-out").textContent = fmt(sliderToScale(+$("scale").value));
}

// the patches' size: a log slider over 1 % to 100 % of the median depth
const scaleToSlider = (m) => Math.round(Math.log(m / (0.01 * st.median_depth)) / Math.log(100) * 1000);
const sliderToScale = (v) => Number((0.01 * st.median_depth * Math.pow(100, v / 1000)).toPrecision(3));

// the medium's density: a height fog or an even one, with noise patches in a box around
// what the camera sees (to twice the median depth)
function density() {
  const d = $("height-on").checked
    ? [{ type: "exponential", falloff: +$("falloff").value, offset: [0, +$("height").value, 0] }]
    : [{ type: "homogeneous" }];
  if ($("noise-on").checked) {
    // two octaves, and a march of about 32 steps through the box: a frame in a fraction of a
    // second (the defaults, four octaves and steps of a quarter of the finest, take seconds)
    const m = st.median_depth, scale = sliderToScale(+$("scale").value);
    const r = (x) => Number(x.toPrecision(4));
    d.push({ type: "noise", amplitude: +$("amplitude").value, scale: scale, octaves: 2, step: r(Math.max(scale / 4, m / 16)),
             shape: "box", center: [0, 0, r(-m)], size: [4 * m, 4 * m, 2 * m].map(r), seed: 1 });
  }
  return d;
}

function bind(id, apply) {
  const el = $(id);
  el.addEventListener("input", () => { readControls(); apply(); changed(false); });
  el.addEventListener("change", () => { readControls(); apply(); changed(true); });
}

// a preview while a control moves (the newest ask waits for the one in flight), full size on release
function changed(full) {
  pending = full ? "full" : (pending === "full" ? "full" : "preview");
  if (!busy) pump();
}

async function pump() {
  if (pending === null) return;
  const size = pending;
  pending = null;
  busy = true;
  try {
    const t0 = performance.now();
    const body = { overrides: overridesForServer(), size: size, show: $("show").value, exposure: +$("exposure").value };
    const r = await api("/api/render", body);
    const blob = await r.blob();
    await setImage($("after"), blob, size);
    // from the ask to the frame shown: what tools/tune_latency.py reads while it drags a slider
    (window.tuneLatencies = window.tuneLatencies || []).push([size, performance.now() - t0, +r.headers.get("x-render-ms")]);
    frames += 1;
    $("after").dataset.frames = frames;
    $("after").dataset[size] = (+$("after").dataset[size] || 0) + 1;
    status(`${size} ${size === "full" ? st.width + "x" + st.height : st.preview.join("x")}: ` +
           `${r.headers.get("x-render-ms")} ms`);
    if (size === "full" || $("before").dataset.size !== size || $("before").dataset.exposure !== $("exposure").value) {
      await loadBefore(size);
    }
  } catch (e) {
    status(e.message, true);
  }
  busy = false;
  if (pending !== null) pump();
}

function overridesForServer() {
  const o = overrides();
  if (o.lights) o.lights = lightsForServer();
  return o;
}

function setImage(img, blob, size) {   // resolves once the new frame is decoded and shown
  const old = img.src;
  img.src = URL.createObjectURL(blob);
  img.dataset.size = size;
  if (old.startsWith("blob:")) URL.revokeObjectURL(old);
  return img.decode().catch(() => {});
}

async function loadBefore(size) {
  const ex = $("exposure").value;
  const r = await api(`/api/image?which=input&size=${size}&exposure=${ex}`);
  await setImage($("before"), await r.blob(), size);
  $("before").dataset.exposure = ex;
}

async function reshow() {     // exposure or AOV: the last frames again, no new render
  const size = $("after").dataset.size || "preview";
  try {
    const ex = $("exposure").value;
    const r = await api(`/api/image?which=${$("show").value}&size=${size}&exposure=${ex}`);
    setImage($("after"), await r.blob(), size);
    await loadBefore(size);
  } catch (e) {
    status(e.message, true);
  }
}

function pixelOf(ev) {
  const rect = $("after").getBoundingClientRect();
  return { x: (ev.clientX - rect.left) / rect.width * st.width, y: (ev.clientY - rect.top) / rect.height * st.height };
}

async function clicked(ev) {
  const p = pixelOf(ev);
  try {
    if ($("place-light").checked) {
      const l = await (await api("/api/light", p)).json();
      if (lights === null) lights = st.lights.slice();
      lights.push(l);
      showLights(lights);
      changed(true);
      return;
    }
    const q = await (await api(`/api/pixel?x=${p.x}&y=${p.y}`)).json();
    const v = (a) => a ? a.map(fmt).join(", ") : "-";
    $("pixel").textContent = `pixel (${q.x}, ${q.y}): depth ${fmt(q.depth)} m; in ${v(q.input)}; out ${v(q.output)}` +
      (q.of ? ` (${q.of})` : "");
  } catch (e) {
    status(e.message, true);
  }
}

async function save() {
  try {
    const r = await (await api("/api/save", { overrides: overridesForServer() })).json();
    $("command").textContent = `saved ${r.yaml}\nand ${r.output}\n\n${r.command}`;
    $("command").dataset.saved = "1";
  } catch (e) {
    status(e.message, true);
  }
}

async function start() {
  st = await (await api("/api/state")).json();
  showControls();
  bind("visibility", () => { ov.medium.visibility = String(Number(sliderToVis(+$("visibility").value).toPrecision(4))) + "%"; });
  bind("albedo", () => { ov.medium.albedo = +$("albedo").value; });
  bind("asymmetry", () => { ov.medium.asymmetry = +$("asymmetry").value; });
  const ambient = () => {
    if ($("ambient-auto").checked) { ov.medium.ambient = "auto"; $("ambient-out").textContent = "auto"; return; }
    const hex = $("ambient-colour").value, k = sliderToAmb(+$("ambient").value);
    const c = [1, 3, 5].map((i) => srgbToLinear(parseInt(hex.substr(i, 2), 16) / 255));
    const m = Math.max(...c, 1e-6);
    ov.medium.ambient = c.map((x) => Number((x / m * k).toPrecision(4)));
    $("ambient-out").textContent = fmt(k);
  };
  bind("ambient", ambient); bind("ambient-colour", ambient); bind("ambient-auto", ambient);
  const dens = () => { ov.medium.density = density(); };
  for (const id of ["height-on", "falloff", "height", "noise-on", "amplitude", "scale"]) bind(id, dens);
  const coefficients = () => {
    ov.medium.absorption = [0, 1, 2].map((i) => Math.max(0, +$("abs-" + i).value || 0));
    ov.medium.scattering = [0, 1, 2].map((i) => Math.max(0, +$("sca-" + i).value || 0));
    delete ov.medium.albedo;      // it would share their sum out again
  };
  for (let i = 0; i < 3; i++) { bind("abs-" + i, coefficients); bind("sca-" + i, coefficients); }
  bind("border", () => { ov.render.border = $("border").value; });
  $("preset").addEventListener("change", async () => {
    st = await (await api("/api/preset", { name: $("preset").value })).json();
    ov.medium = {}; ov.render = {};
    showControls();
    changed(true);
  });
  $("exposure").addEventListener("input", () => { $("exposure-out").textContent = $("exposure").value; reshow(); });
  $("show").addEventListener("change", reshow);
  $("split").addEventListener("input", () => {
    $("after").style.clipPath = `inset(0 0 0 ${$("split").value}%)`;
  });
  $("after").addEventListener("click", clicked);
  $("save").addEventListener("click", save);
  document.body.dataset.ready = "1";
  changed(true);
}

start().catch((e) => status(e.message, true));
