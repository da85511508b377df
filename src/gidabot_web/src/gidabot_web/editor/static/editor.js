// The GidaBot building editor's page (plain JS, no library: it works offline). Everything it changes goes to the
// server as edits of the building file (POST /api/edit); the server checks each change as `gidabot check` does
// and this page shows the verdict, the problems on the map, and the preview's robots.
"use strict";

(() => {
  const LANGS = ["eu", "en", "es"];
  const CATEGORIES = ["office", "lab", "lecture", "service", "entrance", "meeting", "other"];
  const DRIVES = ["differential", "synchro"];
  const PREVIEW_STARTING = "Preview starting: the simulated building takes a few seconds to come up";
  const HANDLE = 26;          // px from a place to its heading handle
  const PICK = 10;            // px: how near a click must be to pick something

  const S = {
    csrf: null, rev: -1, doc: null, floors: [], files: {maps: [], images: []}, check: null, preview: null,
    undo: null, redo: null, dirty: false, floor: 0, tab: "locations", selected: null, mode: "select",
    search: "", bpAlpha: 0.45, ghost: true, images: {}, views: {}, zone: [], pairs: [], pending: null,
    reference: null, drag: null, tours: [], fitNote: "",
  };
  const $ = (id) => document.getElementById(id);

  // ------------------------------------------------------------------ server
  async function api(method, path, body) {
    const headers = {};
    if (body !== undefined) headers["Content-Type"] = "application/json";
    if (method === "POST") headers["X-CSRF-Token"] = S.csrf || "";
    const r = await fetch(path, {method, headers, body: body === undefined ? undefined : JSON.stringify(body),
                                 credentials: "same-origin"});
    let data = {};
    try { data = await r.json(); } catch (e) { data = {}; }
    if (!r.ok) {
      const err = new Error(data.message || `${r.status}`);
      err.status = r.status; err.reason = data.error;
      throw err;
    }
    return data;
  }

  async function login() {
    const m = /token=([A-Za-z0-9_-]+)/.exec(location.hash);
    if (m) {
      const r = await fetch("/api/session", {method: "POST", headers: {"X-Editor-Token": m[1]},
                                             credentials: "same-origin"});
      if (!r.ok) throw new Error("the token in the address is wrong: open the address gidabot edit printed");
      S.csrf = (await r.json()).csrf;
      history.replaceState(null, "", location.pathname);       // the token leaves the address bar
      return;
    }
    S.csrf = (await api("GET", "/api/session")).csrf;
  }

  async function refresh(full) {
    const data = await api("GET", full ? "/api/state" : `/api/state?since=${S.rev}`);
    S.check = data.check; S.preview = data.preview; S.undo = data.undo; S.redo = data.redo; S.dirty = data.dirty;
    if (data.doc) {
      S.doc = data.doc; S.floors = data.floors; S.files = data.files; S.rev = data.revision;
      $("building-name").textContent = `— ${S.doc.name || data.folder}`;
      if (S.floor >= floors().length) S.floor = Math.max(0, floors().length - 1);
      loadImages();
      renderSide();
    }
    renderStatus();
    draw();
  }

  // a change: the server applies it (or says why not), then the page shows the document again
  async function change(path, body) {
    try {
      await api("POST", path, body);
      say("");
    } catch (e) {
      say(e.message);
    }
    await refresh(true);
  }
  const edit = (edits, label) => change("/api/edit", {edits, label});

  function say(text, info) {
    const m = $("message");
    m.hidden = !text; m.textContent = text || ""; m.className = info ? "message info" : "message";
  }

  // ------------------------------------------------------------------ document helpers
  const floors = () => (S.doc && Array.isArray(S.doc.floors)) ? S.doc.floors : [];
  const list = (name) => (S.doc && Array.isArray(S.doc[name])) ? S.doc[name] : [];
  const floorDoc = () => floors()[S.floor] || null;
  const floorId = () => (floorDoc() ? floorDoc().id : null);
  const sameFloor = (a, b) => typeof a === "number" && typeof b === "number" && Math.abs(a - b) < 1e-3;
  const fmt = (v) => (typeof v === "number" ? String(Math.round(v * 1000) / 1000) : String(v));
  const name = (item) => (item && item.names && (item.names.en || item.names.eu || item.names.es)) || "";
  const round = (v, d) => Math.round(v * 10 ** d) / 10 ** d;

  function freeId(prefix, taken) {
    for (let i = 1; ; i++) if (!taken.has(`${prefix}${i}`)) return `${prefix}${i}`;
  }
  function allIds() {
    return new Set([...list("locations").map((l) => l.id), ...list("connectors").map((c) => c.id)].map(String));
  }

  // ------------------------------------------------------------------ images
  function image(name) {
    if (!name) return null;
    if (!S.images[name]) {
      const img = new Image();
      img.onload = () => draw();
      img.src = `/files/${encodeURIComponent(name)}?r=${Date.now()}`;
      S.images[name] = img;
    }
    const img = S.images[name];
    return img.complete && img.naturalWidth ? img : null;
  }
  function loadImages() {
    for (const f of S.floors) {
      if (f.map) image(f.map.image);
      if (f.blueprint) image(f.blueprint.image);
    }
  }

  // ------------------------------------------------------------------ geometry (affine: [a, b, c, d, e, f] as canvas)
  const mul = (m, n) => [m[0] * n[0] + m[2] * n[1], m[1] * n[0] + m[3] * n[1], m[0] * n[2] + m[2] * n[3],
    m[1] * n[2] + m[3] * n[3], m[0] * n[4] + m[2] * n[5] + m[4], m[1] * n[4] + m[3] * n[5] + m[5]];
  const apply = (m, x, y) => [m[0] * x + m[2] * y + m[4], m[1] * x + m[3] * y + m[5]];
  function inv(m) {
    const det = m[0] * m[3] - m[1] * m[2];
    return [m[3] / det, -m[1] / det, -m[2] / det, m[0] / det, (m[2] * m[5] - m[3] * m[4]) / det,
      (m[1] * m[4] - m[0] * m[5]) / det];
  }
  // a floor's map image pixel (col right, row down) from its map metres
  function pxFromMetres(info) {
    const [ox, oy, yaw] = info.origin, r = info.resolution, c = Math.cos(yaw), s = Math.sin(yaw);
    // local = R(-yaw) (p - o); col = lx / r; row = H - ly / r
    const local = [c, -s, s, c, -(c * ox + s * oy), -(-s * ox + c * oy)];
    return mul([1 / r, 0, 0, -1 / r, 0, info.height], local);
  }
  // map metres from a blueprint pixel (the inverse of blueprint_transform)
  function metresFromBlueprint(t) {
    const s = t.scale, r = t.rotation || 0, c = Math.cos(r), n = Math.sin(r);
    const [u0, v0] = t.origin_px;
    // (u, v) = (u0, v0) + s [[c, -n], [-n, -c]] (x, y)
    return inv([s * c, -s * n, -s * n, -s * c, u0, v0]);
  }
  // this floor's map metres from another floor's (its aligned_to: this -> other)
  function alignedMatrix(a) {
    const [x, y, yaw] = a.pose, c = Math.cos(yaw), s = Math.sin(yaw);
    return [c, s, -s, c, x, y];            // other-from-this
  }

  // a canvas view: screen = view * content (content: map image px, or blueprint px)
  function view(canvasId) {
    if (!S.views[canvasId]) S.views[canvasId] = {m: null, key: ""};
    return S.views[canvasId];
  }
  function fitView(canvas, w, h, key) {
    const v = view(canvas.id);
    if (v.key === key && v.m) return v;
    const k = Math.min(canvas.width / w, canvas.height / h) * 0.96;
    v.m = [k, 0, 0, k, (canvas.width - w * k) / 2, (canvas.height - h * k) / 2];
    v.key = key;
    return v;
  }
  function mapScreen(canvasId, floorIndex) {
    const info = S.floors[floorIndex] && S.floors[floorIndex].map;
    if (!info) return null;
    return mul(view(canvasId).m, pxFromMetres(info));
  }
  function toScreen(canvasId, x, y) {
    const canvas = $(canvasId);
    if (canvasId === "other" && S.mode === "align") {
      const [sx, sy] = apply(view("other").m, x, y);
      return [sx * canvas.clientWidth / canvas.width, sy * canvas.clientHeight / canvas.height];
    }
    const index = canvasId === "other" ? S.reference : S.floor;
    const m = mapScreen(canvasId, index);
    const [sx, sy] = apply(m, x, y);
    return [sx * canvas.clientWidth / canvas.width, sy * canvas.clientHeight / canvas.height];
  }
  function eventPoint(ev, canvas) {
    const r = canvas.getBoundingClientRect();
    return [(ev.clientX - r.left) * canvas.width / r.width, (ev.clientY - r.top) * canvas.height / r.height];
  }

  // ------------------------------------------------------------------ drawing
  function sizeCanvas(canvas) {
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (w && h && (canvas.width !== w || canvas.height !== h)) {
      canvas.width = w; canvas.height = h;
      view(canvas.id).key = "";
    }
  }

  function draw() {
    const canvas = $("map");
    const split = S.mode === "align" || S.mode === "floors";
    $("other-view").hidden = !split;            // first: the map's size depends on it
    $("align-panel").hidden = !split;
    sizeCanvas(canvas);
    const ctx = canvas.getContext("2d");
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    const f = S.floors[S.floor], fd = floorDoc();
    if (!f || !f.map || !fd) {
      ctx.fillStyle = "#56656f"; ctx.font = "14px sans-serif";
      ctx.fillText(f && f.note ? f.note : "No floor: add one (its map and blueprint must be files of the folder).",
                   20, 30);
      drawOther();
      return;
    }
    const v = fitView(canvas, f.map.width, f.map.height, `floor${S.floor}:${f.map.image}`);
    const toScreenM = mul(v.m, pxFromMetres(f.map));
    const img = image(f.map.image);
    ctx.imageSmoothingEnabled = false;
    if (img) { ctx.setTransform(...v.m); ctx.drawImage(img, 0, 0); }
    // the floor below (or the floor this one is aligned to) as a ghost
    const ghost = ghostFloor();
    if (S.ghost && ghost !== null && S.floors[ghost].map) {
      const gimg = image(S.floors[ghost].map.image);
      const align = fd.aligned_to ? alignedMatrix(fd.aligned_to) : [1, 0, 0, 1, 0, 0];
      const thisFromOther = fd.aligned_to && sameFloor(fd.aligned_to.floor, floors()[ghost].id) ? inv(align)
        : [1, 0, 0, 1, 0, 0];
      if (gimg) {
        ctx.globalAlpha = 0.3;
        ctx.setTransform(...mul(mul(toScreenM, thisFromOther), inv(pxFromMetres(S.floors[ghost].map))));
        ctx.drawImage(gimg, 0, 0);
        ctx.globalAlpha = 1;
      }
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      for (const c of list("connectors")) {
        const m = (c.meeting || []).find((mm) => sameFloor(mm.floor, floors()[ghost].id));
        if (!m || !Array.isArray(m.pose)) continue;
        const [gx, gy] = apply(thisFromOther, m.pose[0], m.pose[1]);
        const [sx, sy] = apply(toScreenM, gx, gy);
        ctx.strokeStyle = "#1f6fb2"; ctx.setLineDash([3, 3]); ctx.lineWidth = 1.5;
        ctx.strokeRect(sx - 8, sy - 8, 16, 16); ctx.setLineDash([]);
      }
    }
    // the blueprint over the map
    const bp = f.blueprint && image(f.blueprint.image);
    if (bp && fd.blueprint_transform && Array.isArray(fd.blueprint_transform.origin_px)
        && fd.blueprint_transform.scale > 0 && S.bpAlpha > 0) {
      ctx.globalAlpha = S.bpAlpha;
      ctx.imageSmoothingEnabled = true;
      ctx.setTransform(...mul(toScreenM, metresFromBlueprint(fd.blueprint_transform)));
      ctx.drawImage(bp, 0, 0);
      ctx.globalAlpha = 1;
    }
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    drawItems(ctx, toScreenM, f.map.resolution);
    drawOther();
  }

  function ghostFloor() {
    const fd = floorDoc();
    if (!fd) return null;
    if (fd.aligned_to) {
      const i = floors().findIndex((x) => sameFloor(x.id, fd.aligned_to.floor));
      if (i >= 0) return i;
    }
    return S.floor > 0 ? S.floor - 1 : null;
  }

  function badItems() {
    const bad = new Set();
    for (const p of (S.check && S.check.problems) || []) {
      const it = p.item;
      if (!it) continue;
      if (it.index !== undefined) bad.add(`${it.list}:${it.index}`);
      else {
        const i = list(it.list).findIndex((x) => String(x.id ?? x.name) === it.id);
        if (i >= 0) bad.add(`${it.list}:${i}`);
      }
    }
    return bad;
  }

  function drawPose(ctx, m, pose, color, label, selected, shape) {
    const [sx, sy] = apply(m, pose[0], pose[1]);
    const [hx, hy] = apply(m, pose[0] + Math.cos(pose[2] || 0), pose[1] + Math.sin(pose[2] || 0));
    const d = Math.hypot(hx - sx, hy - sy) || 1;
    const ax = sx + (hx - sx) / d * HANDLE, ay = sy + (hy - sy) / d * HANDLE;
    ctx.strokeStyle = color; ctx.fillStyle = color; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(sx, sy); ctx.lineTo(ax, ay); ctx.stroke();
    ctx.beginPath(); ctx.arc(ax, ay, 4, 0, 2 * Math.PI); ctx.fill();
    ctx.beginPath();
    if (shape === "square") ctx.rect(sx - 7, sy - 7, 14, 14); else ctx.arc(sx, sy, 7, 0, 2 * Math.PI);
    ctx.fill();
    if (selected) { ctx.strokeStyle = "#e8772e"; ctx.lineWidth = 3; ctx.stroke(); }
    ctx.fillStyle = "#1b2730"; ctx.font = "12px sans-serif";
    ctx.fillText(label, sx + 9, sy - 8);
  }

  function drawItems(ctx, m, resolution) {
    const fid = floorId(), bad = badItems(), sel = S.selected;
    const isSel = (l, i) => sel && sel.list === l && sel.index === i;
    // keep-out zones
    (floorDoc().keep_out || []).forEach((z, i) => {
      if (!Array.isArray(z.polygon) || z.polygon.length < 2) return;
      ctx.beginPath();
      z.polygon.forEach((p, k) => { const [x, y] = apply(m, p[0], p[1]); k ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
      ctx.closePath();
      ctx.fillStyle = "rgba(179, 38, 30, 0.25)"; ctx.fill();
      ctx.strokeStyle = isSel("zones", i) ? "#e8772e" : "#b3261e"; ctx.lineWidth = isSel("zones", i) ? 3 : 2;
      ctx.stroke();
      if (isSel("zones", i)) {
        for (const p of z.polygon) {
          const [x, y] = apply(m, p[0], p[1]);
          ctx.fillStyle = "#e8772e"; ctx.fillRect(x - 4, y - 4, 8, 8);
        }
      }
      const [x, y] = apply(m, z.polygon[0][0], z.polygon[0][1]);
      ctx.fillStyle = "#b3261e"; ctx.font = "12px sans-serif"; ctx.fillText(String(z.id), x + 4, y - 4);
    });
    // robots' homes (discs of their radius)
    list("robots").forEach((r, i) => {
      if (!sameFloor(r.floor, fid) || !Array.isArray(r.home)) return;
      const [sx, sy] = apply(m, r.home[0], r.home[1]);
      const rad = (r.radius || 0.3) / resolution * Math.abs(view("map").m[0]);
      ctx.fillStyle = "rgba(31, 111, 178, 0.25)";
      ctx.beginPath(); ctx.arc(sx, sy, rad, 0, 2 * Math.PI); ctx.fill();
      drawPose(ctx, m, r.home, bad.has(`robots:${i}`) ? "#b3261e" : "#1f6fb2", `${r.name} (home)`,
               isSel("robots", i), "circle");
    });
    // connectors' meeting points
    list("connectors").forEach((c, i) => {
      for (const mm of c.meeting || []) {
        if (!sameFloor(mm.floor, fid) || !Array.isArray(mm.pose)) continue;
        drawPose(ctx, m, mm.pose, bad.has(`connectors:${i}`) ? "#b3261e" : "#6a3d9a", `${c.id} (${c.kind})`,
                 isSel("connectors", i), "square");
      }
    });
    // places
    list("locations").forEach((l, i) => {
      if (!sameFloor(l.floor, fid) || !Array.isArray(l.pose)) return;
      drawPose(ctx, m, l.pose, bad.has(`locations:${i}`) ? "#b3261e" : (l.featured ? "#0b6e69" : "#3d4a52"),
               String(l.id), isSel("locations", i), "circle");
    });
    // where the checks found problems on this floor
    for (const p of [...((S.check && S.check.problems) || []), ...((S.check && S.check.warnings) || [])]) {
      if (!sameFloor(p.floor, fid)) continue;
      const warn = (S.check.warnings || []).includes(p);
      for (const [x, y, what] of p.marks || []) {
        const [sx, sy] = apply(m, x, y);
        ctx.strokeStyle = warn ? "#b7791f" : "#b3261e"; ctx.fillStyle = ctx.strokeStyle; ctx.lineWidth = 2.5;
        ctx.beginPath();
        if (what === "closed") {
          ctx.moveTo(sx - 7, sy - 7); ctx.lineTo(sx + 7, sy + 7); ctx.moveTo(sx + 7, sy - 7); ctx.lineTo(sx - 7, sy + 7);
          ctx.stroke();
        } else if (what === "narrow") {
          ctx.moveTo(sx, sy - 8); ctx.lineTo(sx + 8, sy); ctx.lineTo(sx, sy + 8); ctx.lineTo(sx - 8, sy); ctx.closePath();
          ctx.stroke();
          ctx.font = "11px sans-serif"; ctx.fillText("narrow", sx + 10, sy + 4);
        } else if (what === "reached") {
          ctx.arc(sx, sy, 3, 0, 2 * Math.PI); ctx.fill();
        } else {
          ctx.arc(sx, sy, 12, 0, 2 * Math.PI); ctx.stroke();
        }
      }
    }
    // the zone being drawn
    if (S.mode === "zone" && S.zone.length) {
      ctx.strokeStyle = "#b3261e"; ctx.lineWidth = 2; ctx.setLineDash([5, 4]); ctx.beginPath();
      S.zone.forEach((p, k) => { const [x, y] = apply(m, p[0], p[1]); k ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
      ctx.stroke(); ctx.setLineDash([]);
      for (const p of S.zone) { const [x, y] = apply(m, p[0], p[1]); ctx.fillStyle = "#b3261e"; ctx.fillRect(x - 3, y - 3, 6, 6); }
    }
    // alignment points on the map
    if (S.mode === "align" || S.mode === "floors") drawPairs(ctx, m, 0);
    // the preview's robots
    const robots = (S.preview && S.preview.robots) || {};
    for (const [rname, p] of Object.entries(robots)) {
      if (!sameFloor(p.floor, fid)) continue;
      const r = list("robots").find((x) => x.name === rname);
      const [sx, sy] = apply(m, p.x, p.y);
      const rad = Math.max(6, ((r && r.radius) || 0.3) / resolution * Math.abs(view("map").m[0]));
      ctx.fillStyle = "#e8772e"; ctx.strokeStyle = "#fff"; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.arc(sx, sy, rad, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      const [hx, hy] = apply(m, p.x + Math.cos(p.yaw), p.y + Math.sin(p.yaw));
      const d = Math.hypot(hx - sx, hy - sy) || 1;
      ctx.beginPath(); ctx.moveTo(sx, sy); ctx.lineTo(sx + (hx - sx) / d * rad, sy + (hy - sy) / d * rad); ctx.stroke();
      ctx.fillStyle = "#1b2730"; ctx.font = "bold 12px sans-serif"; ctx.fillText(rname, sx + rad + 3, sy + 4);
    }
  }

  function drawPairs(ctx, m, side) {
    const pts = S.pairs.map((p) => p[side]);
    if (S.pending && side === 0) pts.push(S.pending);
    pts.forEach((p, k) => {
      const [sx, sy] = apply(m, p[0], p[1]);
      ctx.strokeStyle = "#e8772e"; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.moveTo(sx - 9, sy); ctx.lineTo(sx + 9, sy); ctx.moveTo(sx, sy - 9); ctx.lineTo(sx, sy + 9);
      ctx.stroke();
      ctx.fillStyle = "#e8772e"; ctx.font = "bold 13px sans-serif"; ctx.fillText(String(k + 1), sx + 6, sy - 6);
    });
  }

  // the second view: the blueprint (align) or the other floor's map (align floors)
  function drawOther() {
    const canvas = $("other");
    if (S.mode !== "align" && S.mode !== "floors") return;
    sizeCanvas(canvas);
    const ctx = canvas.getContext("2d");
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    if (S.mode === "align") {
      const f = S.floors[S.floor];
      const img = f && f.blueprint && image(f.blueprint.image);
      $("other-title").textContent = f && f.blueprint ? `Blueprint ${f.blueprint.image}` : "No blueprint";
      if (!img) return;
      const v = fitView(canvas, img.naturalWidth, img.naturalHeight, `bp${S.floor}:${f.blueprint.image}`);
      ctx.setTransform(...v.m); ctx.drawImage(img, 0, 0); ctx.setTransform(1, 0, 0, 1, 0, 0);
      drawPairs(ctx, v.m, 1);
    } else {
      const i = S.reference;
      const f = i !== null ? S.floors[i] : null;
      $("other-title").textContent = f ? `Floor ${fmt(floors()[i].id)}: ${name(floors()[i])}` : "Choose the other floor";
      if (!f || !f.map) return;
      const img = image(f.map.image);
      const v = fitView(canvas, f.map.width, f.map.height, `other${i}:${f.map.image}`);
      if (img) { ctx.imageSmoothingEnabled = false; ctx.setTransform(...v.m); ctx.drawImage(img, 0, 0); }
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      drawPairs(ctx, mul(v.m, pxFromMetres(f.map)), 1);
    }
  }

  // ------------------------------------------------------------------ status, problems, preview
  function renderStatus() {
    const st = $("status"), c = S.check;
    if (!c || c.revision !== S.rev) {
      st.className = "status checking"; st.textContent = "checking…";
    } else if (c.accepted) {
      st.className = "status ok";
      st.textContent = `✓ accepted${c.warnings.length ? `, ${c.warnings.length} warning(s)` : ""}`;
    } else {
      st.className = "status bad"; st.textContent = `✗ ${c.problems.length} problem(s): gidabot check would refuse it`;
    }
    $("undo").disabled = !S.undo; $("undo").title = S.undo ? `Undo: ${S.undo} (Ctrl+Z)` : "Nothing to undo";
    $("redo").disabled = !S.redo; $("redo").title = S.redo ? `Redo: ${S.redo} (Ctrl+Y)` : "Nothing to redo";
    $("save").textContent = S.dirty ? "Save*" : "Save";
    $("summary").textContent = c ? c.summary : "";
    const fill = (ul, items) => {
      ul.replaceChildren(...items.map((p) => {
        const li = document.createElement("li");
        const b = document.createElement("b");
        b.textContent = p.where;
        li.append(b, `: ${p.message}`);
        li.addEventListener("click", () => goTo(p));
        return li;
      }));
    };
    fill($("problems"), (c && c.problems) || []);
    fill($("warnings"), (c && c.warnings) || []);
    $("warnings-title").hidden = !(c && c.warnings.length);
    const p = S.preview || {state: "idle"};
    const robots = Object.keys(p.robots || {}).length;
    $("preview-state").textContent = p.state === "idle" ? "not running" :
      `${p.state}${p.tour ? ` (${p.tour})` : ""}, ${p.elapsed} s${robots ? `, ${robots} robots` : ""}: ${p.message || ""}`;
    const running = p.state === "running" || p.state === "starting";
    if (p.state !== "starting" && $("message").textContent === PREVIEW_STARTING) say("");   // it came up, or ended
    $("preview-start").disabled = running || p.state === "stopping";
    $("preview-stop").disabled = !running;
  }

  function goTo(p) {
    const it = p.item;
    if (p.floor !== null && p.floor !== undefined) {
      const i = floors().findIndex((f) => sameFloor(f.id, p.floor));
      if (i >= 0) S.floor = i;
    }
    if (it) {
      if (it.list === "floors") {
        S.floor = it.index;
        if (it.zone !== undefined) { S.tab = "zones"; S.selected = {list: "zones", index: it.zone}; }
      } else {
        const index = it.index !== undefined ? it.index
          : list(it.list).findIndex((x) => String(x.id ?? x.name) === it.id || x.name === it.id);
        if (index >= 0) { S.tab = it.list; S.selected = {list: it.list, index}; }
        const item = list(it.list)[index];
        if (item && item.floor !== undefined && it.list !== "connectors") {
          const fi = floors().findIndex((f) => sameFloor(f.id, item.floor));
          if (fi >= 0) S.floor = fi;
        }
      }
    }
    renderSide(); draw();
  }

  // ------------------------------------------------------------------ side panel
  function renderSide() {
    // the forms are made again: the field that had the focus (Tab after a change) gets it back
    const active = document.activeElement;
    const focus = active && active.name && active.form ? [active.form.id, active.name] : null;
    renderPanels();
    if (focus) {
      const again = document.querySelector(`#${focus[0]} [name="${focus[1]}"]`);
      if (again) again.focus();
    }
  }

  function renderPanels() {
    // floors
    const ul = $("floors");
    ul.replaceChildren(...floors().map((f, i) => {
      const li = document.createElement("li");
      li.textContent = `${fmt(f.id)} · ${name(f)}${S.floors[i] && S.floors[i].note ? " ⚠" : ""}`;
      li.className = i === S.floor ? "on" : "";
      li.dataset.index = i;
      li.addEventListener("click", () => { S.floor = i; S.selected = S.selected && S.selected.list === "zones" ? null
        : S.selected; S.pairs = []; S.pending = null; S.fitNote = ""; renderSide(); draw(); });
      return li;
    }));
    renderFloorForm();
    for (const b of document.querySelectorAll(".tab")) b.classList.toggle("on", b.dataset.tab === S.tab);
    for (const b of document.querySelectorAll(".mode")) b.classList.toggle("on", b.dataset.mode === S.mode);
    renderItems();
    renderItemForm();
    renderReference();
    renderPairs();
    hint();
  }

  function field(form, label, input, wide) {
    const l = document.createElement("label");
    l.textContent = label;
    input.setAttribute("aria-label", label);
    if (wide) { input.classList.add("wide"); form.append(input); return input; }
    form.append(l, input);
    return input;
  }
  function textInput(value, onChange, kind) {
    const i = document.createElement("input");
    i.type = kind || "text";
    if (kind === "number") i.step = "any";
    i.value = value === undefined || value === null ? "" : String(value);
    i.addEventListener("change", () => onChange(i.value));
    return i;
  }
  function selectInput(options, value, onChange) {
    const s = document.createElement("select");
    for (const [v, text] of options) {
      const o = document.createElement("option");
      o.value = String(v); o.textContent = text;
      if (String(v) === String(value)) o.selected = true;
      s.append(o);
    }
    s.addEventListener("change", () => onChange(s.value));
    return s;
  }
  function button(text, onClick, cls) {
    const b = document.createElement("button");
    b.type = "button"; b.textContent = text;
    if (cls) b.className = cls;
    b.addEventListener("click", onClick);
    return b;
  }
  const num = (v) => { const n = Number(String(v).replace(",", ".")); return Number.isFinite(n) ? n : v; };
  const idValue = (v) => v;   // ids stay text (room numbers: '014')

  function renderFloorForm() {
    const form = $("floor-form"), f = floorDoc(), i = S.floor;
    form.replaceChildren();
    if (!f) return;
    const set = (path, value, label) => edit([{op: "set", path: ["floors", i, ...path], value}], label);
    field(form, "Floor id", textInput(f.id, (v) => change("/api/floor/id", {floor: i, id: num(v)}), "number"))
      .name = "floor-id";
    for (const lang of LANGS) {
      field(form, `Name (${lang})`, textInput((f.names || {})[lang], (v) => set(["names", lang], v, "floor name")))
        .name = `floor-name-${lang}`;
    }
    field(form, "Map", selectInput(S.files.maps.map((m) => [m, m]), f.map, (v) => set(["map"], v, "floor map")))
      .name = "floor-map";
    field(form, "Blueprint", selectInput(S.files.images.map((m) => [m, m]), f.blueprint,
                                          (v) => set(["blueprint"], v, "floor blueprint"))).name = "floor-blueprint";
    const t = f.blueprint_transform || {};
    const info = document.createElement("span");
    info.className = "wide";
    info.textContent = `Blueprint: ${fmt(t.scale)} px/m, origin (${(t.origin_px || []).map(fmt).join(", ")}) px, ` +
      `rotation ${fmt((t.rotation || 0) * 180 / Math.PI)}°${S.fitNote ? ` — ${S.fitNote}` : ""}`;
    info.id = "transform-info";
    form.append(info);
    const skipped = (S.files && S.files.left_out) || [];
    if (skipped.length) {
      const note = document.createElement("span");
      note.className = "wide"; note.id = "left-out"; note.style.color = "#b3261e";
      note.textContent = "Files of the folder left out: " +
        skipped.map((f) => `${JSON.stringify(f.name)}: ${f.reason}`).join("; ");
      form.append(note);
    }
    if (S.floors[i] && S.floors[i].note) {
      const note = document.createElement("span");
      note.className = "wide"; note.style.color = "#b3261e"; note.textContent = S.floors[i].note;
      form.append(note);
    }
  }

  function zones() { return (floorDoc() && floorDoc().keep_out) || []; }
  function items() {
    if (S.tab === "zones") return zones();
    return list(S.tab);
  }
  function itemLabel(item) {
    if (S.tab === "robots") return `${item.name} · floor ${fmt(item.floor)}`;
    if (S.tab === "zones") return `${item.id} (${(item.polygon || []).length} corners)`;
    if (S.tab === "connectors") return `${item.id} · ${item.kind} · ${name(item)}`;
    return `${item.id} · floor ${fmt(item.floor)} · ${name(item)}`;
  }

  function renderItems() {
    const bad = badItems(), q = S.search.toLowerCase();
    const ul = $("items");
    const rows = [];
    items().forEach((item, i) => {
      const text = itemLabel(item);
      const hay = `${text} ${Object.values(item.names || {}).join(" ")}`.toLowerCase();
      if (q && !hay.includes(q)) return;
      const li = document.createElement("li");
      li.textContent = text;
      li.dataset.index = i;
      const key = S.tab === "zones" ? `floors:${S.floor}` : `${S.tab}:${i}`;
      li.className = (S.selected && S.selected.list === S.tab && S.selected.index === i ? "on " : "") +
        (S.tab !== "zones" && bad.has(key) ? "bad" : "");
      li.addEventListener("click", () => select(S.tab, i));
      rows.push(li);
    });
    ul.replaceChildren(...rows);
    const on = ul.querySelector("li.on");
    if (on) on.scrollIntoView({block: "nearest"});
    const row = $("item-add-row");
    row.replaceChildren();
    if (S.tab === "locations") row.append(button("Add place (click on the map)", () => setMode("place")));
    if (S.tab === "connectors") {
      row.append(button("Add lift", () => addConnector("lift")), button("Add staircase", () => addConnector("stairs")));
    }
    if (S.tab === "robots") row.append(button("Add robot", addRobot));
    if (S.tab === "zones") row.append(button("Draw keep-out zone", () => setMode("zone")));
    if (S.selected && S.selected.list === S.tab && items()[S.selected.index]) {
      row.append(button("Delete", deleteSelected, "danger"));
    }
  }

  function select(listName, index) {
    S.tab = listName; S.selected = {list: listName, index};
    const item = listName === "zones" ? null : list(listName)[index];
    if (item && item.floor !== undefined) {
      const fi = floors().findIndex((f) => sameFloor(f.id, item.floor));
      if (fi >= 0) S.floor = fi;
    }
    renderSide(); draw();
  }

  function renderItemForm() {
    const form = $("item-form");
    form.replaceChildren();
    const sel = S.selected;
    if (!sel || sel.list !== S.tab) return;
    const item = items()[sel.index];
    if (!item) return;
    const base = sel.list === "zones" ? ["floors", S.floor, "keep_out", sel.index] : [sel.list, sel.index];
    const set = (path, value, label) => edit([{op: "set", path: [...base, ...path], value}], label);
    const floorOptions = floors().map((f) => [f.id, `${fmt(f.id)} · ${name(f)}`]);
    if (sel.list === "locations") {
      field(form, "Id", textInput(item.id, (v) => set(["id"], idValue(v), "place id"))).name = "id";
      field(form, "Floor", selectInput(floorOptions, item.floor, (v) => set(["floor"], num(v), "place floor")));
      namesFields(form, item, set);
      field(form, "Category", selectInput(CATEGORIES.map((c) => [c, c]), item.category,
                                           (v) => set(["category"], v, "place category"))).name = "category";
      const fe = document.createElement("input");
      fe.type = "checkbox"; fe.checked = !!item.featured; fe.name = "featured";
      fe.addEventListener("change", () => set(["featured"], fe.checked, "featured"));
      field(form, "Featured", fe);
      poseFields(form, item.pose, (p) => set(["pose"], p, "place pose"), "pose");
    } else if (sel.list === "connectors") {
      field(form, "Id", textInput(item.id, (v) => set(["id"], idValue(v), "connector id"))).name = "id";
      field(form, "Kind", selectInput([["lift", "lift"], ["stairs", "stairs"]], item.kind,
                                       (v) => set(["kind"], v, "connector kind"))).name = "kind";
      namesFields(form, item, set);
      const serves = document.createElement("div");
      serves.className = "checks";
      const served = Array.isArray(item.serves) ? item.serves : floors().map((f) => f.id);
      for (const f of floors()) {
        const l = document.createElement("label");
        const c = document.createElement("input");
        c.type = "checkbox"; c.checked = served.some((s) => sameFloor(s, f.id)); c.name = `serves-${fmt(f.id)}`;
        c.addEventListener("change", () => {
          const now = floors().map((g) => g.id).filter((g) => (sameFloor(g, f.id) ? c.checked
            : served.some((s) => sameFloor(s, g))));
          const edits = now.length === floors().length ? (Array.isArray(item.serves)
            ? [{op: "delete", path: [...base, "serves"]}] : [])
            : [{op: "set", path: [...base, "serves"], value: now}];
          if (!c.checked) {
            const k = (item.meeting || []).findIndex((m) => sameFloor(m.floor, f.id));
            if (k >= 0) edits.push({op: "delete", path: [...base, "meeting", k]});
          }
          if (edits.length) edit(edits, "connector floors");
        });
        l.append(c, ` ${fmt(f.id)}`);
        serves.append(l);
      }
      field(form, "Serves", serves);
      const k = (item.meeting || []).findIndex((m) => sameFloor(m.floor, floorId()));
      const here = k >= 0 ? item.meeting[k] : null;
      const info = document.createElement("span");
      info.textContent = here ? `(${here.pose.map(fmt).join(", ")})` : "none on this floor";
      field(form, `Meeting, floor ${fmt(floorId())}`, info);
      if (here) poseFields(form, here.pose, (p) => set(["meeting", k, "pose"], p, "meeting pose"), "meeting");
      form.append(button(here ? "Move meeting point (click on the map)" : "Place meeting point (click on the map)",
                         () => setMode("meeting"), "wide"));
    } else if (sel.list === "robots") {
      field(form, "Name", textInput(item.name, (v) => set(["name"], v, "robot name"))).name = "name";
      field(form, "Floor", selectInput(floorOptions, item.floor, (v) => set(["floor"], num(v), "robot floor")))
        .name = "robot-floor";
      field(form, "Master URI", textInput(item.master_uri, (v) => set(["master_uri"], v, "master URI"))).name = "master_uri";
      field(form, "Relay port", textInput(item.relay_port, (v) => (v.trim() === ""
        ? edit([{op: "delete", path: [...base, "relay_port"]}], "relay port") : set(["relay_port"], num(v), "relay port")),
        "number")).name = "relay_port";
      field(form, "Drive", selectInput(DRIVES.map((d) => [d, d]), item.drive, (v) => set(["drive"], v, "drive")))
        .name = "drive";
      for (const key of ["max_linear", "max_angular", "max_linear_accel", "max_angular_accel", "radius"]) {
        field(form, key.replace(/_/g, " "), textInput(item[key], (v) => set([key], num(v), key), "number")).name = key;
      }
      poseFields(form, item.home, (p) => set(["home"], p, "robot home"), "home");
      form.append(button("Set home (click on the map)", () => setMode("home"), "wide"));
    } else if (sel.list === "zones") {
      field(form, "Id", textInput(item.id, (v) => set(["id"], v, "zone id"))).name = "id";
      const info = document.createElement("span");
      info.textContent = `${(item.polygon || []).length} corners: drag them on the map`;
      field(form, "Outline", info);
    }
  }

  function namesFields(form, item, set) {
    for (const lang of LANGS) {
      field(form, `Name (${lang})`, textInput((item.names || {})[lang], (v) => set(["names", lang], v, "name")))
        .name = `name-${lang}`;
    }
  }
  function poseFields(form, pose, onSet, prefix) {
    const p = Array.isArray(pose) ? pose : [0, 0, 0];
    ["x (m)", "y (m)", "yaw (°)"].forEach((label, k) => {
      const shown = k === 2 ? round(p[2] * 180 / Math.PI, 2) : p[k];
      field(form, label, textInput(shown, (v) => {
        const q = [...p];
        q[k] = k === 2 ? num(v) * Math.PI / 180 : num(v);
        onSet([round(q[0], 3), round(q[1], 3), round(q[2], 4)]);
      }, "number")).name = `${prefix}-${"xyz"[k]}`;
    });
  }

  function renderReference() {
    const sel = $("reference");
    $("reference-label").hidden = S.mode !== "floors";
    if (S.reference === null || S.reference === S.floor || S.reference >= floors().length) {
      S.reference = floors().length > 1 ? (S.floor > 0 ? S.floor - 1 : 1) : null;
    }
    sel.replaceChildren(...floors().map((f, i) => {
      const o = document.createElement("option");
      o.value = String(i); o.textContent = `${fmt(f.id)} · ${name(f)}`; o.disabled = i === S.floor;
      o.selected = i === S.reference;
      return o;
    }));
  }

  function renderPairs() {
    const ol = $("pairs");
    const unit = S.mode === "align" ? "px" : "m";
    ol.replaceChildren(...S.pairs.map((p, k) => {
      const li = document.createElement("li");
      li.textContent = `map (${p[0].map((v) => fmt(round(v, 2))).join(", ")}) m ↔ ` +
        `(${p[1].map((v) => fmt(round(v, 2))).join(", ")}) ${unit}${p[2] !== undefined ? ` — off by ${p[2]} ${unit}` : ""}`;
      return li;
    }));
    if (S.pending) {
      const li = document.createElement("li");
      li.textContent = `map (${S.pending.map((v) => fmt(round(v, 2))).join(", ")}) m ↔ now click the same point on ` +
        (S.mode === "align" ? "the blueprint" : "the other floor");
      ol.append(li);
    }
    $("align-fit").disabled = S.pairs.length < 2;
  }

  function hint() {
    const texts = {
      select: "Drag a place, meeting point, home or corner to move it; drag its handle to turn it. Wheel: zoom; drag: pan.",
      place: "Click where the robot should stop for the new place.",
      zone: "Click the corners of the zone; click the first corner again (or press Enter) to close it; Esc: cancel.",
      align: "Click a point on the map, then the same point on the blueprint (2 pairs or more, far apart).",
      floors: "Click a point on this floor's map, then the same point on the other floor's (the lift, a staircase).",
      meeting: "Click where robots wait at this lift or staircase on this floor.",
      home: "Click where this robot parks.",
    };
    $("hint").textContent = texts[S.mode] || "";
  }

  function setMode(mode) {
    S.mode = mode; S.zone = []; S.pending = null;
    if (mode !== "align" && mode !== "floors") S.pairs = [];
    if (mode === "align" || mode === "floors") { S.pairs = []; view("other").key = ""; }
    renderSide(); draw();
  }

  // ------------------------------------------------------------------ adding and deleting
  function addPlace(x, y) {
    const id = freeId("P", allIds());
    const index = list("locations").length;
    edit([{op: "insert", path: ["locations", index], value: {
      id, floor: floorId(), pose: [round(x, 3), round(y, 3), 0], names: {eu: id, en: id, es: id}, category: "other",
      featured: false}}], `add place ${id}`).then(() => { S.tab = "locations"; S.selected = {list: "locations", index};
      renderSide(); draw(); });
  }
  function addConnector(kind) {
    const id = freeId(kind === "lift" ? "lift" : "stairs", allIds());
    const index = list("connectors").length;
    const names = kind === "lift" ? {eu: "Igogailua", en: "Lift", es: "Ascensor"}
      : {eu: "Eskailerak", en: "Stairs", es: "Escalera"};
    edit([{op: "insert", path: ["connectors", index], value: {id, kind, names, meeting: []}}], `add ${id}`)
      .then(() => { S.tab = "connectors"; S.selected = {list: "connectors", index}; setMode("meeting"); });
  }
  function addRobot() {
    const robots = list("robots");
    const taken = new Set(robots.map((r) => r.name));
    const robotName = freeId("Robot", taken);
    const index = robots.length;
    const c = viewCentre();
    edit([{op: "insert", path: ["robots", index], value: {
      name: robotName, floor: floorId(), master_uri: `http://127.0.0.${11 + index}:11311/`, drive: "differential",
      max_linear: 0.5, max_angular: 1.0, max_linear_accel: 0.5, max_angular_accel: 1.5, radius: 0.3,
      home: [round(c[0], 3), round(c[1], 3), 0]}}], `add robot ${robotName}`)
      .then(() => { S.tab = "robots"; S.selected = {list: "robots", index}; setMode("home"); });
  }
  function viewCentre() {
    const canvas = $("map"), m = mapScreen("map", S.floor);
    return m ? apply(inv(m), canvas.width / 2, canvas.height / 2) : [0, 0];
  }
  function deleteSelected() {
    const sel = S.selected;
    if (!sel) return;
    const path = sel.list === "zones" ? ["floors", S.floor, "keep_out", sel.index] : [sel.list, sel.index];
    S.selected = null;
    edit([{op: "delete", path}], `delete ${sel.list === "zones" ? "keep-out zone" : sel.list.replace(/s$/, "")}`);
  }
  function closeZone() {
    if (S.zone.length < 3) { say("a keep-out zone needs 3 corners or more"); return; }
    const id = freeId("zone", new Set(zones().map((z) => String(z.id))));
    const index = zones().length;
    const polygon = S.zone.map((p) => [round(p[0], 3), round(p[1], 3)]);
    S.zone = [];
    edit([{op: "insert", path: ["floors", S.floor, "keep_out", index], value: {id, polygon}}], `add keep-out ${id}`)
      .then(() => { S.tab = "zones"; S.selected = {list: "zones", index}; S.mode = "select"; renderSide(); draw(); });
  }

  // ------------------------------------------------------------------ floors
  function addFloor() {
    const used = new Set(floors().map((f) => f.map));
    const map = S.files.maps.find((m) => !used.has(m)) || S.files.maps[0];
    if (!map) { say("the building folder has no map_server map (a .yaml with its image): copy one in first"); return; }
    const stem = map.replace(/\.[^.]+$/, "");
    const bp = S.files.images.find((n) => n.replace(/\.[^.]+$/, "") === stem && !/\.pgm$/i.test(n)) ||
      S.files.images.find((n) => !/\.pgm$/i.test(n)) || S.files.images[0];
    let id = floors().length ? Math.max(...floors().map((f) => Number(f.id) || 0)) + 1 : 0;
    const m = /(-?\d+(\.\d+)?)/.exec(stem);
    if (m && !floors().some((f) => sameFloor(f.id, Number(m[1])))) id = Number(m[1]);
    edit([{op: "insert", path: ["floors", floors().length], value: {
      id, names: {eu: `${id}. solairua`, en: `Floor ${id}`, es: `Planta ${id}`}, map, blueprint: bp,
      blueprint_transform: {scale: 10.0, origin_px: [0, 0]}}}], `add floor ${id}`)
      .then(() => { S.floor = floors().length - 1; renderSide(); draw(); });
  }
  function moveFloor(delta) {
    const to = S.floor + delta;
    if (to < 0 || to >= floors().length) return;
    const from = S.floor;
    S.floor = to;
    edit([{op: "move", path: ["floors", from], to}], "move floor");
  }
  function removeFloor() {
    const f = floorDoc();
    if (!f || !confirm(`Remove floor ${fmt(f.id)} with its places, meeting points and robots?`)) return;
    S.selected = null;
    change("/api/floor/remove", {floor: S.floor})
      .then(() => { S.floor = Math.max(0, Math.min(S.floor, floors().length - 1)); renderSide(); draw(); });
  }

  // ------------------------------------------------------------------ the map's mouse
  function hit(px, py) {
    const m = mapScreen("map", S.floor);
    if (!m) return null;
    const fid = floorId();
    const near = (x, y) => { const [sx, sy] = apply(m, x, y); return Math.hypot(sx - px, sy - py); };
    const handleOf = (pose) => {
      const [sx, sy] = apply(m, pose[0], pose[1]);
      const [hx, hy] = apply(m, pose[0] + Math.cos(pose[2] || 0), pose[1] + Math.sin(pose[2] || 0));
      const d = Math.hypot(hx - sx, hy - sy) || 1;
      return Math.hypot(sx + (hx - sx) / d * HANDLE - px, sy + (hy - sy) / d * HANDLE - py);
    };
    const found = [];
    const consider = (kind, listName, index, pose, extra) => {
      if (!Array.isArray(pose)) return;
      found.push({d: handleOf(pose) - 0.5, what: "yaw", listName, index, pose, ...extra});
      found.push({d: near(pose[0], pose[1]), what: "move", listName, index, pose, ...extra});
    };
    list("locations").forEach((l, i) => { if (sameFloor(l.floor, fid)) consider("place", "locations", i, l.pose, {}); });
    list("connectors").forEach((c, i) => (c.meeting || []).forEach((mm, k) => {
      if (sameFloor(mm.floor, fid)) consider("meeting", "connectors", i, mm.pose, {meeting: k});
    }));
    list("robots").forEach((r, i) => { if (sameFloor(r.floor, fid)) consider("home", "robots", i, r.home, {}); });
    zones().forEach((z, i) => (z.polygon || []).forEach((p, k) => {
      if (S.selected && S.selected.list === "zones" && S.selected.index === i) {
        found.push({d: near(p[0], p[1]) - 1, what: "corner", listName: "zones", index: i, corner: k, point: p});
      }
    }));
    const best = found.filter((f) => f.d <= PICK).sort((a, b) => a.d - b.d)[0];
    if (best) return best;
    const [x, y] = apply(inv(m), px, py);
    const z = zones().findIndex((zz) => inside(zz.polygon || [], x, y));
    return z >= 0 ? {what: "zone", listName: "zones", index: z} : null;
  }
  function inside(poly, x, y) {
    let c = false;
    for (let i = 0, j = poly.length - 1; i < poly.length; j = i++) {
      const [xi, yi] = poly[i], [xj, yj] = poly[j];
      if ((yi > y) !== (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) c = !c;
    }
    return c;
  }

  function mapDown(ev) {
    const canvas = $("map"), [px, py] = eventPoint(ev, canvas);
    const m = mapScreen("map", S.floor);
    if (!m) return;
    const [x, y] = apply(inv(m), px, py);
    if (S.mode === "place") { addPlace(x, y); S.mode = "select"; return; }
    if (S.mode === "zone") {
      if (S.zone.length >= 3) {
        const [fx, fy] = apply(m, S.zone[0][0], S.zone[0][1]);
        if (Math.hypot(fx - px, fy - py) <= PICK) { closeZone(); return; }
      }
      S.zone.push([x, y]); draw(); return;
    }
    if (S.mode === "align" || S.mode === "floors") {
      if (!S.pending) { S.pending = [x, y]; renderPairs(); draw(); }
      return;
    }
    if (S.mode === "meeting") { placeMeeting(x, y); return; }
    if (S.mode === "home") { placeHome(x, y); return; }
    const h = hit(px, py);
    if (h) {
      if (h.listName !== "zones" || h.what === "zone") select(h.listName, h.index);
      if (h.what !== "zone") S.drag = {...h, start: [px, py], moved: false};
      return;
    }
    S.drag = {what: "pan", start: [px, py], m0: [...view("map").m]};
  }

  function mapMove(ev) {
    if (!S.drag) return;
    const canvas = $("map"), [px, py] = eventPoint(ev, canvas);
    const d = S.drag;
    if (d.what === "pan") {
      const v = view("map");
      v.m = [...d.m0];
      v.m[4] += px - d.start[0]; v.m[5] += py - d.start[1];
      draw();
      return;
    }
    if (Math.hypot(px - d.start[0], py - d.start[1]) < 3 && !d.moved) return;
    d.moved = true;
    const m = mapScreen("map", S.floor);
    const [x, y] = apply(inv(m), px, py);
    if (d.what === "move") d.pose = [x, y, d.pose[2] || 0];
    else if (d.what === "yaw") d.pose = [d.pose[0], d.pose[1], Math.atan2(y - d.pose[1], x - d.pose[0])];
    else if (d.what === "corner") d.point = [x, y];
    showDrag(d);
    draw();
  }
  // show a drag on the local copy (the server gets it on release)
  function showDrag(d) {
    if (d.what === "corner") { zones()[d.index].polygon[d.corner] = d.point; return; }
    if (d.listName === "locations") list("locations")[d.index].pose = d.pose;
    if (d.listName === "robots") list("robots")[d.index].home = d.pose;
    if (d.listName === "connectors") list("connectors")[d.index].meeting[d.meeting].pose = d.pose;
  }
  function mapUp() {
    const d = S.drag;
    S.drag = null;
    if (!d || d.what === "pan" || !d.moved) return;
    if (d.what === "corner") {
      const polygon = zones()[d.index].polygon.map((p) => [round(p[0], 3), round(p[1], 3)]);
      edit([{op: "set", path: ["floors", S.floor, "keep_out", d.index, "polygon"], value: polygon}], "move a corner");
      return;
    }
    const pose = [round(d.pose[0], 3), round(d.pose[1], 3), round(d.pose[2], 4)];
    const path = d.listName === "locations" ? ["locations", d.index, "pose"]
      : d.listName === "robots" ? ["robots", d.index, "home"] : ["connectors", d.index, "meeting", d.meeting, "pose"];
    edit([{op: "set", path, value: pose}], d.what === "yaw" ? "turn" : "move");
  }
  function mapWheel(ev) {
    ev.preventDefault();
    const canvas = ev.currentTarget, [px, py] = eventPoint(ev, canvas);
    const v = view(canvas.id);
    if (!v.m) return;
    const k = ev.deltaY < 0 ? 1.2 : 1 / 1.2;
    v.m = mul([k, 0, 0, k, px - k * px, py - k * py], v.m);
    draw();
  }

  function placeMeeting(x, y) {
    const sel = S.selected;
    if (!sel || sel.list !== "connectors") { say("choose a lift or staircase first"); return; }
    const c = list("connectors")[sel.index];
    const fid = floorId();
    const k = (c.meeting || []).findIndex((mm) => sameFloor(mm.floor, fid));
    const pose = [round(x, 3), round(y, 3), k >= 0 ? c.meeting[k].pose[2] : 0];
    const edits = k >= 0 ? [{op: "set", path: ["connectors", sel.index, "meeting", k, "pose"], value: pose}]
      : [{op: "insert", path: ["connectors", sel.index, "meeting", (c.meeting || []).length], value: {floor: fid, pose}}];
    if (Array.isArray(c.serves) && !c.serves.some((s) => sameFloor(s, fid))) {
      edits.push({op: "set", path: ["connectors", sel.index, "serves"], value: [...c.serves, fid]});
    }
    S.mode = "select";
    edit(edits, `meeting point of ${c.id}`);
  }
  function placeHome(x, y) {
    const sel = S.selected;
    if (!sel || sel.list !== "robots") { say("choose a robot first"); return; }
    const r = list("robots")[sel.index];
    const pose = [round(x, 3), round(y, 3), Array.isArray(r.home) ? r.home[2] : 0];
    S.mode = "select";
    edit([{op: "set", path: ["robots", sel.index, "home"], value: pose},
          {op: "set", path: ["robots", sel.index, "floor"], value: floorId()}], `home of ${r.name}`);
  }

  function otherDown(ev) {
    if (!S.pending) { say("click the point on the map first (left), then the same point here"); return; }
    const canvas = $("other"), [px, py] = eventPoint(ev, canvas);
    let point;
    if (S.mode === "align") point = apply(inv(view("other").m), px, py);
    else {
      const f = S.floors[S.reference];
      if (!f || !f.map) return;
      point = apply(inv(mul(view("other").m, pxFromMetres(f.map))), px, py);
    }
    S.pairs.push([S.pending, point]);
    S.pending = null;
    say("");
    renderPairs(); draw();
  }

  async function fit() {
    try {
      const pairs = S.pairs.map((p) => [p[0], p[1]]);
      let r;
      if (S.mode === "align") {
        r = await api("POST", "/api/align/blueprint", {floor: S.floor, pairs});
        S.fitNote = `fitted on ${pairs.length} pairs: off by ${r.rms_px} px (rms), ${r.max_px} px at most`;
        r.residuals_px.forEach((v, k) => { S.pairs[k][2] = v; });
      } else {
        r = await api("POST", "/api/align/floor", {floor: S.floor, reference: S.reference, pairs});
        S.fitNote = `floor aligned on ${pairs.length} pairs: off by ${r.rms_m} m (rms); scale of the maps ${r.scale}`;
        r.residuals_m.forEach((v, k) => { S.pairs[k][2] = v; });
      }
      $("align-result").textContent = S.fitNote;
      say(S.fitNote, true);
    } catch (e) {
      $("align-result").textContent = e.message;
      say(e.message);
    }
    await refresh(true);
  }

  // ------------------------------------------------------------------ header actions
  async function save(draft) {
    try {
      const r = await api("POST", "/api/save", {draft});
      say(r.draft ? `Saved as a draft: ${r.saved} (gidabot check and the robots refuse it until the problems are ` +
        "fixed and it is saved again)" : `Saved ${r.saved}${r.backup ? " (the previous file: building.yaml.bak)" : ""}`,
      !r.draft);
    } catch (e) {
      say(e.message);
    }
    await refresh(true);
  }
  async function previewStart() {
    try {
      await api("POST", "/api/preview/start", {tour: $("preview-tour").value || "featured"});
      say(PREVIEW_STARTING, true);
    } catch (e) { say(e.message); }
    await refresh(false);
  }
  async function previewStop() {
    try { await api("POST", "/api/preview/stop", {}); } catch (e) { say(e.message); }
    await refresh(false);
  }
  async function loadTours() {
    try {
      const r = await api("GET", "/api/tours");
      const sel = $("preview-tour"), old = sel.value;
      sel.replaceChildren(...r.tours.map((t) => {
        const o = document.createElement("option");
        o.value = t; o.textContent = t === "featured" ? "tour of the featured places" : t;
        o.selected = t === old;
        return o;
      }));
    } catch (e) { /* not yet a building */ }
  }

  // ------------------------------------------------------------------ start
  function wire() {
    $("undo").addEventListener("click", async () => { await api("POST", "/api/undo", {}); refresh(true); });
    $("redo").addEventListener("click", async () => { await api("POST", "/api/redo", {}); refresh(true); });
    $("save").addEventListener("click", () => save(false));
    $("save-draft").addEventListener("click", () => save(true));
    $("preview-start").addEventListener("click", previewStart);
    $("preview-stop").addEventListener("click", previewStop);
    $("preview-tour").addEventListener("focus", loadTours);
    $("floor-add").addEventListener("click", addFloor);
    $("floor-up").addEventListener("click", () => moveFloor(-1));
    $("floor-down").addEventListener("click", () => moveFloor(1));
    $("floor-remove").addEventListener("click", removeFloor);
    for (const b of document.querySelectorAll(".tab")) {
      b.addEventListener("click", () => { S.tab = b.dataset.tab; S.selected = null; renderSide(); draw(); });
    }
    for (const b of document.querySelectorAll(".mode")) b.addEventListener("click", () => setMode(b.dataset.mode));
    $("search").addEventListener("input", (e) => { S.search = e.target.value; renderItems(); });
    $("bp-alpha").addEventListener("input", (e) => { S.bpAlpha = Number(e.target.value) / 100; draw(); });
    $("ghost").addEventListener("change", (e) => { S.ghost = e.target.checked; draw(); });
    $("reference").addEventListener("change", (e) => { S.reference = Number(e.target.value); S.pairs = [];
      S.pending = null; view("other").key = ""; renderPairs(); draw(); });
    $("align-fit").addEventListener("click", fit);
    $("align-clear").addEventListener("click", () => { S.pairs = []; S.pending = null; renderPairs(); draw(); });
    $("align-undo-point").addEventListener("click", () => { if (S.pending) S.pending = null; else S.pairs.pop();
      renderPairs(); draw(); });
    const map = $("map");
    map.addEventListener("mousedown", mapDown);
    window.addEventListener("mousemove", mapMove);
    window.addEventListener("mouseup", mapUp);
    map.addEventListener("wheel", mapWheel, {passive: false});
    map.addEventListener("dblclick", () => { if (S.mode === "zone") closeZone(); });
    $("other").addEventListener("mousedown", otherDown);
    $("other").addEventListener("wheel", mapWheel, {passive: false});
    window.addEventListener("resize", draw);
    window.addEventListener("keydown", (ev) => {
      if (ev.target && ["INPUT", "SELECT", "TEXTAREA"].includes(ev.target.tagName)) return;
      if ((ev.ctrlKey || ev.metaKey) && ev.key.toLowerCase() === "z") {
        ev.preventDefault(); $(ev.shiftKey ? "redo" : "undo").click();
      } else if ((ev.ctrlKey || ev.metaKey) && ev.key.toLowerCase() === "y") {
        ev.preventDefault(); $("redo").click();
      } else if (ev.key === "Escape") setMode("select");
      else if (ev.key === "Enter" && S.mode === "zone") closeZone();
      else if (ev.key === "Delete" && S.selected) deleteSelected();
    });
  }

  async function start() {
    wire();
    try {
      await login();
      await refresh(true);
      await loadTours();
    } catch (e) {
      say(e.message);
      $("status").textContent = "not connected";
      return;
    }
    setInterval(() => { refresh(false).catch((e) => say(e.message)); }, 500);
  }

  // what tests and scripts may ask the page (where a map point is drawn, what it holds); changes go through clicks
  window.gidabotEditor = {
    toScreen, state: () => S, ready: () => S.rev >= 0 && !!S.check && S.check.revision === S.rev,
    floorIndex: () => S.floor, ghost: () => (S.ghost ? ghostFloor() : null),
  };
  document.addEventListener("DOMContentLoaded", start);
})();
