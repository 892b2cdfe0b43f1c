/* explorer edit: the page. Plain JavaScript and SVG; every number it shows comes from the server
 * (explorer.simulate, explorer.gait, the forces effect, design_yield): this file only draws them.
 *
 * Contracts: each joint's handle is an SVG element with data-joint="NAME" (the crank centre's has
 * data-pivot="crank"); each live figure an element with data-metric="NAME" whose text is its value;
 * the design's status (or a failure) is shown in the element with data-status.
 * Timings of drag steps (pointer event to redrawn frame) are kept in window.editTimings.
 */
"use strict";

const SVGNS = "http://www.w3.org/2000/svg";
const S = {
  info: null, meta: {}, design: null, params: [], size: 1, solve: null, ref: null,
  k: 0, angle: 0, config: null, undo: [], redo: [], playing: false,
  inflight: false, pending: null, drag: null, box: null, topo: "", editing: null,
};
window.editTimings = [];
window.editState = S;

// -- helpers -------------------------------------------------------------------------------------------
const $ = (id) => document.getElementById(id);
function el(tag, attrs, parent) {
  const e = document.createElementNS(SVGNS, tag);
  for (const k in attrs || {}) e.setAttribute(k, attrs[k]);
  if (parent) parent.appendChild(e);
  return e;
}
function h(tag, attrs, text) {
  const e = document.createElement(tag);
  for (const k in attrs || {}) e.setAttribute(k, attrs[k]);
  if (text !== undefined) e.textContent = text;
  return e;
}
function bytes(b64) {
  const s = atob(b64);
  const u = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) u[i] = s.charCodeAt(i);
  return u.buffer;
}
const f64 = (b64) => new Float64Array(bytes(b64));
const f32 = (b64) => new Float32Array(bytes(b64));
/** A figure's text: 7 significant digits (what data-metric elements hold), or "–" when there is none. */
function fmt(v) {
  if (v === null || v === undefined || !isFinite(v)) return "–";
  if (Number.isInteger(v) && Math.abs(v) < 1e15) return String(v);
  return Number(v).toPrecision(7);
}
function short(v, digits) {
  if (v === null || v === undefined || !isFinite(v)) return "–";
  return Number(v).toPrecision(digits || 4);
}
async function api(method, path, body) {
  const opt = { method: method, headers: {} };
  if (body !== undefined) { opt.headers["Content-Type"] = "application/json"; opt.body = JSON.stringify(body); }
  let resp;
  try { resp = await fetch(path, opt); } catch (e) { return { error: "the editor's server is not answering (" + e.message + ")" }; }
  let data;
  try { data = await resp.json(); } catch (e) { data = { error: "the server sent no JSON (" + resp.status + ")" }; }
  if (!resp.ok && !data.error) data.error = "HTTP " + resp.status;
  return data;
}
function setStatus(text, kind) {
  const st = $("status");
  st.textContent = text;
  st.setAttribute("data-status", kind === "ok" ? "ok" : text);
  st.className = "status " + kind;
}
function message(text, note) {
  const m = $("message");
  m.textContent = text || "";
  m.setAttribute("data-message", text || "");
  m.className = "message" + (note ? " note" : "");
}

// -- a design and its solve ------------------------------------------------------------------------------
function decode(solve) {
  const P = f32(solve.positions);
  const theta = f64(solve.theta);
  const nv = solve.vertices.length;
  return Object.assign({}, solve, { P: P, th: theta, nv: nv, S: theta.length,
                                     index: Object.fromEntries(solve.vertices.map((v, i) => [v, i])) });
}
function position(sol, k, i) {
  const j = (k * sol.nv + i) * 2;
  const x = sol.P[j], y = sol.P[j + 1];
  return isFinite(x) && isFinite(y) ? [x, y] : null;
}
function positionsAt(sol, k) {
  const out = [];
  for (let i = 0; i < sol.nv; i++) out.push(position(sol, k, i));
  return out;
}
function shown() {  // the configuration drawn: a drag's (at its angle) or the solve's at sample k
  if (S.config) {
    const out = [];
    for (let i = 0; i < S.solve.nv; i++) {
      const x = S.config[2 * i], y = S.config[2 * i + 1];
      out.push(isFinite(x) && isFinite(y) ? [x, y] : null);
    }
    return out;
  }
  return positionsAt(S.solve, S.k);
}
function isCrank() { return !!S.design.crank; }
function sampleOf(angle) {
  const n = S.solve.S;
  if (isCrank()) return ((Math.round(angle / (2 * Math.PI / n)) % n) + n) % n;
  let best = 0;
  for (let k = 0; k < n; k++) if (Math.abs(S.solve.th[k] - angle) < Math.abs(S.solve.th[best] - angle)) best = k;
  return best;
}
function topology(d) {
  return JSON.stringify([Object.keys(d.fixed || {}), Object.keys(d.guess || {}), (d.links || []).map((l) => [l.a, l.b]),
    (d.bodies || []).map((b) => Object.keys(b.joints)), (d.sliders || []).map((s) => [s.vertex, s.line || null]),
    d.crank ? d.crank.tip : (d.driver || {}).vertex]);
}

/** Take a server payload {design, parameters, solve} as the current design. */
function apply(p, opts) {
  opts = opts || {};
  S.design = p.design;
  S.params = p.parameters;
  S.solve = decode(p.solve);
  if (p.size) S.size = p.size;
  if (p.driven) S.driven = p.driven;
  if (p.angle !== undefined) { S.angle = p.angle; S.k = sampleOf(p.angle); S.config = p.config ? f64(p.config) : null; }
  else if (!opts.keepAngle) { S.config = null; S.angle = S.solve.th[Math.min(S.k, S.solve.S - 1)]; }
  else { S.config = null; S.k = Math.min(S.k, S.solve.S - 1); S.angle = S.solve.th[S.k]; }
  const topo = topology(S.design);
  if (topo !== S.topo) { S.topo = topo; build(); S.box = null; }
  if (!S.box || opts.refit) fit();
  $("scrub").max = String(S.solve.S - 1);
  $("scrub").value = String(S.k);
  draw();
  figures();
  paramValues();
  $("title").textContent = S.design.name + (S.info ? "  (reference: " + S.info.label + ")" : "");
}
function setReference(p) {
  S.ref = { design: p.design, parameters: p.parameters, solve: decode(p.solve) };
  S.refValues = Object.fromEntries(p.parameters.map((r) => [r[0], r[1]]));
  S.size = p.size || S.size;
}

