// SPDX-License-Identifier: MIT
// The page's life: the event stream (GET /api/events, server-sent events
// read with fetch so a token can go with it), the board and machine built
// from the first frame and updated from each, the plots (Chart.js), and
// every action as an ordinary POST of the control API.
"use strict";
(function () {
  const L = window.lbpkit;
  const el = L.el;
  const kWindow = 10;  // seconds of history in the plots
  const token = new URLSearchParams(location.hash.slice(1)).get("token") || sessionStorage.getItem("lbpkit-token") || "";
  if (token) sessionStorage.setItem("lbpkit-token", token);
  const headers = (extra) => Object.assign(token ? { Authorization: `Bearer ${token}` } : {}, extra || {});

  L.post = async function (kind, body) {
    try {
      const r = await fetch(`/api/${kind}`, { method: "POST", headers: headers({ "Content-Type": "application/json" }),
        body: JSON.stringify(body) });
      const j = await r.json().catch(() => ({}));
      L.setText("error", r.ok ? "" : `${kind}: ${j.error || r.status}`);
      return r.ok;
    } catch (e) {
      L.setText("error", `${kind}: ${e}`);
      return false;
    }
  };

  let built = false, firstAt = null;
  const arrivals = [];
  const charts = L.charts = {};
  const plotData = L.plotData = { analog: [], axes: {} };

  function chart(canvas, datasets, y1) {
    const scales = { x: { type: "linear", title: { display: true, text: "simulated time (s)" } },
                     y: { title: { display: true, text: datasets[0].unit } } };
    if (y1) scales.y1 = { position: "right", grid: { drawOnChartArea: false }, title: { display: true, text: y1 } };
    return new Chart(canvas, {
      type: "line",
      data: { datasets: datasets.map((d) => ({ label: d.label, data: [], yAxisID: d.axis || "y", borderColor: d.colour,
        borderWidth: 1.5, pointRadius: 0, parsing: false })) },
      options: { animation: false, responsive: true, maintainAspectRatio: false, normalized: true,
        plugins: { legend: { position: "top", labels: { boxWidth: 12 } } }, scales },
    });
  }
  function trim(arr, now) {
    let k = 0;
    while (k < arr.length && arr[k].x < now - kWindow) ++k;
    if (k) arr.splice(0, k);
  }

  function buildMachine(m) {
    document.getElementById("machine").hidden = false;
    L.setText("machine-name", m.name);
    document.getElementById("estop-press").onclick = (e) =>
      L.post("machine", { action: "estop", pressed: e.target.dataset.pressed !== "true" });
    const body = document.querySelector("#axes tbody");
    for (const a of m.axes) {
      const n = a.name;
      // A stepper axis can be jammed, not pushed, and has no encoder
      // (docs/machines.md: a stepper axis; the API refuses both).
      const stepper = !!a.stepper;
      const jam = el("button", { id: `jam-${n}`, text: "jam", onclick: (e) => L.post("machine", { action: "jam", axis: n,
        jammed: e.target.dataset.jammed !== "true" }) });
      const ctl = stepper ? el("span", {}, jam) : el("span", {},
        el("button", { text: "push -5", onclick: () => L.post("machine", { action: "push", axis: n, distance: -5 }) }), " ",
        el("button", { text: "push +5", onclick: () => L.post("machine", { action: "push", axis: n, distance: 5 }) }), " ",
        jam, " ",
        ...["A", "B", "index"].map((ch) => el("button", { id: `enc-${n}-${ch}`, text: `break ${ch}`,
          onclick: (e) => L.post("machine", { action: "encoder", axis: n, channel: ch, broken: e.target.dataset.broken !== "true" }) })));
      // The stepper's StepGen: steps made, steps the motor lost, stalled.
      const amp = stepper
        ? el("td", { id: `amp-${n}`, class: "stepper" }, `StepGen ${a.stepper.stepgen}: `, el("span", { id: `steps-${n}` }),
          " steps, ", el("span", { id: `lost-${n}` }), " lost, ", el("span", { id: `stall-${n}` }))
        : el("td", { id: `amp-${n}` });
      body.append(el("tr", { id: `axis-${n}` }, el("td", { text: n }), el("td", { id: `pos-${n}` }), el("td", { id: `vel-${n}` }),
        el("td", { id: `cmd-${n}` }), el("td", { id: `fe-${n}` }), amp, el("td", { id: `sw-${n}` }),
        el("td", {}, ctl)));
      const canvas = el("canvas", { id: `plot-${n}` });
      document.getElementById("plots").append(el("div", {}, el("h3", { text: `${n}: commanded vs actual position, following error` }),
        el("div", { class: "plot" }, canvas)));
      plotData.axes[n] = { command: [], position: [], fe: [] };
      charts[n] = chart(canvas, [
        { label: `${n} commanded`, colour: "#1e88e5", unit: "position (machine units)" },
        { label: `${n} actual`, colour: "#e53935", unit: "position" },
        { label: `${n} following error`, colour: "#8e24aa", axis: "y1" }], "following error");
      charts[n].data.datasets[0].data = plotData.axes[n].command;
      charts[n].data.datasets[1].data = plotData.axes[n].position;
      charts[n].data.datasets[2].data = plotData.axes[n].fe;
    }
  }

  // What is wired to the 7I76 rather than the 7I77 says so.
  const on76 = (part) => (part.daughtercard === "7I76" ? " (7I76)" : "");

  // A drive's amplifier and the faults on it and its encoder.
  const driveText = (d) => (d.enabled ? "enabled" : "off") +
    (d.enable_ignored ? " (ENA ignored)" : "") +
    (d.encoder_broken.length ? ` (encoder ${d.encoder_broken.join("+")} broken)` : "") +
    (d.encoder_reversed ? " (encoder reversed)" : "");

  function updateMachine(m) {
    const chain = document.getElementById("estop-chain");
    chain.textContent = m.estop_ok ? "E-stop chain closed (ok)" : "E-stop chain OPEN";
    chain.className = "badge " + (m.estop_ok ? "on" : "off");
    const estop = m.switches.find((s) => s.kind === "estop");
    const b = document.getElementById("estop-press");
    b.dataset.pressed = String(!!(estop && estop.tripped));
    b.textContent = estop && estop.tripped ? "release E-stop" : "press E-stop";
    for (const a of m.axes) {
      const n = a.name;
      L.setText(`pos-${n}`, L.fmt(a.position));
      L.setText(`vel-${n}`, L.fmt(a.velocity));
      L.setText(`cmd-${n}`, L.fmt(a.command_velocity));
      L.setText(`fe-${n}`, L.fmt(a.following_error, 4));
      if (a.stepper) {
        const st = a.stepper, stall = document.getElementById(`stall-${n}`);
        L.setText(`steps-${n}`, String(st.steps));
        L.setText(`lost-${n}`, String(st.lost_steps));
        L.setText(`stall-${n}`, (st.stalled ? "STALLED" : "in step") + (a.jammed ? " JAMMED" : ""));
        stall.classList.toggle("stalled", st.stalled);
        stall.dataset.stalled = String(st.stalled);
      } else {
        L.setText(`amp-${n}`, a.drives.map(driveText).join(", ") + (a.jammed ? " JAMMED" : ""));
      }
      L.setText(`sw-${n}`, a.switches.map((s) => s.name + on76(s) + (s.tripped ? " TRIPPED" : "")).join(", "));
      document.getElementById(`jam-${n}`).dataset.jammed = String(a.jammed);
      document.getElementById(`jam-${n}`).textContent = a.jammed ? "free" : "jam";
      if (a.stepper || !a.drives.length) continue;
      for (const ch of ["A", "B", "index"]) {
        const broken = a.drives[0].encoder_broken.includes(ch);
        const e = document.getElementById(`enc-${n}-${ch}`);
        e.dataset.broken = String(broken);
        e.textContent = (broken ? "mend " : "break ") + ch;
      }
    }
    const s = m.spindle;
    L.setText("spindle", s ? `spindle${on76(s)}: ${s.running ? "running" : "stopped"}, ${L.fmt(s.rpm, 0)} rpm (commanded ${L.fmt(s.command_rpm, 0)})` : "");
  }

  function collect(frame) {
    const st = frame.state, now = st.time_s;
    if (!built) return;  // the charts come with the first drawing
    const d0 = st.daughtercards[0];
    if (d0) {
      if (!charts.analog) {
        plotData.analog = d0.analog.outputs.map(() => []);
        charts.analog = chart(document.getElementById("analog-plot"),
          d0.analog.outputs.map((_, n) => ({ label: `AOUT${n}`, colour: ["#e53935", "#1e88e5", "#43a047", "#fb8c00", "#8e24aa", "#00897b"][n], unit: "volts" })));
        charts.analog.data.datasets.forEach((ds, n) => (ds.data = plotData.analog[n]));
      }
      d0.analog.outputs.forEach((o, n) => { plotData.analog[n].push({ x: now, y: o.volts }); trim(plotData.analog[n], now); });
    }
    const tr = frame.trace;
    if (tr && tr.rows) {
      const col = (name) => tr.columns.indexOf(name);
      for (const n of Object.keys(plotData.axes)) {
        const p = col(`${n}_position`), fe = col(`${n}_following_error`), pd = plotData.axes[n];
        for (const r of tr.rows) {
          // The commanded position is where the axis would be without its lag.
          pd.position.push({ x: r[0], y: r[p] });
          pd.command.push({ x: r[0], y: r[p] + r[fe] });
          pd.fe.push({ x: r[0], y: r[fe] });
        }
        for (const a of Object.values(pd)) trim(a, now);
      }
    }
  }

  // Every frame's data goes into the plots' arrays at once; the page is
  // drawn at most once per animation frame, from the newest frame, so a
  // slow machine drops drawings, never data, and the stream never backs up.
  let pending = null;
  function onFrame(frame) {
    // Frames received over the last two seconds.
    L.frames = (L.frames || 0) + 1;
    const t = performance.now();
    arrivals.push(t);
    while (arrivals[0] < t - 2000) arrivals.shift();
    if (firstAt !== null && t - firstAt >= 2000) L.rate = arrivals.length / 2;
    collect(frame);
    const first = pending === null;
    pending = frame;
    if (first) requestAnimationFrame(() => {
      const f = pending;
      pending = null;
      render(f);
    });
  }

  function render(frame) {
    const st = frame.state;
    if (!built) {
      built = true;
      firstAt = performance.now();
      const root = document.getElementById("boards");
      for (const d of st.daughtercards) (d.type === "7I76" ? L.build76 : L.buildBoard)(root, d);
      L.buildChannels(root, st.sserial.channels);
      if (st.machine) buildMachine(st.machine);
      L.setText("card-name", `: virtual ${st.card.name} at ${st.card.address}:${st.card.port}`);
      document.getElementById("paused").onchange = (e) => L.post("time", { paused: e.target.checked });
    }
    for (const d of st.daughtercards) (d.type === "7I76" ? L.update76 : L.updateBoard)(d);
    L.updateChannels(st.sserial.channels);
    if (st.machine) updateMachine(st.machine);
    L.setText("simtime", `t = ${st.time_s.toFixed(3)} s${st.clock.paused ? " (paused)" : ""}`);
    L.setText("host", `${st.server.datagrams} datagrams, server median ${st.server.median_us.toFixed(1)} us`);
    document.getElementById("paused").checked = st.clock.paused;
    for (const c of Object.values(charts)) c.update("none");
    L.lastFrame = frame;
    L.drawings = (L.drawings || 0) + 1;
    if (L.rate !== undefined) L.setText("rate", `${L.rate.toFixed(1)} frames/s`);
  }

  async function stream() {
    const link = document.getElementById("link");
    for (;;) {
      try {
        const r = await fetch("/api/events", { headers: headers(), cache: "no-store" });
        if (!r.ok) throw new Error(`HTTP ${r.status}`);
        link.textContent = "live";
        link.className = "badge on";
        const reader = r.body.getReader();
        const decoder = new TextDecoder();
        let buf = "";
        for (;;) {
          const { value, done } = await reader.read();
          if (done) break;
          buf += decoder.decode(value, { stream: true });
          let end;
          while ((end = buf.indexOf("\n\n")) >= 0) {
            const ev = buf.slice(0, end);
            buf = buf.slice(end + 2);
            const data = ev.split("\n").filter((l) => l.startsWith("data: ")).map((l) => l.slice(6)).join("\n");
            if (data) onFrame(JSON.parse(data));
          }
        }
      } catch (e) {
        L.setText("error", `event stream: ${e.message}`);
      }
      link.textContent = "reconnecting";
      link.className = "badge off";
      await new Promise((ok) => setTimeout(ok, 1000));
    }
  }
  stream();
})();
