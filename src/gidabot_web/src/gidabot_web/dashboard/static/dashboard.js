"use strict";
// The staff dashboard's page (docs/dashboard.md). It renders the sections the robot pushes (/live) and sends
// staff actions (Web.post); it decides nothing. Every text goes through t() (gidabot_gui's catalogs).
(() => {
  const { t, el } = Web;
  const S = { building: null, robots: [], trips: [], tours: [], links: null, alerts: [], history: null, catalog: [],
              server: null };
  let received = Date.now();       // when the last update arrived (ages count on from there)
  let selected = null;             // the robot whose panel is open
  let view = "building";
  let historyDay = "";
  const armed = new Map();         // two-step buttons: key -> time armed
  const reasons = new Map();       // robot -> the out-of-service reason typed in its panel (kept across renders)
  const STATE_TEXTS = {
    idle: "Ready", guiding: "Guiding a visitor", to_meeting: "Going to meet a visitor",
    waiting: "Waiting for a visitor", returning: "Going back home", error: "Navigation problem",
  };
  const LIVE_TEXTS = { online: "online", offline: "offline", master_down: "master down", link_down: "link down" };
  const PHASE_TEXTS = {
    0: "accepted", 1: "on the way", 2: "goal reached", 3: "sent to another floor", 4: "going to the meeting point",
    5: "waiting for the visitor", 6: "cannot reach the goal", 7: "sent to a floor without robot",
    8: "cancelled here", 9: "cancelled elsewhere", 10: "nobody came", 11: "partner offline", 12: "refused",
    13: "tour stop reached", 14: "tour finished", 15: "partner not reachable", 16: "partner back",
    17: "declined", 18: "assigned",
  };
  const OUTCOME_TEXTS = {
    completed: "completed", cancelled: "cancelled", timed_out: "timed out", refused: "refused", failed: "failed",
    open: "in progress",
  };
  const ALERT_TEXTS = {
    robot_offline: "{robot} is offline", link_down: "The link between {a} and {b} is down",
    battery_low: "{robot}: battery low ({percent} %)", goal_unreachable: "{robot} cannot reach {place}",
    visitor_no_show: "Nobody came to meet {robot} at {place}", node_restarted: "{robot}: {node} restarted",
    floor_out_of_service: "Every robot of floor {floor} is out of service",
  };
  const ROLE_TEXTS = { staff: "staff", admin: "admin" };
  const WHY_TEXTS = { offline: "no status", master_down: "its master does not answer", link_down: "the link to it is down" };

  // ---------------------------------------------------------------- helpers
  const $ = (id) => document.getElementById(id);
  const lang = () => $("language").value;
  const loggedIn = () => Web.session.user !== null && Web.session.user !== undefined;
  const isAdmin = () => Web.session.role === "admin";
  const since = () => (Date.now() - received) / 1000;
  function floorName(id) {
    const f = S.building && S.building.floors.find((x) => Math.abs(x.id - id) < 1e-3);
    return f ? (f.names[lang()] || f.label) : String(id);
  }
  function placeName(id) {
    if (!id || !S.building) return id || "";
    const loc = S.building.locations[id];
    if (loc) return (loc.names[lang()] || id) + " (" + id + ")";
    const c = S.building.connectors[id];
    return c ? (c.names[lang()] || id) : id;
  }
  function clock(wall) {
    return wall ? new Date(wall * 1000).toLocaleTimeString(lang(), { hour12: false }) : "";
  }
  function seconds(s) {
    if (s === null || s === undefined) return "";
    if (s < 90) return t("{n} s", { n: Math.round(s) });
    return t("{n} min", { n: Math.round(s / 60) });
  }
  function number(value, digits) {
    const text = Number(value).toFixed(digits);
    return lang() === "en" ? text : text.replace(".", ",");
  }
  function robot(name) { return S.robots.find((r) => r.name === name); }
  function table(headers, rows, cls) {
    return el("table", { class: cls || "" },
      el("thead", {}, el("tr", {}, headers.map((h) => el("th", {}, h)))),
      el("tbody", {}, rows));
  }
  function replace(id, ...nodes) {
    const box = $(id);
    box.replaceChildren(...nodes.flat(Infinity).filter((n) => n));
  }
  function flash(node, text, ok) {
    node.textContent = text;
    node.className = ok ? "ok" : "error";
  }
  // a button that acts on its second press within 5 s ("Cancel trip" -> "Confirm: cancel trip")
  function twoStep(key, label, confirmLabel, act, attrs) {
    const isArmed = armed.has(key) && Date.now() - armed.get(key) < 5000;
    return el("button", Object.assign({ type: "button", class: isArmed ? "armed" : "", "data-step": isArmed ? "2" : "1",
                                        onclick: async (e) => {
      if (!(armed.has(key) && Date.now() - armed.get(key) < 5000)) {
        armed.set(key, Date.now());
        renderAll();
        return;
      }
      armed.delete(key);
      e.target.disabled = true;
      try { await act(); } catch (err) { showError(err); }
      renderAll();
    } }, attrs || {}), isArmed ? confirmLabel : label);
  }
  function showError(err) {
    const b = $("banner");
    b.hidden = false;
    b.className = "error";
    b.textContent = t("Refused: {why}", { why: err.message || String(err) });
    setTimeout(() => { if (b.className === "error") b.hidden = true; }, 8000);
  }

  // ---------------------------------------------------------------- the building
  function buildFloors() {
    const b = S.building;
    $("building-name").textContent = "· " + b.name;
    $("seen-from").textContent = t("as {robot} sees it", { robot: b.me });
    document.title = "GidaBot · " + b.me;
    const cards = b.floors.map((f) => {
      const w = f.width || 1000;
      const h = f.height || 600;
      const svg = el("svg:svg", { viewBox: "0 0 " + w + " " + h, class: "floormap", "data-floor": f.id,
                                  preserveAspectRatio: "xMidYMid meet" },
        el("svg:image", { href: "/blueprints/" + f.blueprint, x: 0, y: 0, width: w, height: h }),
        el("svg:g", { class: "marks", "data-floor": f.id }));
      return el("div", { class: "floor", "data-floor": f.id }, el("h3", { class: "floor-title" }), svg);
    });
    replace("floors", cards);
  }

  function renderFloors() {
    if (!S.building) return;
    for (const card of document.querySelectorAll("#floors .floor")) {
      const fid = Number(card.dataset.floor);
      const f = S.building.floors.find((x) => x.id === fid);
      const onFloor = S.robots.filter((r) => Math.abs(r.floor - fid) < 1e-3);
      card.querySelector(".floor-title").textContent = floorName(fid) + " · " +
        (onFloor.length ? onFloor.map((r) => r.name).join(", ") : t("no robot"));
      const g = card.querySelector("g.marks");
      const size = Math.max(f.width, f.height) / 70;
      g.replaceChildren(...onFloor.map((r) => marker(r, size)));
    }
  }

  function marker(r, size) {
    const off = r.live !== "online";
    const cls = ["robot", off ? "offline" : "online", r.name === S.building.me ? "me" : "",
                 r.out_of_service ? "out" : "", r.name === selected ? "selected" : ""].join(" ");
    const a = (r.heading || 0) * Math.PI / 180;
    const label = off ? t("{robot} · last heard {age}", { robot: r.name, age: age(r) }) : r.name;
    return el("svg:g", { class: cls, "data-robot": r.name, "data-live": r.live, transform: "translate(" + r.u + "," + r.v + ")",
                         onclick: () => { selected = r.name; renderAll(); } },
      el("svg:circle", { r: size }),
      el("svg:line", { x1: 0, y1: 0, x2: 1.8 * size * Math.cos(a), y2: -1.8 * size * Math.sin(a) }),
      el("svg:text", { x: size * 1.4, y: -size * 1.2, "font-size": size * 1.5 }, label));
  }

  function age(r) {
    return r.heard_s === null ? t("never") : t("{age} ago", { age: seconds(r.heard_s + since()) });
  }

  function liveText(r) {
    if (r.live === "online") return t("online");
    return t(LIVE_TEXTS[r.live] || "offline") + " · " + t("last heard {age}", { age: age(r) });
  }

  function renderPanel() {
    const panel = $("robot-panel");
    const r = selected && robot(selected);
    if (!r) { panel.hidden = true; return; }
    panel.hidden = false;
    const rows = [
      [t("Floor"), floorName(r.floor)],
      [t("Connection"), liveText(r)],
      [t("State"), t(STATE_TEXTS[r.state] || "Unknown state")],
      [t("Battery"), r.battery >= 0 ? t("Battery {percent} %", { percent: Math.round(100 * r.battery) }) : t("Battery unknown")],
      [t("Position"), "x " + number(r.x, 1) + " m, y " + number(r.y, 1) + " m"],
      [t("Wait for a new request"), seconds(r.wait_new)],
    ];
    const links = (S.links && (r.name === S.links.me ? S.links.mine : (S.links.others[r.name] || {}).links)) || [];
    const current = S.trips.find((tr) => tr.uid === r.current);
    const leg = current && current.legs.find((l) => l.robot === r.name);
    const typing = document.activeElement && document.activeElement.id === "service-reason";
    panel.replaceChildren(
      el("h2", {}, r.name, r.out_of_service ? el("span", { class: "tag out" }, t("out of service")) : null),
      el("button", { type: "button", class: "close", onclick: () => { selected = null; renderAll(); } }, "×"),
      el("dl", {}, rows.map(([k, v]) => [el("dt", {}, k), el("dd", {}, v)])),
      el("h3", {}, t("Current leg")),
      leg ? el("p", { class: "current-leg" }, legText(current, leg)) : el("p", {}, t("none")),
      el("h3", {}, t("Queue")),
      queueList(r),
      el("h3", {}, t("Links")),
      links.length ? table([t("Robot"), t("Link"), t("Round trip")], links.map((k) => el("tr", {},
        el("td", {}, k.peer), el("td", { class: k.connected ? "ok" : "bad" }, linkState(k)),
        el("td", {}, k.rtt_ms >= 0 ? t("{ms} ms", { ms: number(k.rtt_ms, 1) }) : "")))) : el("p", {}, t("unknown")),
      serviceBox(r));
    const input = typing && $("service-reason");
    if (input) {                   // the panel is rebuilt with every update: staff go on typing where they were
      input.focus();
      input.setSelectionRange(input.value.length, input.value.length);
    }
  }

  function serviceBox(r) {
    if (!loggedIn()) return document.createDocumentFragment();   // nothing (replaceChildren would show a null as "null")
    const s = r.service;
    const who = s ? { user: s.user, robot: s.robot, time: clock(s.wall) } : null;
    const note = s ? el("p", { class: "service-note" }, s.out ? t("Taken out of service by {user} at {robot} ({time})", who)
      : t("Put back in service by {user} at {robot} ({time})", who), s.detail ? " · " + s.detail : "") : null;
    const reason = el("input", { id: "service-reason", size: 24, placeholder: t("Reason"), value: reasons.get(r.name) ?? "",
                                 oninput: (e) => reasons.set(r.name, e.target.value) });
    const act = async () => {
      const answer = await Web.post("/api/robots/service",
                                    { robot: r.name, out: !r.out_of_service, reason: reasons.get(r.name) ?? "" });
      reasons.delete(r.name);
      return answer;
    };
    return el("div", { class: "service" }, note, reason,
      twoStep("service:" + r.name, r.out_of_service ? t("Back in service") : t("Take out of service"),
        t("Confirm"), act, { "data-action": "service", "data-robot": r.name }));
  }

  function queueList(r) {
    if (!r.queue.length) return el("p", { class: "queue-empty" }, t("No pending requests"));
    return el("ol", { class: "queue" }, r.queue.map((q) => el("li", {},
      (q.goal ? placeName(q.goal) : q.trip) + " · " + (q.eta >= 0 ? t("done in about {wait}", { wait: seconds(q.eta) }) : ""))));
  }

  function legText(trip, leg) {
    const parts = [leg.leg === "start" ? t("start leg") : t("goal leg"), leg.robot];
    if (leg.phase !== null) parts.push(t(PHASE_TEXTS[leg.phase] || "phase {n}", { n: leg.phase }));
    else parts.push(leg.committed ? t("committed") : t("proposed"));
    if (trip.connector) parts.push(placeName(trip.connector));
    if (leg.waiting_s !== null) parts.push(t("waiting for the visitor for {age}", { age: seconds(leg.waiting_s + since()) }));
    return parts.join(" · ");
  }

  function linkState(k) {
    if (!k.known) return t("unknown");
    if (k.connected) return k.peer_master_up ? t("up") : t("up · master down");
    return t("down for {age}", { age: seconds(k.down_s) });
  }

  // ---------------------------------------------------------------- queues, trips, tours
  function renderTrips() {
    replace("queues", table([t("Robot"), t("Connection"), t("State"), t("Queue"), t("Wait for a new request")],
      S.robots.map((r) => el("tr", { "data-robot": r.name, class: r.live !== "online" ? "offline" : "" },
        el("td", {}, r.name, r.out_of_service ? el("span", { class: "tag out" }, t("out of service")) : null),
        el("td", {}, liveText(r)), el("td", {}, t(STATE_TEXTS[r.state] || "Unknown state")),
        el("td", {}, queueList(r)), el("td", {}, seconds(r.wait_new))))));
    const active = S.trips.filter((tr) => !tr.outcome);
    replace("trips-active", active.length ? table([t("Trip"), t("From"), t("To"), t("Legs"), t("Since"), ""],
      active.map(tripRow), "trips") : el("p", {}, t("No trip in progress")));
    const done = S.trips.filter((tr) => tr.outcome);
    replace("trips-done", done.length ? table([t("Trip"), t("From"), t("To"), t("Outcome"), t("Ended")],
      done.map((tr) => el("tr", { "data-trip": tr.uid, "data-outcome": tr.outcome },
        el("td", { class: "uid" }, tr.uid), el("td", {}, tripFrom(tr)), el("td", {}, tripTo(tr)),
        el("td", {}, t(OUTCOME_TEXTS[tr.outcome] || tr.outcome), cancelNote(tr)),
        el("td", {}, clock(tr.ended))))) : el("p", {}, t("none")));
    replace("tours-active", S.tours.length ? table([t("Tour"), t("Steps"), t("Now")], S.tours.map((run) =>
      el("tr", { "data-tour": run.file },
        el("td", {}, run.name),
        el("td", {}, el("ol", { class: "steps" }, (run.steps.length ? run.steps : [run.file]).map((line, i) =>
          el("li", { class: run.done.includes(i) ? "done" : i === run.current ? "current" : "" }, line)))),
        el("td", {}, run.finished ? t("finished") : run.at ? t("stop done at {robot}", { robot: run.at })
          : t("step {n}", { n: run.current + 1 })))))
      : el("p", {}, t("No tour under way")));
  }

  function tripFrom(tr) {
    return (tr.start && tr.start !== "robot" ? placeName(tr.start) : tr.origin) + " · " + floorName(tr.start_floor);
  }

  function tripTo(tr) {
    const step = tr.tour ? " · " + t("{tour}, stop {n}", { tour: tr.tour, n: tr.step + 1 }) : "";
    return placeName(tr.goal) + " · " + floorName(tr.goal_floor) + step;
  }

  function cancelNote(tr) {
    const c = tr.cancel;
    if (!c) return null;
    const text = c.confirmed ? t("cancelled by {user}: every robot dropped it", { user: c.user })
      : t("cancelling ({user}): waiting for {robots}", { user: c.user, robots: c.waiting.join(", ") });
    return el("div", { class: "cancel-state " + (c.confirmed ? "ok" : "pending"), "data-confirmed": String(c.confirmed) },
      text);
  }

  function tripRow(tr) {
    const cancel = loggedIn() && !tr.cancel ? twoStep("cancel:" + tr.uid, t("Cancel trip"), t("Confirm: cancel trip"),
      () => Web.post("/api/trips/cancel", { trip: tr.uid }), { "data-action": "cancel", "data-trip": tr.uid }) : null;
    return el("tr", { "data-trip": tr.uid },
      el("td", { class: "uid" }, tr.uid), el("td", {}, tripFrom(tr)), el("td", {}, tripTo(tr)),
      el("td", {}, el("ul", { class: "legs" }, tr.legs.map((l) => el("li", { class: l.done ? "done" : "" }, legText(tr, l))))),
      el("td", {}, seconds(tr.age_s + since())),
      el("td", {}, cancelNote(tr), cancel));
  }

  // ---------------------------------------------------------------- links, alerts, history
  function linkTable(links) {
    return table([t("Robot"), t("Link"), t("Last heard"), t("Round trip"), t("Events queued"), t("Re-sent"),
                  t("Dropped"), t("Duplicates suppressed"), t("Connections lost")],
      links.map((k) => el("tr", { "data-peer": k.peer, class: k.known && !k.connected ? "bad" : "" },
        el("td", {}, k.peer), el("td", { class: k.connected ? "ok" : "bad" }, linkState(k)),
        el("td", {}, k.known ? t("{age} ago", { age: seconds(k.heard_s) }) : ""),
        el("td", {}, k.rtt_ms >= 0 ? t("{ms} ms", { ms: number(k.rtt_ms, 1) }) : ""),
        el("td", {}, k.queued), el("td", {}, k.resent), el("td", {}, k.dropped), el("td", {}, k.duplicates),
        el("td", {}, k.losses))), "links");
  }

  function renderLinks() {
    if (!S.links) return;
    $("links-mine-title").textContent = t("Links of {robot}", { robot: S.links.me });
    replace("links-mine", linkTable(S.links.mine));
    const others = Object.keys(S.links.others).sort();
    replace("links-others", others.length ? others.map((name) => {
      const o = S.links.others[name];
      return el("div", { class: "other-links" + (o.current ? "" : " stale") },
        el("h3", {}, name, " · ", o.current ? t("as it said {age} ago", { age: seconds(o.age_s) })
          : t("not heard for {age}", { age: seconds(o.age_s) })), linkTable(o.links));
    }) : el("p", {}, t("nothing heard yet")));
    const s = S.server;
    if (s) {
      const refused = Object.entries(s.refused).filter(([, n]) => n > 0);
      replace("server", el("p", {}, t("{n} requests answered, {c} live clients", { n: s.requests, c: s.clients })),
        el("p", {}, t("Requests refused")),
        refused.length ? table([t("Reason"), t("Count")], refused.map(([k, n]) => el("tr", { "data-refused": k },
          el("td", {}, k.replace("refused_", "")), el("td", {}, n)))) : el("p", {}, t("none")));
    }
  }

  function alertText(a) {
    const p = Object.assign({}, a.params);
    if (p.place) p.place = placeName(p.place);
    let text = t(ALERT_TEXTS[a.kind] || a.kind, p);
    if (a.kind === "robot_offline" && p.why) text += " (" + t(WHY_TEXTS[p.why] || p.why) + ")";
    return text;
  }

  function renderAlerts() {
    const open = S.alerts.filter((a) => !a.acked_by);
    $("alert-count").textContent = open.length ? "(" + open.length + ")" : "";
    $("alert-count").className = open.length ? "badge" : "";
    replace("alerts", S.alerts.length ? table([t("Alert"), t("First"), t("Last"), t("Times"), t("Now"), ""],
      S.alerts.map((a) => el("tr", { "data-alert-id": a.id, "data-kind": a.kind,
                                     class: (a.acked_by ? "acked" : "open") + (a.active ? " active" : "") },
        el("td", {}, alertText(a)), el("td", {}, clock(a.first)), el("td", {}, clock(a.last)), el("td", {}, a.count),
        el("td", {}, a.active ? t("ongoing") : t("over")),
        el("td", {}, a.acked_by ? t("acknowledged by {user}", { user: a.acked_by })
          : loggedIn() ? el("button", { type: "button", "data-action": "ack", onclick: async () => {
            try { await Web.post("/api/alerts/ack", { id: a.id }); } catch (err) { showError(err); }
          } }, t("Acknowledge")) : "")))) : el("p", {}, t("No alerts")));
  }

  async function renderHistory() {
    const h = S.history;
    if (!h || !h.day) { replace("history", el("p", {}, t("nothing recorded yet"))); return; }
    const days = h.days || [h.day];
    const sel = $("history-day");
    if (sel.options.length !== days.length) {
      sel.replaceChildren(...days.map((d) => el("option", { value: d }, d)));
      if (!historyDay) historyDay = h.day;
      sel.value = historyDay;
    }
    let d = h;
    if (historyDay && historyDay !== h.day) {
      const r = await fetch("/api/history/" + encodeURIComponent(historyDay), { cache: "no-store" });
      if (!r.ok) return;
      d = await r.json();
    }
    $("history-csv").setAttribute("href", "/api/history/" + encodeURIComponent(d.day) + "/csv");
    const counts = ["completed", "cancelled", "timed_out", "refused", "failed", "open"];
    replace("history",
      table([t("Trips"), ...counts.map((k) => t(OUTCOME_TEXTS[k]))], [el("tr", { "data-day": d.day },
        el("td", {}, d.trips), counts.map((k) => el("td", { "data-count": k }, d[k])))], "sums"),
      el("p", {}, d.waits ? t("Wait before the first robot moved: mean {mean}, worst {worst} ({n} trips)",
        { mean: seconds(d.wait_mean_s), worst: seconds(d.wait_max_s), n: d.waits }) : t("No wait measured")),
      el("h3", {}, t("Busiest places")),
      d.places.length ? el("ol", {}, d.places.map((p) => el("li", {}, placeName(p.id) + " · " + p.trips))) : el("p", {}, t("none")),
      el("h3", {}, t("Per robot")),
      table([t("Robot"), t("Trips made here"), t("Legs served"), t("Mean wait")], d.robots.map((r) => el("tr", {},
        el("td", {}, r.robot), el("td", {}, r.originated), el("td", {}, r.legs),
        el("td", {}, r.wait_mean_s === null ? "" : seconds(r.wait_mean_s))))));
  }

  // ---------------------------------------------------------------- tours (admin)
  function tourText(tour) {
    return "Tour" + (tour.name ? ": " + tour.name : "") + "\n" + tour.goals.join("\n") + "\n";
  }

  function renderCatalog() {
    const admin = isAdmin();
    $("tour-form").hidden = !admin;
    replace("catalog", S.catalog.length ? table([t("Tour"), t("File name"), t("Stops"), t("Language"), ""],
      S.catalog.map((tour) => el("tr", { "data-tour-file": tour.file },
        el("td", {}, tour.name || tour.file), el("td", {}, tour.file), el("td", {}, tour.goals.length),
        el("td", {}, tour.language),
        el("td", {}, admin ? [el("button", { type: "button", "data-action": "edit-tour", onclick: () => {
          $("tour-file").value = tour.file;
          $("tour-language").value = tour.language || "en";
          $("tour-text").value = tourText(tour);
        } }, t("Edit")), twoStep("delete:" + tour.file, t("Delete"), t("Confirm: delete"),
          () => Web.post("/api/tours/delete", { file_name: tour.file }), { "data-action": "delete-tour" })] : null))))
      : el("p", {}, t("No tours")));
  }

  async function saveTour(e) {
    e.preventDefault();
    const result = $("tour-result");
    try {
      await Web.post("/api/tours/save", { file_name: $("tour-file").value.trim(), text: $("tour-text").value,
                                          language: $("tour-language").value });
      flash(result, t("Tour saved: shared with the other robots"), true);
    } catch (err) {
      flash(result, t("Refused: {why}", { why: err.message }), false);
    }
  }

  // ---------------------------------------------------------------- rendering, live, session
  function renderAll() {
    if (!S.building) return;
    renderFloors();
    renderPanel();
    renderTrips();
    renderLinks();
    renderAlerts();
    renderCatalog();
    renderHistory();
    translateStatic();
  }

  function render(names) {
    if (names.has("building")) buildFloors();
    if (names.has("robots") || names.has("building")) { renderFloors(); renderPanel(); }
    if (names.has("robots") || names.has("trips") || names.has("tours")) renderTrips();
    if (names.has("links") || names.has("server")) renderLinks();
    if (names.has("server")) showConn($("conn").dataset.state);
    if (names.has("alerts")) renderAlerts();
    if (names.has("history")) renderHistory();
    if (names.has("catalog")) renderCatalog();
    if (names.has("trips") || names.has("robots")) renderPanel();
  }

  function onMessage(m) {
    received = Date.now();
    if (m.type !== "update") return;
    const names = new Set(Object.keys(m.sections));
    Object.assign(S, m.sections);
    if (S.building) render(names);
  }

  function onState(state) {
    const before = $("conn").dataset.state;
    showConn(state);
    if (state === "live" && before !== "live") Web.refreshSession().then(showSession).then(renderAll);
  }

  function showConn(state) {
    const c = $("conn");
    c.dataset.state = state;
    c.textContent = state === "live" ? t("live") : state === "connecting" ? t("connecting…") : t("Reconnecting…");
    const down = S.server && !S.server.master_up;
    const b = $("banner");
    if (state !== "live") {
      b.hidden = false;
      b.className = "warn";
      b.textContent = t("The dashboard of this robot does not answer: reconnecting…");
    } else if (down) {
      b.hidden = false;
      b.className = "warn";
      b.textContent = t("The master of {robot} does not answer: its data may be old; reconnecting…", { robot: S.server.robot });
    } else if (b.className === "warn") {
      b.hidden = true;
    }
  }

  function showSession() {
    const s = Web.session;
    $("login").hidden = loggedIn();
    $("whoami").hidden = !loggedIn();
    $("whoami-text").textContent = loggedIn() ? t("Logged in as {user} ({role})", { user: s.user, role: t(ROLE_TEXTS[s.role] || "staff") }) : "";
  }

  function translateStatic() {
    for (const n of document.querySelectorAll("[data-t]")) n.textContent = t(n.dataset.t);
    for (const n of document.querySelectorAll("[data-tp]")) n.setAttribute("placeholder", t(n.dataset.tp));
    document.documentElement.lang = lang();
    showConn($("conn").dataset.state);
  }

  function showView(name) {
    view = name;
    for (const v of document.querySelectorAll(".view")) v.hidden = v.id !== "view-" + name;
    for (const b of document.querySelectorAll("#tabs button")) b.classList.toggle("active", b.dataset.view === name);
    if (location.hash !== "#" + name) history.replaceState(null, "", "#" + name);
  }

  async function start() {
    const stored = localStorage.getItem("gidabot-language");
    $("language").value = ["eu", "en", "es"].includes(stored) ? stored : "en";
    $("tour-language").value = lang();
    await Web.loadTexts(lang());
    translateStatic();
    await Web.refreshSession();
    showSession();
    $("language").addEventListener("change", async () => {
      localStorage.setItem("gidabot-language", lang());
      await Web.loadTexts(lang());
      showSession();
      renderAll();
    });
    $("login").addEventListener("submit", async (e) => {
      e.preventDefault();
      try {
        await Web.login($("login-user").value, $("login-password").value);
        $("login-password").value = "";
      } catch (err) { showError(err); }
      showSession();
      renderAll();
    });
    $("logout-button").addEventListener("click", async () => { await Web.logout(); showSession(); renderAll(); });
    $("tabs").addEventListener("click", (e) => {
      const b = e.target.closest("button");
      if (b) showView(b.dataset.view);
    });
    $("history-day").addEventListener("change", () => { historyDay = $("history-day").value; renderHistory(); });
    $("tour-form").addEventListener("submit", saveTour);
    $("tour-upload").addEventListener("change", () => {
      const f = $("tour-upload").files[0];
      if (!f) return;
      if (!$("tour-file").value) $("tour-file").value = f.name;
      const reader = new FileReader();
      reader.onload = () => { $("tour-text").value = String(reader.result); };
      reader.readAsText(f);
    });
    const wanted = location.hash.slice(1);
    showView(document.getElementById("view-" + wanted) ? wanted : "building");
    window.addEventListener("hashchange", () => {
      const name = location.hash.slice(1);
      if (document.getElementById("view-" + name) && name !== view) showView(name);
    });
    setInterval(() => { if (S.building) { renderFloors(); renderPanel(); if (view === "trips") renderTrips(); } }, 1000);
    Web.live("/live", onMessage, onState);
  }

  document.addEventListener("DOMContentLoaded", start);
})();