// -- the drawing ----------------------------------------------------------------------------------------
let R = 1;  // handle radius, model units
function fit() {
  const xs = [], ys = [];
  const add = (p) => { if (p) { xs.push(p[0]); ys.push(p[1]); } };
  for (const sol of [S.solve, S.ref && S.ref.solve]) {
    if (!sol) continue;
    for (let k = 0; k < sol.S; k += Math.max(1, Math.floor(sol.S / 90))) for (let i = 0; i < sol.nv; i++) add(position(sol, k, i));
  }
  shown().forEach(add);
  const d = S.design;
  for (const v in d.fixed || {}) add(d.fixed[v]);
  if (d.crank) { const c = d.crank.center, r = d.crank.radius; add([c[0] - r, c[1] - r]); add([c[0] + r, c[1] + r]); }
  if (!xs.length) { xs.push(0, 1); ys.push(0, 1); }
  let x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
  const w = Math.max(x1 - x0, 1e-9), hh = Math.max(y1 - y0, 1e-9), pad = 0.1 * Math.max(w, hh);
  x0 -= pad; x1 += pad; y0 -= pad; y1 += pad;
  S.box = [x0, y0, x1, y1];
  R = 0.014 * Math.max(x1 - x0, y1 - y0);
  $("drawing").setAttribute("viewBox", [x0, -y1, x1 - x0, y1 - y0].join(" "));
  document.querySelectorAll("#handles .handle").forEach((c) => c.setAttribute("r", c.classList.contains("pivot") ? 0 : R));
  document.querySelectorAll("#handles rect.handle").forEach((c) => { c.setAttribute("width", 2 * R); c.setAttribute("height", 2 * R); });
  drawAll();
}

const G = {};  // the drawing's elements, made once per topology
function build() {
  for (const id of ["ghost", "walker", "traces", "guides", "bodies", "links", "crank", "pivots", "handles", "labels", "fail-mark", "ground-line"]) {
    $(id).textContent = "";
  }
  const d = S.design;
  G.links = (d.links || []).map((l) => ({ a: l.a, b: l.b, e: el("line", { class: "link", "data-link": l.name || (l.a + "-" + l.b) }, $("links")) }));
  G.bodies = (d.bodies || []).map((b) => ({ joints: Object.keys(b.joints), e: el("polygon", { class: "body", "data-body": b.name }, $("bodies")) }));
  G.sliders = (d.sliders || []).map((s) => ({ s: s, e: el("line", { class: s.line ? "slot" : "guide", "data-slider": s.name }, $("guides")) }));
  G.crank = d.crank ? el("line", { class: "crank-bar" }, $("crank")) : null;
  G.ghostLinks = (d.links || []).map((l) => ({ a: l.a, b: l.b, e: el("line", { class: "ghost-link" }, $("ghost")) }));
  G.ghostBodies = (d.bodies || []).map((b) => ({ joints: Object.keys(b.joints), e: el("polygon", { class: "ghost-link", fill: "none" }, $("ghost")) }));
  G.ghostPath = el("path", { class: "ghost-path" }, $("ghost"));
  G.handles = {};
  G.labels = {};
  const vertices = S.solve.vertices;
  const driven = S.driven;
  for (const v of vertices) {
    const cls = ["handle"];
    if (v in (d.fixed || {})) cls.push("fixed");
    if (d.crank && v === d.crank.tip) cls.push("tip");
    if (v === d.foot) cls.push("foot");
    if (!d.crank && v === driven) cls.push("driven");
    if (v in (d.fixed || {})) el("path", { class: "pivot-base", "data-base": v }, $("pivots"));
    const c = el("circle", { class: cls.filter(Boolean).join(" "), "data-joint": v, r: R }, $("handles"));
    const t = el("title", {}, c); t.textContent = "joint " + v + (v === d.foot ? " (foot)" : "") + (v in (d.fixed || {}) ? " (ground pivot)" : "");
    if (!cls.includes("driven")) c.addEventListener("pointerdown", (e) => startDrag(e, v, c));
    G.handles[v] = c;
    G.labels[v] = el("text", { class: "label" }, $("labels"));
    G.labels[v].textContent = v;
  }
  if (d.crank) {
    const c = el("rect", { class: "handle fixed", "data-pivot": "crank", width: 2 * R, height: 2 * R }, $("handles"));
    el("title", {}, c).textContent = "the crank centre (axle): drag to move it";
    c.addEventListener("pointerdown", (e) => startDrag(e, S.info.crank_centre, c));
    G.centre = c;
  } else G.centre = null;
  G.walker = [];
  G.ground = el("line", { class: "ground" }, $("ground-line"));
  G.traces = vertices.map(() => el("path", { class: "trace" }, $("traces")));
  G.failRing = el("circle", { class: "fail-ring" }, $("fail-mark"));
  G.failLabel = el("text", { class: "label fail" }, $("labels"));
  buildParams();
}

