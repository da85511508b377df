"use strict";
// The web stack's client (gidabot_web/web, docs/dashboard.md): the session and its CSRF token, JSON actions,
// live updates over a WebSocket that reconnects by itself, the page's texts in the chosen language, and el(),
// which builds DOM nodes from text only (nothing received is ever parsed as HTML).
const Web = (() => {
  let csrf = "";
  let session = { user: null, role: null };
  let catalog = {};

  async function refreshSession() {
    const r = await fetch("/api/session", { credentials: "same-origin", cache: "no-store" });
    const j = await r.json();
    csrf = j.csrf || "";
    session = { user: j.user, role: j.role };
    return session;
  }

  async function post(path, body) {
    const r = await fetch(path, {
      method: "POST", credentials: "same-origin", cache: "no-store",
      headers: { "Content-Type": "application/json", "X-CSRF-Token": csrf },
      body: JSON.stringify(body || {}),
    });
    let j = {};
    try { j = await r.json(); } catch (e) { j = {}; }
    if (!r.ok) {
      const err = new Error(j.message || r.statusText);
      err.status = r.status;
      err.reason = j.error || "";
      throw err;
    }
    return j;
  }

  async function login(user, password) {
    const j = await post("/api/login", { user: user, password: password });
    csrf = j.csrf;
    session = { user: j.user, role: j.role };
    return session;
  }

  async function logout() {
    try { await post("/api/logout", {}); } finally { await refreshSession(); }
    return session;
  }

  // onMessage(message) for every message; onState("connecting" | "live" | "reconnecting"). A socket silent for
  // 6 s (the server ticks every 2 s) counts as dead: it is closed and opened again, with a growing pause.
  function live(path, onMessage, onState) {
    let ws = null;
    let timer = null;
    let pause = 250;
    let last = 0;
    function connect() {
      onState(ws === null ? "connecting" : "reconnecting");
      const proto = location.protocol === "https:" ? "wss:" : "ws:";
      const sock = new WebSocket(proto + "//" + location.host + path);
      ws = sock;
      sock.onopen = () => { pause = 250; last = Date.now(); onState("live"); };
      sock.onmessage = (e) => {
        last = Date.now();
        let m = null;
        try { m = JSON.parse(e.data); } catch (err) { return; }
        onMessage(m);
      };
      sock.onclose = () => { if (sock === ws) { onState("reconnecting"); again(); } };
      sock.onerror = () => { try { sock.close(); } catch (err) { /* closed already */ } };
    }
    function again() {
      clearTimeout(timer);
      timer = setTimeout(connect, pause);
      pause = Math.min(pause * 2, 4000);
    }
    setInterval(() => {
      if (ws && ws.readyState === WebSocket.OPEN && Date.now() - last > 6000) {
        onState("reconnecting");
        try { ws.close(); } catch (err) { /* closed already */ }
      }
    }, 1000);
    connect();
  }

  async function loadTexts(language) {
    const r = await fetch("/i18n/" + encodeURIComponent(language), { cache: "no-store" });
    catalog = r.ok ? await r.json() : {};
  }

  // msgid in the chosen language, {placeholders} replaced by params
  function t(msgid, params) {
    let s = catalog[msgid] || msgid;
    if (params) {
      s = s.replace(/\{(\w+)\}/g, (m, k) => (Object.prototype.hasOwnProperty.call(params, k) ? String(params[k]) : m));
    }
    return s;
  }

  function el(tag, attrs, ...children) {
    const node = tag.startsWith("svg:")
      ? document.createElementNS("http://www.w3.org/2000/svg", tag.slice(4)) : document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === null || v === undefined || v === false) continue;
      if (k.startsWith("on")) node.addEventListener(k.slice(2), v);
      else node.setAttribute(k, v === true ? "" : String(v));
    }
    for (const c of children.flat(Infinity)) {
      if (c === null || c === undefined || c === false) continue;
      node.appendChild(typeof c === "string" || typeof c === "number" ? document.createTextNode(String(c)) : c);
    }
    return node;
  }

  return {
    refreshSession, post, login, logout, live, loadTexts, t, el,
    get session() { return session; },
  };
})();
