// loadpath load-case editor: the page.  Our own code, no libraries, no request outside this server.
// The case is held as the TOML file's tables ({version, frame, material, supports, loads, toolpath});
// the server evaluates it with loadpath's own selector code and answers what each selector picks.
// One file of about 670 lines on purpose: the page loads exactly one script of its own (the
// Content-Security-Policy allows nothing else, and there is no bundler); its sections are set-up,
// drawing and picking, the item forms, material and [toolpath], the server's answers, load
// arrows, box drag, and solve/save.
"use strict";

const SVGNS = "http://www.w3.org/2000/svg";
const S = {
  part: null, frame: "bed", c: null, layer: 0, picked: null, features: [],
  resolved: null, solved: null, materials: [], toolpath: [], timer: null, seq: 0,
};
const $ = (id) => document.getElementById(id);

function el(tag, attrs = {}, text = null) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) if (v !== null && v !== undefined) e.setAttribute(k, v);
  if (text !== null) e.textContent = text;
  return e;
}
function sv(tag, attrs = {}) {
  const e = document.createElementNS(SVGNS, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  return e;
}
const fmt = (v, d = 2) => Number(v).toFixed(d);
const round = (v, d = 6) => Math.round(v * 10 ** d) / 10 ** d;
const pts = (cs) => cs.map((p) => `${p[0]},${p[1]}`).join(" ");

async function api(path, body) {
  const opts = body === undefined ? {} : {
    method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
  };
  const r = await fetch(path, opts);
  const data = await r.json();
  if (data.error) throw new Error(data.error.message);
  return data;
}

// ------------------------------------------------------------------------------------------ set-up
async function start() {
  const d = await api("/api/start");
  S.part = d.part; S.frame = d.frame; S.c = d.case; S.materials = d.materials; S.toolpath = d.toolpath;
  S.c.supports = S.c.supports || []; S.c.loads = S.c.loads || [];
  $("part-name").textContent = "on " + d.part.name;
  $("part-info").textContent = `${d.part.kind === "gcode" ? "G-code" : "STL"}; frame = "${d.frame}"` +
    (d.frame === "part" ? " (coordinates from the part's minimum corner)" : " (bed coordinates)") +
    `; saves to ${d.save_path}`;
  const L = $("layer");
  L.max = String(d.part.layers.length - 1);
  L.disabled = d.part.layers.length < 2;
  L.addEventListener("input", () => { S.layer = Number(L.value); drawLayer(); drawSelections(); drawSolved(); });
  fitView();
  buildMaterial();
  buildToolpath();
  renderItems();
  $("feature").addEventListener("change", () => {
    const f = S.features[Number($("feature").value)];
    if (f) pick(f);
  });
  $("as-support").addEventListener("click", () => addFromPick("support"));
  $("as-load").addEventListener("click", () => addFromPick("load"));
  $("solve").addEventListener("click", solve);
  $("save").addEventListener("click", save);
  $("show-slicer").addEventListener("change", drawSolved);
  setupDrag();
  drawLayer();
  scheduleResolve(0);
  document.body.dataset.ready = "1";
}

function span() {
  const b = S.part.bounds;
  return Math.max(b[2] - b[0], b[3] - b[1]);
}

function fitView() {
  const b = S.part.bounds, p = 0.15 * span() + 2;  // room for load arrows (0.18 span long)
  const svg = $("svg");
  svg.setAttribute("viewBox", `${b[0] - p} ${-(b[3] + p)} ${b[2] - b[0] + 2 * p} ${b[3] - b[1] + 2 * p}`);
  svg.setAttribute("preserveAspectRatio", "xMidYMid meet");
  $("flip").setAttribute("transform", "scale(1,-1)");
}

function origin(objectName) {
  const objs = S.part.objects;
  const o = objs.find((x) => x.name === (objectName || S.c.object)) || objs[0];
  return o.origin;
}

// ------------------------------------------------------------------------------------ the drawing
function drawLayer() {
  const layer = S.part.layers[S.layer];
  const info = `z ${fmt(layer.z0)} to ${fmt(layer.z1)} mm` +
    (layer.file_layers.length ? `, G-code layers ${ranges(layer.file_layers)}` : "") +
    ` (region ${S.layer + 1} of ${S.part.layers.length})`;
  $("layer-info").textContent = info;
  $("layer").setAttribute("aria-valuetext", info);
  const go = $("g-outline"), gh = $("g-holes"), ge = $("g-edges");
  go.replaceChildren(); gh.replaceChildren(); ge.replaceChildren();
  S.features = [];
  const sel = $("feature");
  sel.replaceChildren(el("option", { value: "" }, "choose a hole or an edge"));
  for (const obj of layer.objects) {
    for (const poly of obj.polygons) {
      const d = poly.map((ring) => "M" + ring.map((p) => `${p[0]},${p[1]}`).join("L") + "Z").join("");
      go.appendChild(sv("path", { d, class: "outline", "vector-effect": "non-scaling-stroke", "stroke-width": "1" }));
    }
    obj.holes.forEach((h, i) => {
      const label = `hole ${i + 1} at x ${fmt(h.center[0])}, y ${fmt(h.center[1])} (${fmt(h.diameter)} mm)`;
      const f = { kind: "hole", where: h.where, label, object: obj.name, anchor: h.center, id: `h${S.features.length}` };
      const g = sv("g", { class: "feature", tabindex: "0", role: "button", "aria-label": "Pick " + label,
        "data-kind": "hole", "data-index": String(i), id: f.id });
      g.appendChild(sv("polygon", { points: pts(h.ring), class: "hole", "vector-effect": "non-scaling-stroke", "stroke-width": "1.5" }));
      hookFeature(g, f);
      gh.appendChild(g);
      sel.appendChild(el("option", { value: String(S.features.length) }, label));
      S.features.push(f);
    });
    obj.edges.forEach((e, i) => {
      const w = e.where;
      const label = `edge ${i + 1}, ${fmt(e.length, 1)} mm` + (w.side ? ` (side ${w.side})` : "");
      const mid = e.points[Math.floor(e.points.length / 2)];
      const a = e.points[0], b = e.points[e.points.length - 1];
      const anchor = e.points.length === 2 ? [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2] : mid;
      const f = { kind: "edge", where: w, label, object: obj.name, anchor, id: `e${S.features.length}` };
      const g = sv("g", { class: "feature", tabindex: "0", role: "button", "aria-label": "Pick " + label,
        "data-kind": "edge", "data-index": String(i), id: f.id });
      g.appendChild(sv("polyline", { points: pts(e.points), class: "edge-hit", "vector-effect": "non-scaling-stroke", "stroke-width": "14" }));
      g.appendChild(sv("polyline", { points: pts(e.points), class: "edge", "vector-effect": "non-scaling-stroke", "stroke-width": "4" }));
      hookFeature(g, f);
      ge.appendChild(g);
      sel.appendChild(el("option", { value: String(S.features.length) }, label));
      S.features.push(f);
    });
  }
}

function hookFeature(g, f) {
  g.addEventListener("mousedown", (ev) => ev.stopPropagation());
  g.addEventListener("click", (ev) => { ev.stopPropagation(); pick(f); });
  g.addEventListener("keydown", (ev) => {
    if (ev.key === "Enter" || ev.key === " ") { ev.preventDefault(); pick(f); }
  });
}

function ranges(ix) {
  const out = []; let s = ix[0], p = ix[0];
  for (const i of [...ix.slice(1), null]) {
    if (i !== null && i === p + 1) { p = i; continue; }
    out.push(p > s ? `${s}-${p}` : `${s}`);
    if (i !== null) { s = p = i; }
  }
  return out.join(", ");
}

function pick(f) {
  S.picked = f;
  document.querySelectorAll(".feature.picked").forEach((g) => g.classList.remove("picked"));
  if (f.id && $(f.id)) $(f.id).classList.add("picked");
  const idx = S.features.indexOf(f);
  if (idx >= 0) $("feature").value = String(idx);
  const where = Object.entries(f.where).map(([k, v]) => `${k} = ${JSON.stringify(v)}`).join(", ");
  $("pick-what").textContent = `Picked ${f.label}: where = { ${where} }`;
  const sup = $("as-support"), load = $("as-load");
  sup.disabled = load.disabled = false;
  sup.textContent = f.kind === "hole" ? "Pin support" : "Support";
  load.textContent = f.kind === "hole" ? "Bearing load" : f.kind === "edge" ? "Distributed load" : "Load";
}

function uniqueName(base) {
  const names = new Set([...S.c.supports, ...S.c.loads].map((x) => x.name));
  for (let i = 1; ; i++) if (!names.has(`${base} ${i}`)) return `${base} ${i}`;
}

function defaultDirection(anchor) {
  const b = S.part.bounds, c = [(b[0] + b[2]) / 2, (b[1] + b[3]) / 2];
  let dx = anchor[0] - c[0], dy = anchor[1] - c[1];
  const n = Math.hypot(dx, dy);
  if (n < 1e-9) return [0, -1];
  dx /= n; dy /= n;
  return Math.abs(dx) > Math.abs(dy) ? [Math.sign(dx), 0] : [0, Math.sign(dy)];
}

function addFromPick(role) {
  const f = S.picked;
  if (!f) return;
  const where = JSON.parse(JSON.stringify(f.where));
  let key;
  if (role === "support") {
    const base = f.kind === "hole" ? "pin" : f.kind === "box" ? "box support" : "support";
    S.c.supports.push({ name: uniqueName(base), where, fix: ["x", "y"] });
    key = `supports/${S.c.supports.length - 1}`;
  } else {
    const base = f.kind === "hole" ? "bearing" : f.kind === "box" ? "box load" : "edge load";
    const d = defaultDirection(f.anchor);
    S.c.loads.push({ name: uniqueName(base), where, force: [100 * d[0], 100 * d[1], 0.0] });
    key = `loads/${S.c.loads.length - 1}`;
  }
  renderItems();
  scheduleResolve(0);
  const first = document.querySelector(`[data-item="${key}"] input`);
  if (first) first.focus();
  $("status").textContent = `Added ${role} ${key === undefined ? "" : (role === "support" ? S.c.supports.at(-1).name : S.c.loads.at(-1).name)}`;
}

// ------------------------------------------------------------------------------------- the items
let uid = 0;
function field(parent, label, input, cls) {
  const id = `f${++uid}`;
  input.id = id;
  if (cls) input.classList.add(cls);
  const wrap = el("div");
  wrap.appendChild(el("label", { for: id }, label));
  wrap.appendChild(input);
  parent.appendChild(wrap);
  return input;
}
function num(value, onChange, attrs = {}) {
  const i = el("input", { type: "number", step: "any", ...attrs });
  i.value = value === undefined || value === null ? "" : String(value);
  i.addEventListener("change", () => onChange(i.value === "" ? null : Number(i.value)));
  return i;
}

function renderItems() {
  renderList("supports", S.c.supports, "support");
  renderList("loads", S.c.loads, "load");
  drawArrows();
}

function renderList(section, items, role) {
  const box = $(section);
  box.replaceChildren();
  items.forEach((it, i) => {
    const key = `${section}/${i}`;
    const fs = el("fieldset", { class: `item ${role}`, "data-item": key });
    fs.appendChild(el("legend", {}, `${role} ${i + 1}`));
    const name = el("input", { type: "text" });
    name.value = it.name || "";
    name.addEventListener("change", () => { it.name = name.value; scheduleResolve(); });
    field(fs, "Name", name, "name");
    whereFields(fs, it);
    fs.appendChild(el("p", { class: "picked" }, ""));
    if (role === "support") {
      const row = el("div", { role: "group", "aria-label": "Directions held" });
      row.appendChild(el("span", { class: "hint" }, "Directions held: "));
      for (const a of ["x", "y", "z"]) {
        const lab = el("label", { class: "check" });
        const cb = el("input", { type: "checkbox", class: `fix-${a}` });
        cb.checked = (it.fix || []).includes(a);
        cb.addEventListener("change", () => {
          const s = new Set(it.fix || []);
          if (cb.checked) s.add(a); else s.delete(a);
          it.fix = ["x", "y", "z"].filter((x) => s.has(x));
          scheduleResolve();
        });
        lab.appendChild(cb);
        lab.appendChild(document.createTextNode(`fix ${a}`));
        row.appendChild(lab);
      }
      fs.appendChild(row);
    } else {
      loadFields(fs, it);
    }
    const err = el("p", { class: "error", role: "alert" });
    err.hidden = true;
    fs.appendChild(err);
    const del = el("button", { type: "button", class: "delete", "aria-label": `Delete ${role} ${it.name}` }, "Delete");
    del.addEventListener("click", () => { items.splice(i, 1); renderItems(); scheduleResolve(0); });
    fs.appendChild(del);
    box.appendChild(fs);
  });
}

const WHERE_LABELS = {
  within: "Within (mm of the side)", radius: "Radius (mm)", x_min: "x min (mm)", x_max: "x max (mm)",
  y_min: "y min (mm)", y_max: "y max (mm)", z_min: "z min (mm)", z_max: "z max (mm)",
};

function whereFields(fs, it) {
  const w = it.where;
  const grid = el("div", { class: "row" });
  if ("side" in w) {
    const s = el("select");
    for (const v of ["x_min", "x_max", "y_min", "y_max", "z_min", "z_max"]) s.appendChild(el("option", { value: v }, v));
    s.value = w.side;
    s.addEventListener("change", () => { w.side = s.value; scheduleResolve(); });
    field(grid, "Side of the part", s, "side");
  }
  if ("hole_near" in w) {
    field(grid, "Hole near x (mm)", num(w.hole_near[0], (v) => { w.hole_near[0] = v; scheduleResolve(); }), "near-x");
    field(grid, "Hole near y (mm)", num(w.hole_near[1], (v) => { w.hole_near[1] = v; scheduleResolve(); }), "near-y");
  }
  for (const k of Object.keys(w)) {
    if (k === "side" || k === "hole_near") continue;
    field(grid, WHERE_LABELS[k] || k, num(w[k], (v) => { w[k] = v; scheduleResolve(); }), k);
  }
  fs.appendChild(grid);
}

function loadFields(fs, it) {
  const kind = el("select");
  kind.appendChild(el("option", { value: "force" }, "total force (N)"));
  kind.appendChild(el("option", { value: "pressure" }, "pressure (MPa)"));
  kind.value = "pressure" in it ? "pressure" : "force";
  field(fs, "Load given as", kind, "kind");
  const box = el("div", { class: "row3" });
  fs.appendChild(box);
  const draw = () => {
    box.replaceChildren();
    if (kind.value === "pressure") {
      field(box, "Pressure (MPa, + pushes)", num(it.pressure, (v) => { it.pressure = v; scheduleResolve(); }), "pressure");
      return;
    }
    const F = it.force;
    const mag = Math.hypot(F[0], F[1]);
    const dir = Math.atan2(F[1], F[0]) * 180 / Math.PI;
    const setXY = (m, deg) => {
      const r = deg * Math.PI / 180;
      F[0] = round(m * Math.cos(r)); F[1] = round(m * Math.sin(r));
      drawArrows(); scheduleResolve();
    };
    const m = field(box, "Force (N)", num(round(mag, 4), (v) => setXY(v || 0, Number(d.value))), "magnitude");
    const d = field(box, "Direction (degrees from +x)", num(round(dir, 3), (v) => setXY(Number(m.value), v || 0)), "direction");
    field(box, "Force z (N)", num(F[2], (v) => { F[2] = v || 0; scheduleResolve(); }), "fz");
  };
  kind.addEventListener("change", () => {
    if (kind.value === "pressure") { delete it.force; it.pressure = 1.0; } else { delete it.pressure; it.force = [100, 0, 0]; }
    draw(); drawArrows(); scheduleResolve();
  });
  draw();
}

function syncForceInputs() {
  S.c.loads.forEach((it, i) => {
    if (!it.force) return;
    const fs = document.querySelector(`[data-item="loads/${i}"]`);
    if (!fs) return;
    fs.querySelector(".magnitude").value = String(round(Math.hypot(it.force[0], it.force[1]), 4));
    fs.querySelector(".direction").value = String(round(Math.atan2(it.force[1], it.force[0]) * 180 / Math.PI, 3));
  });
}

// ---------------------------------------------------------------------------- material, toolpath
function buildMaterial() {
  const card = $("material-card");
  S.materials.forEach((m, i) => card.appendChild(el("option", { value: String(i) }, `${m.name}: E ${m.youngs_modulus} MPa, nu ${m.poissons_ratio}`)));
  card.appendChild(el("option", { value: "custom" }, "custom values"));
  S.c.material = S.c.material || { youngs_modulus: 3500.0, poissons_ratio: 0.35 };
  const E = $("youngs"), nu = $("poisson");
  const show = () => {
    E.value = String(S.c.material.youngs_modulus); nu.value = String(S.c.material.poissons_ratio);
    const i = S.materials.findIndex((m) => m.youngs_modulus === S.c.material.youngs_modulus && m.poissons_ratio === S.c.material.poissons_ratio);
    card.value = i >= 0 ? String(i) : "custom";
    $("material-source").textContent = i >= 0 ? "Source: " + S.materials[i].source : "";
  };
  card.addEventListener("change", () => {
    if (card.value === "custom") return;
    const m = S.materials[Number(card.value)];
    S.c.material = { youngs_modulus: m.youngs_modulus, poissons_ratio: m.poissons_ratio };
    show(); scheduleResolve();
  });
  E.addEventListener("change", () => { S.c.material.youngs_modulus = Number(E.value); show(); scheduleResolve(); });
  nu.addEventListener("change", () => { S.c.material.poissons_ratio = Number(nu.value); show(); scheduleResolve(); });
  show();
}

function buildToolpath() {
  const box = $("toolpath");
  S.c.toolpath = S.c.toolpath || {};
  const tp = S.c.toolpath;
  for (const f of S.toolpath) {
    const help = el("p", { class: "hint", id: `help-${f.name}` }, f.help + (f.unit ? ` (${f.unit})` : ""));
    const label = `${f.name}${f.unit ? " (" + f.unit + ")" : ""}`;
    if (f.type === "kinds") {
      const g = el("div", { role: "group", "aria-labelledby": `lab-${f.name}`, "aria-describedby": help.id });
      g.appendChild(el("span", { id: `lab-${f.name}`, class: "hint" }, `${f.name}: `));
      for (const k of f.choices) {
        const lab = el("label", { class: "check" });
        const cb = el("input", { type: "checkbox", id: `tp-${f.name}-${k}` });
        cb.checked = (tp[f.name] || []).includes(k);
        cb.addEventListener("change", () => {
          const s = new Set(tp[f.name] || []);
          if (cb.checked) s.add(k); else s.delete(k);
          const v = f.choices.filter((x) => s.has(x));
          if (v.length) tp[f.name] = v; else delete tp[f.name];
          scheduleResolve();
        });
        lab.appendChild(cb); lab.appendChild(document.createTextNode(k));
        g.appendChild(lab);
      }
      box.appendChild(g);
      box.appendChild(help);
      continue;
    }
    let input;
    if (f.choices.length) {
      input = el("select", { "aria-describedby": help.id });
      input.appendChild(el("option", { value: "" }, `default (${f.default})`));
      for (const c of f.choices) input.appendChild(el("option", { value: c }, c));
      input.value = tp[f.name] || "";
      input.addEventListener("change", () => { if (input.value) tp[f.name] = input.value; else delete tp[f.name]; scheduleResolve(); });
    } else {
      input = el("input", { type: "number", step: "any", "aria-describedby": help.id,
        placeholder: f.default === null ? "slicer's value" : `default ${f.default}` });
      if (f.minimum !== null) input.min = String(f.minimum);
      if (f.maximum !== null) input.max = String(f.maximum);
      input.value = tp[f.name] === undefined ? "" : String(tp[f.name]);
      input.addEventListener("change", () => { if (input.value === "") delete tp[f.name]; else tp[f.name] = Number(input.value); scheduleResolve(); });
    }
    field(box, label, input, `tp-${f.name}`);
    box.appendChild(help);
  }
}

// --------------------------------------------------------------------- the server's view of the case
function caseForServer() {
  const c = JSON.parse(JSON.stringify(S.c));
  if (c.toolpath && !Object.keys(c.toolpath).length) delete c.toolpath;
  return c;
}

function scheduleResolve(delay = 200) {
  clearTimeout(S.timer);
  document.body.dataset.resolved = "0";
  S.timer = setTimeout(resolve, delay);
}

async function resolve() {
  const seq = ++S.seq;
  document.body.dataset.resolved = "0";
  try {
    const r = await api("/api/resolve", { case: caseForServer() });
    if (seq !== S.seq) return;
    S.resolved = r;
    showErrors(r.errors);
    for (const s of r.selections) {
      const p = document.querySelector(`[data-item="${s.item}"] .picked`);
      if (p) p.textContent = `${s.object}: ${s.picked}`;
    }
    $("toml").textContent = r.toml || "(add at least one support and one load)";
    drawSelections();
    drawArrows();
  } catch (e) {
    showErrors([{ item: null, message: e.message }]);
  }
  if (seq === S.seq) document.body.dataset.resolved = "1";
}

function showErrors(errors) {
  document.querySelectorAll(".item .error, #err-supports, #err-loads, #err-general").forEach((p) => { p.hidden = true; p.textContent = ""; });
  for (const e of errors || []) {
    let p = null;
    if (e.item === "supports") p = $("err-supports");
    else if (e.item === "loads") p = $("err-loads");
    else if (e.item) p = document.querySelector(`[data-item="${e.item}"] .error`);
    if (!p) p = $("err-general");
    p.textContent = p.textContent ? p.textContent + " " + e.message : e.message;
    p.hidden = false;
  }
}

function drawSelections() {
  const g = $("g-selections");
  g.replaceChildren();
  if (!S.resolved) return;
  for (const s of S.resolved.selections) {
    const cls = s.role === "support" ? "sel-support" : "sel-load";
    const lines = s.layers[S.layer] || [];
    const grp = sv("g", { "data-item": s.item, class: "selection" });
    for (const ln of lines) grp.appendChild(sv("polyline", { points: pts(ln), class: cls, "vector-effect": "non-scaling-stroke", "stroke-width": "6" }));
    if (s.box) {
      const [x0, y0, x1, y1] = s.box;
      grp.appendChild(sv("rect", { x: x0, y: y0, width: x1 - x0, height: y1 - y0, class: `${cls} sel-box`, "vector-effect": "non-scaling-stroke", "stroke-width": "1" }));
    }
    const t = sv("title"); t.textContent = `${s.role} ${s.name}: ${s.picked}`;
    grp.appendChild(t);
    g.appendChild(grp);
  }
}

// ----------------------------------------------------------------------------------- load arrows
function anchorOf(item) {
  if (!S.resolved) return null;
  const s = S.resolved.selections.find((x) => x.item === item);
  if (!s) return null;
  const lines = s.layers[S.layer] || [];
  const all = lines.flat();
  if (!all.length) return null;
  const xs = all.map((p) => p[0]), ys = all.map((p) => p[1]);
  return [(Math.min(...xs) + Math.max(...xs)) / 2, (Math.min(...ys) + Math.max(...ys)) / 2];
}

function drawArrows() {
  const g = $("g-arrows");
  g.replaceChildren();
  const mags = S.c.loads.filter((l) => l.force).map((l) => Math.hypot(l.force[0], l.force[1]));
  const ref = Math.max(1e-9, ...mags);
  S.c.loads.forEach((ld, i) => {
    if (!ld.force) return;
    const a = anchorOf(`loads/${i}`);
    if (!a) return;
    const m = Math.hypot(ld.force[0], ld.force[1]);
    if (m === 0) return;
    const L = 0.18 * span() * (m / ref);
    const ux = ld.force[0] / m, uy = ld.force[1] / m;
    const tip = [a[0] + ux * L, a[1] + uy * L];
    const hs = 0.03 * span();
    const grp = sv("g", { class: "arrow", "data-item": `loads/${i}` });
    grp.appendChild(sv("line", { x1: a[0], y1: a[1], x2: tip[0], y2: tip[1], "vector-effect": "non-scaling-stroke", "stroke-width": "3" }));
    const left = [tip[0] - ux * hs - uy * hs * 0.5, tip[1] - uy * hs + ux * hs * 0.5];
    const right = [tip[0] - ux * hs + uy * hs * 0.5, tip[1] - uy * hs - ux * hs * 0.5];
    const head = sv("polygon", { points: pts([tip, left, right]), class: "arrow-head" });
    grp.appendChild(head);
    const hit = sv("circle", { cx: tip[0], cy: tip[1], r: hs, class: "arrow-hit", fill: "transparent" });
    grp.appendChild(hit);
    const t = sv("title"); t.textContent = `${ld.name}: ${fmt(m, 0)} N; drag the head to turn or stretch it`;
    grp.appendChild(t);
    hit.addEventListener("mousedown", (ev) => startArrowDrag(ev, ld, a, L, m));
    g.appendChild(grp);
  });
}

function toModel(ev) {
  const m = $("flip").getScreenCTM().inverse();
  const p = new DOMPoint(ev.clientX, ev.clientY).matrixTransform(m);
  return [p.x, p.y];
}

function startArrowDrag(ev, ld, anchor, L, m) {
  ev.preventDefault(); ev.stopPropagation();
  const move = (e) => {
    const p = toModel(e);
    const dx = p[0] - anchor[0], dy = p[1] - anchor[1];
    const len = Math.hypot(dx, dy);
    if (len < 1e-9) return;
    const mag = Math.max(1, Math.round(m * len / L));
    const deg = Math.round(Math.atan2(dy, dx) * 180 / Math.PI);
    const r = deg * Math.PI / 180;
    ld.force[0] = round(mag * Math.cos(r)); ld.force[1] = round(mag * Math.sin(r));
    syncForceInputs(); drawArrows();
  };
  const up = () => { window.removeEventListener("mousemove", move); window.removeEventListener("mouseup", up); scheduleResolve(0); };
  window.addEventListener("mousemove", move);
  window.addEventListener("mouseup", up);
}

// ------------------------------------------------------------------------------------- box drag
function setupDrag() {
  const svg = $("svg"), rect = $("drag-box");
  let start = null;
  svg.addEventListener("mousedown", (ev) => {
    if (ev.button !== 0) return;
    start = toModel(ev);
    rect.setAttribute("visibility", "visible");
    rect.setAttribute("width", "0"); rect.setAttribute("height", "0");
  });
  svg.addEventListener("mousemove", (ev) => {
    if (!start) return;
    const p = toModel(ev);
    rect.setAttribute("x", Math.min(p[0], start[0])); rect.setAttribute("y", Math.min(p[1], start[1]));
    rect.setAttribute("width", Math.abs(p[0] - start[0])); rect.setAttribute("height", Math.abs(p[1] - start[1]));
  });
  svg.addEventListener("mouseup", (ev) => {
    if (!start) return;
    const p = toModel(ev), s0 = start;
    start = null;
    rect.setAttribute("visibility", "hidden");
    if (Math.abs(p[0] - s0[0]) < 0.01 * span() || Math.abs(p[1] - s0[1]) < 0.01 * span()) return;
    const o = origin();
    const r2 = (v) => Math.round(v * 100) / 100;
    const where = {
      x_min: r2(Math.min(p[0], s0[0]) - o[0]), x_max: r2(Math.max(p[0], s0[0]) - o[0]),
      y_min: r2(Math.min(p[1], s0[1]) - o[1]), y_max: r2(Math.max(p[1], s0[1]) - o[1]),
    };
    pick({ kind: "box", where, label: "the box", object: null, anchor: [(p[0] + s0[0]) / 2, (p[1] + s0[1]) / 2], id: null });
  });
}

// -------------------------------------------------------------------------------- solve and save
async function solve() {
  const b = $("solve");
  b.disabled = true;
  document.body.dataset.solved = "0";
  $("status").textContent = "Solving: stress analysis" + (S.part.kind === "gcode" ? ", new paths for the whole G-code and the stiffness of both files (this takes a while)" : " and path preview") + "...";
  try {
    let r = await api("/api/solve", { case: caseForServer(), layer: S.layer });
    const base = $("status").textContent;
    while (r.running) {  // a G-code solve runs the whole pipeline: ask until it is done
      await new Promise((ok) => setTimeout(ok, 1000));
      r = await api("/api/solve-result", { job: r.job });
      if (r.running) $("status").textContent = `${base} ${Math.round(r.seconds)} s`;
    }
    S.resolved = r.selections ? r : S.resolved;
    showErrors(r.errors);
    drawSelections();
    if (r.ok) {
      S.solved = { ...r, layer: S.layer };
      $("status").textContent = "Solved.";
      drawSolved();
      showResults(r);
    } else {
      $("status").textContent = "Not solved: see the message next to the selection at fault.";
    }
  } catch (e) {
    showErrors([{ item: null, message: e.message }]);
    $("status").textContent = "Not solved.";
  }
  b.disabled = false;
  document.body.dataset.solved = "1";
}

function drawSolved() {
  const gs = $("g-stress"), gp = $("g-paths"), gsl = $("g-slicer");
  gs.replaceChildren(); gp.replaceChildren(); gsl.replaceChildren();
  $("legend").textContent = "";
  const r = S.solved;
  if (!r || r.layer !== S.layer) return;
  let scale = 0;
  for (const f of r.stress) {
    scale = Math.max(scale, f.scale);
    const h = f.h;
    for (const [x, y, s1, s2, a1] of f.points) {
      const mag = Math.min(1, Math.max(Math.abs(s1), Math.abs(s2)) / f.scale);
      gs.appendChild(sv("rect", { x: x - h / 2, y: y - h / 2, width: h, height: h, fill: `hsl(${40 - 40 * mag}, 90%, ${92 - 42 * mag}%)` }));
      for (const [s, a] of [[s1, a1], [s2, a1 + Math.PI / 2]]) {
        const l = 0.45 * h * Math.min(1, Math.abs(s) / f.scale);
        if (l < 0.02 * h) continue;
        const dx = Math.cos(a) * l, dy = Math.sin(a) * l;
        gs.appendChild(sv("line", { x1: x - dx, y1: y - dy, x2: x + dx, y2: y + dy, class: s >= 0 ? "tension" : "compression", "vector-effect": "non-scaling-stroke", "stroke-width": "1.5" }));
      }
    }
  }
  const pv = r.preview || {};
  for (const p of pv.paths || []) gp.appendChild(sv("polyline", { points: pts(p), class: "path-new", "vector-effect": "non-scaling-stroke", "stroke-width": "1" }));
  if ($("show-slicer").checked) for (const p of pv.slicer_paths || []) gsl.appendChild(sv("polyline", { points: pts(p), class: "path-slicer", "vector-effect": "non-scaling-stroke", "stroke-width": "1" }));
  $("legend").textContent = `Principal stresses: red tension, blue compression, bar length and shade up to ${fmt(scale, 2)} MPa; blue lines: new paths (${pv.paths ? pv.paths.length : 0}).`;
}

function showResults(r) {
  const box = $("results");
  box.replaceChildren();
  for (const f of r.stress) box.appendChild(el("p", {}, `${f.body}: ${f.analysis} analysis, residual ${f.residual.toExponential(1)}, stress scale ${fmt(f.scale, 2)} MPa`));
  const pv = r.preview || {};
  if (pv.paths_note) box.appendChild(el("p", { id: "paths-note" }, "Paths: " + pv.paths_note));
  if (pv.stiffness) {
    const t = el("table", { id: "stiffness" });
    const head = el("tr"); for (const h of ["", "slicer", "loadpath"]) head.appendChild(el("th", {}, h)); t.appendChild(head);
    const rows = [["compliance (N mm)", pv.stiffness.slicer_compliance, pv.stiffness.new_compliance, 1],
      ["peak displacement (mm)", pv.stiffness.slicer_peak_displacement, pv.stiffness.new_peak_displacement, 4]];
    for (const [name, a, b, d] of rows) {
      const tr = el("tr"); tr.appendChild(el("th", {}, name)); tr.appendChild(el("td", {}, fmt(a, d))); tr.appendChild(el("td", {}, fmt(b, d))); t.appendChild(tr);
    }
    box.appendChild(t);
    box.appendChild(el("p", { id: "relative-stiffness" }, `Predicted stiffness ${fmt(pv.stiffness.relative_stiffness, 3)}x the slicer's infill (${fmt(pv.stiffness.relative_specific_stiffness, 3)}x per gram).`));
  }
  if (pv.failure_load) {
    const f = pv.failure_load;
    box.appendChild(el("p", { id: "relative-failure-load" }, `Predicted failure load (first-ply failure) ${fmt(f.slicer, 0)} N with the slicer's infill, ${fmt(f.new, 0)} N with loadpath's: ${fmt(f.relative, 3)}x (${fmt(f.relative_per_mass, 3)}x per gram).`));
  }
  if (pv.failure_note) box.appendChild(el("p", { class: "hint" }, pv.failure_note));
  for (const w of pv.warnings || []) box.appendChild(el("p", { class: "hint" }, "Warning: " + w));
}

async function save() {
  try {
    const r = await api("/api/save", { case: caseForServer() });
    showErrors(r.errors);
    if (r.saved) { $("status").textContent = `Saved to ${r.saved}`; $("toml").textContent = r.toml; }
    else $("status").textContent = "Not saved: see the messages.";
  } catch (e) {
    showErrors([{ item: null, message: e.message }]);
  }
  document.body.dataset.saved = "1";
}

window.editorState = S;  // for the tests and for debugging in the browser's console
window.addEventListener("DOMContentLoaded", () => {
  start().catch((e) => { showErrors([{ item: null, message: e.message }]); });
});