function pathD(sol, i, closed) {
  let d = "", open = false;
  for (let k = 0; k < sol.S; k++) {
    const p = position(sol, k, i);
    if (!p) { open = false; continue; }
    d += (open ? "L" : "M") + p[0].toFixed(6) + " " + p[1].toFixed(6);
    open = true;
  }
  if (closed && d && position(sol, 0, i) && position(sol, sol.S - 1, i)) d += "Z";
  return d;
}
function line(e, p, q) {
  if (!p || !q) { e.setAttribute("visibility", "hidden"); return; }
  e.setAttribute("visibility", "visible");
  e.setAttribute("x1", p[0]); e.setAttribute("y1", p[1]); e.setAttribute("x2", q[0]); e.setAttribute("y2", q[1]);
}
function hull(pts) {
  const p = pts.slice().sort((a, b) => a[0] - b[0] || a[1] - b[1]);
  if (p.length < 3) return p;
  const cross = (o, a, b) => (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
  const lo = [], up = [];
  for (const q of p) { while (lo.length >= 2 && cross(lo[lo.length - 2], lo[lo.length - 1], q) <= 0) lo.pop(); lo.push(q); }
  for (let i = p.length - 1; i >= 0; i--) { const q = p[i]; while (up.length >= 2 && cross(up[up.length - 2], up[up.length - 1], q) <= 0) up.pop(); up.push(q); }
  up.pop(); lo.pop();
  const out = lo.concat(up);
  return out.length ? out : p;
}
function polygon(e, pts) {
  if (pts.some((p) => !p)) { e.setAttribute("visibility", "hidden"); return; }
  e.setAttribute("visibility", "visible");
  e.setAttribute("points", hull(pts).map((p) => p[0] + "," + p[1]).join(" "));
}
function drawLeg(P, links, bodies, idx) {
  links.forEach((L) => line(L.e, P[idx[L.a]], P[idx[L.b]]));
  bodies.forEach((B) => polygon(B.e, B.joints.map((j) => P[idx[j]])));
}

function drawAll() { draw(); }
function draw() {
  if (!S.solve) return;
  const sol = S.solve, idx = sol.index, d = S.design, P = shown();
  drawLeg(P, G.links, G.bodies, idx);
  // the crank
  if (d.crank) {
    const c = d.crank.center;
    line(G.crank, c, P[idx[d.crank.tip]]);
    const cc = $("crank-circle");
    cc.setAttribute("cx", c[0]); cc.setAttribute("cy", c[1]); cc.setAttribute("r", d.crank.radius);
    G.centre.setAttribute("x", c[0] - R); G.centre.setAttribute("y", c[1] - R);
    G.centre.setAttribute("width", 2 * R); G.centre.setAttribute("height", 2 * R);
  }
  // sliders: a ground line over its vertex's travel, a slot along its member
  G.sliders.forEach((g) => {
    const s = g.s, v = P[idx[s.vertex]];
    if (s.line) {
      const a = P[idx[s.line[0]]], b = P[idx[s.line[1]]];
      if (!a || !b || !v) { line(g.e, null, null); return; }
      const ux = b[0] - a[0], uy = b[1] - a[1], n = Math.hypot(ux, uy) || 1, u = [ux / n, uy / n];
      const t = [a, b, v].map((p) => (p[0] - v[0]) * u[0] + (p[1] - v[1]) * u[1]);
      line(g.e, [v[0] + Math.min(...t) * u[0], v[1] + Math.min(...t) * u[1]], [v[0] + Math.max(...t) * u[0], v[1] + Math.max(...t) * u[1]]);
    } else {
      const n = Math.hypot(s.direction[0], s.direction[1]) || 1, u = [s.direction[0] / n, s.direction[1] / n];
      const ts = [];
      for (let k = 0; k < sol.S; k++) { const p = position(sol, k, idx[s.vertex]); if (p) ts.push((p[0] - s.point[0]) * u[0] + (p[1] - s.point[1]) * u[1]); }
      if (v) ts.push((v[0] - s.point[0]) * u[0] + (v[1] - s.point[1]) * u[1]);
      if (!ts.length) { line(g.e, null, null); return; }
      let t0 = Math.min(...ts), t1 = Math.max(...ts); const pad = 0.1 * Math.max(t1 - t0, S.size * 0.05); t0 -= pad; t1 += pad;
      line(g.e, [s.point[0] + t0 * u[0], s.point[1] + t0 * u[1]], [s.point[0] + t1 * u[0], s.point[1] + t1 * u[1]]);
    }
  });
  // handles, labels, ground pivots
  const showLabels = $("show-labels").checked;
  for (const v of sol.vertices) {
    const p = P[idx[v]], c = G.handles[v], t = G.labels[v];
    if (!p) { c.setAttribute("visibility", "hidden"); t.setAttribute("visibility", "hidden"); continue; }
    c.setAttribute("visibility", "visible");
    c.setAttribute("cx", p[0]); c.setAttribute("cy", p[1]); c.setAttribute("r", R);
    t.setAttribute("visibility", showLabels ? "visible" : "hidden");
    t.setAttribute("x", p[0] + 1.4 * R); t.setAttribute("y", -p[1] - 1.4 * R); t.setAttribute("font-size", 1.7 * R);
    t.setAttribute("stroke-width", 0.25 * R);  // model units, as the font: a halo that scales with the drawing
  }
  document.querySelectorAll("#pivots .pivot-base").forEach((b) => {
    const p = P[idx[b.getAttribute("data-base")]];
    if (!p) return;
    b.setAttribute("d", `M${p[0]} ${p[1]}L${p[0] - 1.6 * R} ${p[1] - 2.4 * R}L${p[0] + 1.6 * R} ${p[1] - 2.4 * R}Z`);
  });
  // the foot path over the whole turn
  $("foot-path").setAttribute("d", pathD(sol, idx[d.foot], isCrank()));
  drawGhost();
  drawWalker(P);
  drawTraces();
  drawFailure(P);
  const a = isCrank() ? "θ = " + (((S.angle * 180 / Math.PI) % 360 + 360) % 360).toFixed(1) + "°" : "t = " + S.angle.toFixed(3) + " s";
  $("angle").textContent = a;
}

function drawGhost() {
  const on = $("show-ghost").checked && S.ref && topology(S.ref.design) === S.topo;
  $("ghost").setAttribute("visibility", on ? "visible" : "hidden");
  if (!on) return;
  const ref = S.ref.solve;
  const k = Math.min(sampleOf(S.angle), ref.S - 1);
  const P = positionsAt(ref, k);
  drawLeg(P, G.ghostLinks, G.ghostBodies, ref.index);
  G.ghostPath.setAttribute("d", pathD(ref, ref.index[S.ref.design.foot], isCrank()));
}

function walkerSpec() {
  const w = S.design.walker;
  if (w) return { legs: w.legs, phases: w.phases.map((p) => p * Math.PI / 180), mirrored: w.mirrored };
  const n = 4;
  return { legs: n, phases: [...Array(n).keys()].map((j) => 2 * Math.PI * j / n), mirrored: Array(n).fill(false) };
}
function drawWalker(P0) {
  const on = $("show-walker").checked && isCrank();
  $("walker").setAttribute("visibility", on ? "visible" : "hidden");
  G.ground.setAttribute("visibility", on ? "visible" : "hidden");
  if (!on) return;
  const sol = S.solve, w = walkerSpec(), n = sol.S, dth = 2 * Math.PI / n, cx = S.design.crank.center[0];
  while (G.walker.length < w.legs) {
    G.walker.push({ links: S.design.links.map((l) => ({ a: l.a, b: l.b, e: el("line", { class: "walker-link" }, $("walker")) })),
                    bodies: (S.design.bodies || []).map((b) => ({ joints: Object.keys(b.joints), e: el("polygon", { class: "walker-link", fill: "none" }, $("walker")) })) });
  }
  let ground = Infinity;
  const foot = sol.index[S.design.foot];
  for (let j = 0; j < G.walker.length; j++) {
    const g = G.walker[j];
    if (j >= w.legs) { g.links.forEach((L) => line(L.e, null, null)); g.bodies.forEach((B) => B.e.setAttribute("visibility", "hidden")); continue; }
    let P;
    if (w.mirrored[j]) {
      const k = (((Math.round((Math.PI - S.angle - w.phases[j]) / dth)) % n) + n) % n;
      P = positionsAt(sol, k).map((p) => (p ? [2 * cx - p[0], p[1]] : null));
    } else {
      const k = (((Math.round((S.angle + w.phases[j]) / dth)) % n) + n) % n;
      P = positionsAt(sol, k);
    }
    if (P[foot]) ground = Math.min(ground, P[foot][1]);
    drawLeg(P, g.links, g.bodies, sol.index);
  }
  if (isFinite(ground) && S.box) line(G.ground, [S.box[0], ground], [S.box[2], ground]);
}

function drawTraces() {
  const on = $("show-traces").checked;
  $("traces").setAttribute("visibility", on ? "visible" : "hidden");
  if (!on) return;
  S.solve.vertices.forEach((v, i) => G.traces[i].setAttribute("d", pathD(S.solve, i, isCrank())));
}

function drawFailure(P) {
  const f = S.solve.failure, arc = $("fail-arc");
  G.failRing.setAttribute("visibility", "hidden");
  G.failLabel.setAttribute("visibility", "hidden");
  arc.setAttribute("d", "");
  if (!f) return;
  const idx = S.solve.index;
  const d = S.design;
  if (d.crank && f.theta !== null) {
    const c = d.crank.center, r = d.crank.radius;
    const a0 = f.theta * Math.PI / 180;
    let a1 = f.theta_end !== null ? f.theta_end * Math.PI / 180 : a0 + 2 * Math.PI / S.solve.S;
    while (a1 <= a0) a1 += 2 * Math.PI;
    const large = a1 - a0 > Math.PI ? 1 : 0;
    const p0 = [c[0] + r * Math.cos(a0), c[1] + r * Math.sin(a0)], p1 = [c[0] + r * Math.cos(a1), c[1] + r * Math.sin(a1)];
    arc.setAttribute("d", a1 - a0 >= 2 * Math.PI - 1e-9
      ? `M${c[0] + r} ${c[1]}A${r} ${r} 0 1 1 ${c[0] - r} ${c[1]}A${r} ${r} 0 1 1 ${c[0] + r} ${c[1]}`
      : `M${p0[0]} ${p0[1]}A${r} ${r} 0 ${large} 1 ${p1[0]} ${p1[1]}`);
  }
  // the failing joint: where it was last solved before the failure (else where it is drawn)
  let p = null;
  if (f.vertex !== null && f.vertex in idx) {
    const i = idx[f.vertex];
    if (f.theta !== null) {
      const kf = isCrank() ? Math.floor((f.theta * Math.PI / 180) / (2 * Math.PI / S.solve.S)) : sampleOf(f.theta);
      for (let k = kf; k >= kf - S.solve.S; k--) { p = position(S.solve, ((k % S.solve.S) + S.solve.S) % S.solve.S, i); if (p) break; }
    }
    p = p || P[i];
  }
  if (p) {
    G.failRing.setAttribute("visibility", "visible");
    G.failRing.setAttribute("cx", p[0]); G.failRing.setAttribute("cy", p[1]); G.failRing.setAttribute("r", 2.2 * R);
    G.failLabel.setAttribute("visibility", "visible");
    G.failLabel.setAttribute("x", p[0] + 2.4 * R); G.failLabel.setAttribute("y", -p[1] + 3.5 * R);
    G.failLabel.setAttribute("font-size", 2.2 * R);
    G.failLabel.setAttribute("stroke-width", 0.3 * R);
    const at = f.theta === null ? "" : (f.unit === "deg" ? " at θ = " + f.theta.toFixed(1) + "°" : " at t = " + f.theta.toFixed(3) + " s");
    G.failLabel.textContent = f.vertex + ": " + f.kind + at;
  }
}

// -- the figures ----------------------------------------------------------------------------------------
const SHOWN_FIRST = ["travel", "bob", "clearance", "slip", "peak_torque", "torque_ripple", "body_speed_ripple", "contact_fraction", "quick_return"];
function unitText(u) { return u === "length" ? "model units" : u === "length/turn" ? "per turn" : u === "1" ? "" : u; }
function changeCell(td, name, v, r) {
  td.className = "change";
  td.setAttribute("data-change", name);
  if (v === null || r === null || r === undefined || !isFinite(v) || !isFinite(r) || r === 0) { td.textContent = ""; return; }
  const pct = 100 * (v - r) / Math.abs(r);
  td.textContent = (pct >= 0 ? "+" : "") + pct.toFixed(Math.abs(pct) < 10 ? 2 : 1) + " %";
  const dir = (S.meta[name] || {}).direction;
  if (Math.abs(pct) >= 0.005 && dir) td.classList.add((dir === "max") === (pct > 0) ? "better" : "worse");
}
function metricRow(table, name, value, ref, note) {
  let tr = table.querySelector(`tr[data-row="${CSS.escape(name)}"]`);
  if (!tr) {
    tr = h("tr", { "data-row": name });
    const m = S.meta[name] || { unit: name.startsWith("pin_force.") ? "N" : "", description: "" };
    const td = h("td", { class: "name", title: m.description || "" }, name);
    tr.append(td, h("td", { class: "value", "data-metric": name }), h("td", { class: "unit" }, unitText(m.unit)), h("td"));
    table.appendChild(tr);
  }
  tr.className = value === null && note ? "na" : "";
  const v = tr.children[1];
  v.textContent = note && value === null ? "n/a" : fmt(value);
  v.title = note || "";
  changeCell(tr.children[3], name, value, ref);
}
function figures() {
  const sol = S.solve, ref = S.ref ? S.ref.solve : null;
  $("vs-label").textContent = S.ref ? "(change against " + S.info.label + ")" : "";
  const main = $("metrics"), leg = $("leg-metrics");
  const names = Object.keys(sol.metrics);
  const first = SHOWN_FIRST.filter((m) => names.includes(m));
  const screenInputs = new Set(["min_transmission_angle", "foot_headroom", "self_crossings"]);
  const rest = names.filter((m) => !first.includes(m) && !screenInputs.has(m));
  const wanted = new Set(first.concat(rest));
  for (const t of [main, leg]) t.querySelectorAll("tr[data-row]").forEach((tr) => { if (!wanted.has(tr.getAttribute("data-row"))) tr.remove(); });
  for (const m of first) metricRow(main, m, sol.metrics[m], ref ? ref.metrics[m] : null);
  for (const m of rest) metricRow(leg, m, sol.metrics[m], ref ? ref.metrics[m] : null);
  $("leg-details").style.display = rest.length ? "" : "none";
  if (!names.length) {
    main.textContent = "";
    const why = Object.values(sol.not_applicable || {})[0] || "no gait metric applies";
    main.appendChild(h("tr", {}, "")).appendChild(h("td", { class: "muted" }, why));
  }
  screenFigures(ref);
  forceFigures(ref);
  // a failure: in the data-status element, with the angle, the joint and the reason
  if (sol.ok) setStatus("ok: turns all round", "ok");
  else setStatus(sol.failure ? sol.failure.message : sol.status, "failed");
  const scatterMark = document.getElementById("current-mark");
  if (scatterMark) placeCurrentMark();
}
function screenFigures(ref) {
  const t = $("screen"), sc = S.solve.screen;
  t.textContent = "";
  const b = $("buildable");
  if (!sc) { b.textContent = ""; t.appendChild(h("tr")).appendChild(h("td", { class: "muted" }, "not applicable to this mechanism")); return; }
  b.textContent = sc.buildable === null ? "" : sc.buildable ? "✓ buildable" : "✗ " + sc.reason;
  b.className = sc.buildable ? "pass" : "fail";
  const head = h("tr");
  ["check", "value", "limit", "margin", ""].forEach((x) => head.appendChild(h("td", { class: "muted" }, x)));
  t.appendChild(head);
  for (const c of sc.checks) {
    const tr = h("tr", { "data-check": c.check });
    const whip = c.check === "foot whip";
    const value = h("td", whip ? { class: "value", "data-screen": c.check } : { class: "value", "data-metric": c.metric }, fmt(c.value));
    const unit = (S.meta[c.metric] || {}).unit;
    tr.append(h("td", { class: "name", title: c.metric + (whip ? " / crank radius" : "") }, c.check), value,
              h("td", { class: "unit" }, (c.field.startsWith("min") ? "≥ " : "≤ ") + c.threshold + (whip ? " crank radii/rad" : unit === "deg" ? "°" : "")),
              h("td", { class: "value", "data-margin": c.check }, fmt(c.margin)),
              h("td", { class: c.pass ? "pass" : "fail" }, c.pass ? "✓" : "✗"));
    t.appendChild(tr);
  }
}
function forceFigures(ref) {
  const box = $("forces"), fo = S.solve.forces, plot = $("torque-plot");
  box.textContent = "";
  plot.textContent = "";
  if (!fo || fo.note) { box.appendChild(h("p", { class: "muted" }, fo ? fo.note : "")); plot.style.display = "none"; return; }
  const t = h("table", { class: "figures" });
  const rf = ref && ref.forces && ref.forces.metrics ? ref.forces.metrics : {};
  for (const m in fo.metrics) metricRow(t, m, fo.metrics[m], rf[m]);
  box.appendChild(h("p", { class: "muted" }, "at " + Object.entries(fo.operating).map(([k, v]) => k + " " + v).join(", ") +
                    "; " + fo.legs + (fo.legs === 1 ? " leg" : " legs") + (fo.status !== "ok" ? "; " + (fo.failure ? fo.failure.message : fo.status) : "")));
  box.appendChild(t);
  if (fo.torque) {
    plot.style.display = "";
    const tq = f64(fo.torque), n = tq.length;
    let lo = Math.min(0, ...tq), hi = Math.max(0, ...tq);
    if (!(hi > lo)) hi = lo + 1;
    const y = (v) => 65 - 60 * (v - lo) / (hi - lo);
    el("line", { x1: 0, x2: 300, y1: y(0), y2: y(0), class: "axis" }, plot);
    let d = "";
    for (let k = 0; k < n; k++) if (isFinite(tq[k])) d += (d ? "L" : "M") + (300 * k / n).toFixed(1) + " " + y(tq[k]).toFixed(1);
    el("path", { d: d, fill: "none", stroke: "#8a3b2f", "stroke-width": 1.5 }, plot);
    el("text", { x: 2, y: 10, class: "axis-label" }, plot).textContent = "motor torque over the turn, " + short(lo, 3) + " … " + short(hi, 3) + " N·m";
  }
}

// -- parameters -------------------------------------------------------------------------------------------
function range(name, kind) {
  const r = S.refValues && name in S.refValues ? S.refValues[name] : S.params.find((p) => p[0] === name)[1];
  if (kind === "length") return [0.5 * r, 1.5 * r];
  return [r - 0.3 * S.size, r + 0.3 * S.size];
}
function buildParams() {
  const t = $("params");
  t.textContent = "";
  for (const [name, , kind] of S.params) {
    const tr = h("tr", { "data-param": name });
    const [lo, hi] = range(name, kind);
    const slider = h("input", { type: "range", min: lo, max: hi, step: (hi - lo) / 1000, "data-param-slider": name });
    const num = h("input", { type: "number", step: "any", class: "num", "data-param-field": name });
    slider.addEventListener("input", () => paramChange(name, Number(slider.value), true));
    slider.addEventListener("change", () => { S.editing = null; });
    num.addEventListener("change", () => { const v = Number(num.value); if (isFinite(v) && num.value !== "") paramChange(name, v, false); });
    tr.append(h("td", { class: "pname", title: kind }, name), h("td").appendChild(slider).parentNode, h("td").appendChild(num).parentNode);
    t.appendChild(tr);
  }
}
function paramValues() {
  for (const [name, value] of S.params) {
    const s = document.querySelector(`[data-param-slider="${CSS.escape(name)}"]`);
    const f = document.querySelector(`[data-param-field="${CSS.escape(name)}"]`);
    if (!s || !f) continue;
    if (document.activeElement !== s) s.value = value;
    if (document.activeElement !== f) f.value = String(value);
  }
}
function paramChange(name, value, live) {
  if (!live || S.editing !== name) { pushUndo(); S.editing = live ? name : null; }
  S.pending = { kind: "edit", body: () => ({ design: S.design, parameters: { [name]: value } }), t: performance.now() };
  pump();
}

// -- dragging -----------------------------------------------------------------------------------------------
function toModel(evt) {
  const pt = $("drawing").createSVGPoint();
  pt.x = evt.clientX; pt.y = evt.clientY;
  const p = pt.matrixTransform($("world").getScreenCTM().inverse());
  return [p.x, p.y];
}
function configMap() {
  const P = shown(), out = {};
  S.solve.vertices.forEach((v, i) => { out[v] = P[i]; });
  return out;
}
function startDrag(e, joint, handle) {
  if (S.playing) togglePlay();
  e.preventDefault();
  handle.setPointerCapture(e.pointerId);
  handle.classList.add("dragging");
  const gesture = { before: S.design, pushed: false };  // one undo step per drag, taken at its first accepted step
  S.drag = { joint: joint, handle: handle, gesture: gesture };
  const move = (ev) => {
    if (!S.drag) return;
    const t = performance.now();
    const to = toModel(ev);
    S.pending = { kind: "drag", joint: joint, to: to, t: t, gesture: gesture };
    pump();
  };
  const up = () => {
    handle.classList.remove("dragging");
    handle.removeEventListener("pointermove", move);
    handle.removeEventListener("pointerup", up);
    handle.removeEventListener("pointercancel", up);
    S.drag = null;
  };
  handle.addEventListener("pointermove", move);
  handle.addEventListener("pointerup", up);
  handle.addEventListener("pointercancel", up);
}
/** Send the latest pending step once the one in flight has come back (steps coalesce: never a queue). */
async function pump() {
  if (S.inflight || !S.pending) return;
  const job = S.pending;
  S.pending = null;
  S.inflight = true;
  try {
    if (job.kind === "drag") {
      job.sent = performance.now();
      const res = await api("POST", "/api/drag", { design: S.design, angle: S.angle, joint: job.joint, to: job.to, config: configMap() });
      job.received = performance.now();
      job.server = res.solve ? Object.values(res.solve.ms).reduce((a, b) => a + b, 0) : (res.ms ? res.ms.drag : null);
      if (res.error) { message(res.error); }
      else if (res.refused) {
        message(res.refused);
        const hd = G.handles[job.joint] || G.centre;
        if (hd) { hd.classList.add("refused"); setTimeout(() => hd.classList.remove("refused"), 600); }
      } else {
        if (!job.gesture.pushed) { pushUndo(job.gesture.before); job.gesture.pushed = true; }
        apply(res);
        message(res.note || "", true);
      }
      await frameDone(job, "drag");
    } else if (job.kind === "edit") {
      const res = await api("POST", "/api/edit", job.body());
      if (res.error) message(res.error); else { apply(res, { keepAngle: true }); message(""); }
      await frameDone(job, "edit");
    }
  } finally {
    S.inflight = false;
  }
  if (S.pending) pump();
}
function frameDone(job, kind) {
  const drawn = performance.now();
  return new Promise((resolve) => requestAnimationFrame(() => {
    const painted = performance.now();
    window.editTimings.push({ kind: kind, event: job.t, sent: job.sent, received: job.received, server: job.server,
                              drawn: drawn, painted: painted, ms: painted - job.t });
    resolve();
  }));
}

// -- undo, redo, reset, play ---------------------------------------------------------------------------------
function pushUndo(design) {
  S.undo.push(design || S.design);
  if (S.undo.length > 200) S.undo.shift();
  S.redo = [];
  buttons();
}
function buttons() { $("undo").disabled = !S.undo.length; $("redo").disabled = !S.redo.length; }
async function setDesign(design) {
  const res = await api("PUT", "/api/design", { design: design });
  if (res.error) { setStatus("error: " + res.error, "error"); return false; }
  apply(res, { keepAngle: true });
  return true;
}
async function undo() { if (!S.undo.length) return; S.redo.push(S.design); await setDesign(S.undo.pop()); buttons(); }
async function redo() { if (!S.redo.length) return; S.undo.push(S.design); await setDesign(S.redo.pop()); buttons(); }
async function reset() {
  pushUndo();
  const res = await api("POST", "/api/reset", {});
  if (res.error) { message(res.error); return; }
  apply(res, { refit: true });
  message("");
}
let lastFrame = 0;
function togglePlay() {
  S.playing = !S.playing;
  $("play").textContent = S.playing ? "Pause" : "Play";
  if (S.playing) { lastFrame = performance.now(); requestAnimationFrame(tick); }
}
function tick(now) {
  if (!S.playing) return;
  const n = S.solve.S, per = n / 3000;  // one turn in 3 s
  const adv = Math.floor((now - lastFrame) * per);
  if (adv >= 1) {
    lastFrame = now;
    S.k = (S.k + adv) % n; S.config = null; S.angle = S.solve.th[S.k];
    $("scrub").value = String(S.k);
    draw();
  }
  requestAnimationFrame(tick);
}

// -- study -------------------------------------------------------------------------------------------------
function studyPanel(st) {
  const body = $("study-body");
  body.textContent = "";
  if (!st) { body.appendChild(h("p", { class: "muted" }, "No results file is open.")); return; }
  $("study-panel").open = true;
  body.appendChild(h("p", { class: "muted" }, `${st.file}: ${st.variants.toLocaleString()} variants, ` +
    Object.entries(st.status).map(([k, v]) => `${v.toLocaleString()} ${k}`).join(", ") + ". Click a design to load it."));
  // the scatter
  const sc = st.scatter;
  if (sc.x && sc.points.length) {
    const sel = h("div", { class: "row" });
    const sx = h("select", { id: "scatter-x" }), sy = h("select", { id: "scatter-y" });
    for (const m of st.metrics) { sx.appendChild(h("option", { value: m }, m)); sy.appendChild(h("option", { value: m }, m)); }
    sx.value = sc.x; sy.value = sc.y;
    const re = async () => { const r = await api("GET", `/api/study?x=${encodeURIComponent(sx.value)}&y=${encodeURIComponent(sy.value)}`); if (!r.error) studyPanel(r); };
    sx.addEventListener("change", re); sy.addEventListener("change", re);
    sel.append("x", sx, "y", sy);
    body.appendChild(sel);
    const svg = el("svg", { class: "scatter", viewBox: "0 0 400 260", id: "scatter" });
    body.appendChild(svg);
    const xs = sc.points.map((p) => p[1]), ys = sc.points.map((p) => p[2]);
    const x0 = Math.min(...xs), x1 = Math.max(...xs), y0 = Math.min(...ys), y1 = Math.max(...ys);
    const X = (v) => 40 + 350 * (v - x0) / ((x1 - x0) || 1), Y = (v) => 235 - 225 * (v - y0) / ((y1 - y0) || 1);
    S.scatter = { X: X, Y: Y, x: sc.x, y: sc.y };
    el("line", { x1: 40, y1: 235, x2: 390, y2: 235, class: "axis" }, svg);
    el("line", { x1: 40, y1: 10, x2: 40, y2: 235, class: "axis" }, svg);
    el("text", { x: 215, y: 255, class: "axis-label", "text-anchor": "middle" }, svg).textContent = `${sc.x} (${short(x0)} … ${short(x1)})`;
    el("text", { x: 12, y: 125, class: "axis-label", transform: "rotate(-90 12 125)", "text-anchor": "middle" }, svg).textContent = `${sc.y} (${short(y0)} … ${short(y1)})`;
    for (const [v, x, y, b] of sc.points) {
      const c = el("circle", { cx: X(x), cy: Y(y), r: 2.4, fill: b ? "#2f5d8a" : "#c7ccd4", "data-variant": v }, svg);
      el("title", {}, c).textContent = `variant ${v}: ${sc.x} ${short(x)}, ${sc.y} ${short(y)}${b ? "" : " (screened out)"}`;
      c.addEventListener("click", () => loadVariant(v));
    }
    const mark = el("path", { id: "current-mark", fill: "#d0671f", stroke: "#fff", "stroke-width": 1 }, svg);
    el("title", {}, mark).textContent = "the design being edited";
    placeCurrentMark();
  }
  // the ranking
  if (st.ranking.length) {
    const t = h("table");
    const cols = Object.keys(st.ranking[0]).filter((c) => !["variant", "rank", "body_speed_ripple"].includes(c));
    const head = h("tr");
    ["#", "variant"].concat(cols).forEach((c) => head.appendChild(h("th", {}, c)));
    t.appendChild(head);
    for (const r of st.ranking) {
      const tr = h("tr", { "data-variant": r.variant });
      tr.appendChild(h("td", {}, r.rank)); tr.appendChild(h("td", {}, r.variant));
      cols.forEach((c) => tr.appendChild(h("td", {}, short(r[c]))));
      tr.addEventListener("click", () => loadVariant(r.variant));
      t.appendChild(tr);
    }
    body.appendChild(h("p", { class: "muted" }, `ranked by the ${st.ranked_by} (explorer rank)`));
    const box = h("div", { class: "scroll" });
    box.appendChild(t);
    body.appendChild(box);
    const m = /^variant (\d+) of /.exec(S.info.label);
    if (m) { const tr = t.querySelector(`tr[data-variant="${m[1]}"]`); if (tr) tr.className = "current"; }
  } else if (st.ranking_note) body.appendChild(h("p", { class: "muted" }, st.ranking_note));
}
function placeCurrentMark() {
  const m = document.getElementById("current-mark");
  if (!m || !S.scatter || !S.solve) return;
  const x = S.solve.metrics[S.scatter.x], y = S.solve.metrics[S.scatter.y];
  if (x === null || y === null || x === undefined || y === undefined) { m.setAttribute("d", ""); return; }
  const cx = S.scatter.X(x), cy = S.scatter.Y(y), r = 6;
  m.setAttribute("d", `M${cx} ${cy - r}L${cx + r * 0.3} ${cy - r * 0.3}L${cx + r} ${cy}L${cx + r * 0.3} ${cy + r * 0.3}L${cx} ${cy + r}L${cx - r * 0.3} ${cy + r * 0.3}L${cx - r} ${cy}L${cx - r * 0.3} ${cy - r * 0.3}Z`);
}
async function loadVariant(v) {
  pushUndo();
  const res = await api("POST", "/api/variant", { variant: v });
  if (res.error) { message(res.error); return; }
  start(res);
}
async function openStudy() {
  const res = await api("POST", "/api/study", { path: $("study-path").value });
  if (res.error) { message(res.error); return; }
  pushUndo();
  start(res);
}
async function openMechanism() {
  const name = $("mech-path").value.trim() || $("mech-select").value;
  const res = await api("POST", "/api/mechanism", { name: name });
  if (res.error) { message(res.error); return; }
  pushUndo();
  start(res);
}

// -- yield, save, share ----------------------------------------------------------------------------------------
async function computeYield() {
  const out = $("yield-value");
  out.textContent = "…";
  const res = await api("POST", "/api/yield", { design: S.design, tolerance: Number($("yield-tol").value),
                                                unit: $("yield-unit").value, copies: Number($("yield-copies").value) });
  if (res.error) { out.textContent = "–"; $("yield-note").textContent = res.error; return; }
  out.textContent = fmt(res.yield);
  $("yield-se").textContent = "± " + short(res.se, 2) + ` (${res.count} of ${res.copies})`;
  $("yield-note").textContent = res.describe + `; ${res.ms.toFixed(0)} ms`;
}
function defaultSavePath() {
  const f = $("save-format").value, n = S.design.name;
  return { toml: n + ".toml", svg: n + "-parts.svg", dxf: n + "-parts.dxf", kit: n + "-kit", handoff: n + "-start" }[f];
}
async function save() {
  const path = $("save-path").value.trim() || defaultSavePath();
  $("save-path").value = path;
  const body = { design: S.design, path: path, format: $("save-format").value, force: false };
  let res = await api("POST", "/api/save", Object.assign({}, body, { check: true }));
  if (!res.error && res.exists && res.exists.length) {
    if (!window.confirm(`${res.exists.join(", ")} already exists. Overwrite?`)) { $("save-result").textContent = "not saved"; return; }
    body.force = true;
  }
  if (res.error) { $("save-result").textContent = res.error; return; }
  res = await api("POST", "/api/save", body);
  $("save-result").textContent = res.error ? res.error
    : "written: " + res.written.join(", ") + (res.commands ? "\n\n" + res.commands.join("\n") : "");
}
function b64url(text) {
  const bytes = new TextEncoder().encode(text);
  let s = "";
  for (const b of bytes) s += String.fromCharCode(b);
  return btoa(s).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
}
function unb64url(text) {
  const s = atob(text.replace(/-/g, "+").replace(/_/g, "/"));
  return new TextDecoder().decode(Uint8Array.from(s, (c) => c.charCodeAt(0)));
}
function copyLink() {
  const url = location.origin + location.pathname + "#design=" + b64url(JSON.stringify(S.design));
  $("link").value = url;
  $("link").select();
  if (navigator.clipboard) navigator.clipboard.writeText(url).then(() => message("link copied", true), () => message("the link is in the field below; copy it from there", true));
}
async function download() {
  const res = await api("POST", "/api/toml", { design: S.design });
  if (res.error) { message(res.error); return; }
  const a = h("a", { href: URL.createObjectURL(new Blob([res.text], { type: "application/toml" })), download: res.name + ".toml" });
  document.body.appendChild(a); a.click(); a.remove();
}

// -- start -------------------------------------------------------------------------------------------------------
function start(info) {
  S.info = info;
  S.meta = info.metrics;
  setReference(info.reference);
  S.k = 0; S.angle = 0; S.config = null; S.topo = "";
  apply(info.current, { refit: true });
  studyPanel(info.study);
}
/** A link that holds a design (#design=base64url of its JSON): it becomes the current design. */
async function fromLink() {
  const m = /#design=([A-Za-z0-9_-]*)/.exec(location.hash);
  if (!m) return;
  let design = null;
  try { design = JSON.parse(unb64url(m[1])); } catch (e) {
    setStatus("error: the link's design cannot be read (" + e.message + ")", "error");
    return;
  }
  pushUndo();
  if (await setDesign(design)) fit();
}
async function main() {
  const t0 = performance.now();
  const info = await api("GET", "/api/session");
  if (info.error) { setStatus("error: " + info.error, "error"); document.body.setAttribute("data-ready", "1"); return; }
  const sel = $("mech-select");
  for (const b of info.builtins) sel.appendChild(h("option", { value: b }, b));
  const fmtSel = $("save-format");
  for (const f in info.save_formats) fmtSel.appendChild(h("option", { value: f, title: info.save_formats[f] }, f));
  start(info);
  await fromLink();
  window.addEventListener("hashchange", fromLink);
  $("undo").addEventListener("click", undo);
  $("redo").addEventListener("click", redo);
  $("reset").addEventListener("click", reset);
  $("play").addEventListener("click", togglePlay);
  $("scrub").addEventListener("input", () => { S.k = Number($("scrub").value); S.config = null; S.angle = S.solve.th[S.k]; draw(); });
  for (const id of ["show-ghost", "show-walker", "show-traces", "show-labels"]) $(id).addEventListener("change", draw);
  $("yield-run").addEventListener("click", computeYield);
  $("save").addEventListener("click", save);
  $("save-format").addEventListener("change", () => { $("save-path").value = defaultSavePath(); });
  $("copy-link").addEventListener("click", copyLink);
  $("download").addEventListener("click", download);
  $("study-open").addEventListener("click", openStudy);
  $("mech-open").addEventListener("click", openMechanism);
  document.addEventListener("keydown", (e) => {
    if (e.target instanceof HTMLInputElement) return;
    if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === "z") { e.preventDefault(); (e.shiftKey ? redo : undo)(); }
    else if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === "y") { e.preventDefault(); redo(); }
    else if (e.key === " ") { e.preventDefault(); togglePlay(); }
  });
  window.addEventListener("resize", () => draw());
  window.editFirstLoad = performance.now() - t0;  // from this script's start; performance.now() counts from navigation
  window.editReadyAt = performance.now();
  document.body.setAttribute("data-ready", "1");
}
main();
