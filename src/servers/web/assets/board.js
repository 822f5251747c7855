// SPDX-License-Identifier: MIT
// The 7I77 as the manual draws and names it (7I77 manual: CONNECTORS,
// STATUS LEDs, HARDWARE CONFIGURATION), built once per connector and then
// updated from each frame's state. Every control calls lbpkit.post(), an
// ordinary POST of the control API.
"use strict";
const lbpkit = window.lbpkit = window.lbpkit || {};

function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === "onclick" || k === "onchange" || k === "oninput") e[k] = v;
    else if (k === "text") e.textContent = v;
    else e.setAttribute(k, v);
  }
  for (const c of children) if (c != null) e.append(c);
  return e;
}
lbpkit.el = el;

// STATUS LEDs: the manual's list, with its colours and functions.
const kLeds = [
  ["CR1", "yellow", "5V monitor"], ["CR3", "yellow", "Field voltage monitor"],
  ["CR6", "yellow", "+16V monitor"], ["CR7", "yellow", "-12V monitor"],
  ["CR15", "green", "Field I/O activity (blinks at about 1 Hz at a 1 kHz update rate)"],
  ["CR16", "red", "Field I/O fault (watchdog fault before the host talks to it)"],
];
// TB2 FIELD POWER, pins 1..8.
const kTb2 = ["VFIELD", "VFIELD", "VFIELD", "VFIELD", "VIN", "NC", "NC", "GROUND"];
// TB5: ENAn-, ENAn+, GND, AOUTn for n = 0..5.
// TB6 RS-422 INTERFACE.
const kTb6 = ["GND", "GND", "RX+", "RX-", "TX+", "TX-", "+5V", "+5V"];

lbpkit.buildBoard = function (root, d) {
  const c = d.connector;
  const id = (s) => `${s}-${c}`;
  const card = el("div", { class: "card", id: id("card") });
  // Left: power, jumpers, LEDs.
  const tb2 = el("div", { class: "tb" });
  kTb2.forEach((name, i) => tb2.append(el("div", { class: "pin", id: id(`tb2-${i + 1}`) },
    el("span", { class: "no", text: String(i + 1) }), el("span", { text: name }))));
  const field = el("input", { type: "range", min: "0", max: "36", step: "0.5", id: id("field"),
    title: "drag: POST /api/field {volts}" });
  field.onchange = () => lbpkit.post("field", { connector: c, volts: Number(field.value) });
  const leds = el("div", { class: "leds" });
  for (const [name, colour, what] of kLeds)
    leds.append(el("span", { class: `led ${colour}`, id: id(`led-${name}`), title: `${name} (${colour}): ${what}` },
      el("span", { class: "dot" }), el("span", { text: name })));
  const chips = el("div");
  for (let chip = 0; chip < 2; ++chip) {
    const b = el("label", { title: "POST /api/overtemp {chip, hot}" },
      el("input", { type: "checkbox", id: id(`hot-${chip}`) }), ` driver chip ${chip} (outputs ${chip * 8}..${chip * 8 + 7}) overheated`);
    b.querySelector("input").onchange = (e) => lbpkit.post("overtemp", { connector: c, chip, hot: e.target.checked });
    chips.append(b, el("br"));
  }
  card.append(el("div", { class: "left" },
    el("h3", { text: `7I77 on connector ${c}` }),
    el("div", { class: "blk" }, el("h3", { text: "STATUS LEDs" }), leds),
    el("div", { class: "blk" }, el("h3", { text: "TB1 AUX 5V" }), el("div", { class: "tb" },
      el("div", { class: "pin" }, el("span", { class: "no", text: "1" }), el("span", { text: "GND" })),
      el("div", { class: "pin" }, el("span", { class: "no", text: "2" }), el("span", { text: "5V" })))),
    el("div", { class: "blk" }, el("h3", { text: "TB2 FIELD POWER" }), tb2,
      el("div", {}, "VFIELD ", el("b", { id: id("vfield") }), " V ", field),
      el("div", {}, "VIN ", el("b", { id: id("vin") }), " V")),
    el("div", { class: "blk" }, el("h3", { text: "Jumpers" }), el("div", { id: id("jumpers") })),
    el("div", { class: "blk" }, el("h3", { text: "Output drivers" }), chips)));
  // Top: encoders TB3/TB4.
  const enc = el("table", { id: id("encoders") }, el("tr", {}, ...["encoder", "terminal", "count", "position",
    "velocity", "counts/rev (index)", "set velocity"].map((t) => el("th", { text: t }))));
  for (let n = 0; n < 6; ++n) {
    const v = el("input", { type: "number", step: "100", value: "0", style: "width:80px", id: id(`enc-vel-${n}`),
      title: "counts per second: POST /api/encoder {encoder, velocity}" });
    v.onchange = () => lbpkit.post("encoder", { connector: c, encoder: n, velocity: Number(v.value) });
    enc.append(el("tr", {}, el("td", { text: String(n) }),
      el("td", { text: `${n < 3 ? "TB3" : "TB4"} ${(n % 3) * 8 + 1}..${(n % 3) * 8 + 8}` }),
      el("td", { id: id(`enc-count-${n}`) }), el("td", { id: id(`enc-pos-${n}`) }), el("td", { id: id(`enc-v-${n}`) }),
      el("td", { id: id(`enc-cpr-${n}`) }), el("td", {}, v)));
  }
  card.append(el("div", { class: "top blk" }, el("h3", { text: "TB3 ENCODER 0 THROUGH 2, TB4 ENCODER 3 THROUGH 5 (QAn /QAn QBn /QBn IDXn /IDXn)" }), enc));
  // Mid: analog TB5 and RS-422 TB6 with the SSLBP channels.
  const ana = el("table", { id: id("analog") }, el("tr", {}, ...["TB5 pins", "AOUTn", "volts", "ENAn"].map((t) => el("th", { text: t }))));
  for (let n = 0; n < 6; ++n)
    ana.append(el("tr", {}, el("td", { text: `${n * 4 + 1}..${n * 4 + 4}` }), el("td", { text: `AOUT${n}` }),
      el("td", { id: id(`aout-${n}`) }), el("td", { id: id(`ena-${n}`) })));
  card.append(el("div", { class: "mid blk" }, el("h3", { text: "TB5 ANALOG DRIVE INTERFACE" }), ana,
    el("div", { class: "faults", id: id("analog-faults") })));
  // Right: TB8 and TB7, the field inputs and outputs, in pin order.
  const io = el("div", { class: "io" });
  for (const [tb, base, obase] of [["TB8", 0, 0], ["TB7", 16, 8]]) {
    const col = el("div", { class: "tb" }, el("h3", { text: `${tb} (pin 1 at the bottom edge)` }));
    for (let pin = 24; pin >= 1; --pin) {
      if (pin > 16) {
        const o = obase + pin - 17;
        const sel = el("select", { id: id(`load-${o}`), title: "POST /api/output {output, short | ohms}" },
          ...["open", "load 1k", "short"].map((t) => el("option", { value: t, text: t })));
        sel.onchange = () => lbpkit.post("output", Object.assign({ connector: c, output: o },
          sel.value === "short" ? { short: true } : sel.value === "open" ? { ohms: null } : { ohms: 1000 }));
        col.append(el("div", { class: "pin output", id: id(`out-${o}`) }, el("span", { class: "no", text: String(pin) }),
          el("span", { class: "lamp" }), el("span", { text: `OUTPUT${o}` }), sel));
      } else {
        const i = base + pin - 1;
        const p = el("div", { class: "pin input", id: id(`in-${i}`), title: "click: POST /api/input {input, on}" },
          el("span", { class: "no", text: String(pin) }), el("span", { class: "lamp" }), el("span", { text: `INPUT${i}` }));
        p.onclick = () => lbpkit.post("input", { connector: c, input: i, on: !p.classList.contains("on") });
        col.append(p);
      }
    }
    io.append(col);
  }
  card.append(el("div", { class: "right blk" }, el("h3", { text: "FIELD INPUT/OUTPUT CONNECTORS" }), io,
    el("div", {}, "field I/O faults: ", el("span", { class: "faults", id: id("fio-faults") }))));
  root.append(card);
};

lbpkit.buildChannels = function (root, channels) {
  const t = el("table", { id: "channels" }, el("tr", {}, ...["channel", "cable (TB6 / DB25)", "state", "CS", "remote faults",
    "to remote", "from remote", "dropped", "corrupted", "breaks"].map((s) => el("th", { text: s }))));
  for (const ch of channels) {
    const n = ch.channel;
    const b = el("button", { id: `ch-${n}-cable`, title: "POST /api/cable {channel, connected}" });
    b.onclick = () => lbpkit.post("cable", { channel: n, connected: b.dataset.connected !== "true" });
    t.append(el("tr", {}, el("td", { text: String(n) }), el("td", {}, b), el("td", { id: `ch-${n}-state` }),
      el("td", { id: `ch-${n}-cs` }), el("td", { class: "faults", id: `ch-${n}-faults` }),
      ...["to_remote", "from_remote", "dropped", "corrupted", "breaks"].map((k) => el("td", { id: `ch-${n}-${k}` }))));
  }
  root.append(el("div", { class: "blk sslbp" }, el("h3", { text: "SSLBP channels (TB6 RS-422 INTERFACE: " + kTb6.join(" ") + ")" }), t));
};

function setText(id, text) {
  const e = document.getElementById(id);
  if (e && e.textContent !== text) e.textContent = text;
}
lbpkit.setText = setText;
const fmt = (v, n = 3) => (typeof v === "number" ? v.toFixed(n) : String(v));
lbpkit.fmt = fmt;

lbpkit.updateBoard = function (d) {
  const c = d.connector;
  const id = (s) => `${s}-${c}`;
  const fio = d.field_io, an = d.analog;
  for (const [name] of kLeds) {
    const e = document.getElementById(id(`led-${name}`));
    const lit = !!(d.leds && d.leds[name]);
    e.classList.toggle("lit", lit);
    e.dataset.lit = String(lit);
  }
  setText(id("vfield"), fmt(fio.field_voltage, 1));
  setText(id("vin"), fmt(fio.vin, 1));
  const f = document.getElementById(id("field"));
  if (document.activeElement !== f) f.value = fio.field_voltage;
  // Jumpers: what the state shows of them (setup mode runs at 115.2 kBaud).
  const j = d.jumpers || {};
  const w12 = j.W12 || (fio.baud === 115200 ? "right: setup mode" : "left: operate mode");
  const w4 = j.W4 || (an.baud === 115200 ? "right: setup mode" : "left: operate mode");
  const w1 = j.W1 || (fio.vin === fio.field_voltage ? "left: VIN from field power" : "right: VIN from TB2 pin 5");
  setText(id("jumpers"), `W1 ${w1}; W4 (analog) ${w4}; W12 (field I/O) ${w12}; field I/O at ${fio.baud} baud`);
  fio.inputs.forEach((inp, i) => {
    const e = document.getElementById(id(`in-${i}`));
    e.classList.toggle("on", inp.on);
    e.dataset.on = String(inp.on);
    e.title = `INPUT${i}: ${fmt(inp.volts, 2)} V (click: POST /api/input)`;
  });
  fio.outputs.forEach((o, i) => {
    const e = document.getElementById(id(`out-${i}`));
    e.classList.toggle("on", o.on);
    e.classList.toggle("tripped", o.tripped);
    e.dataset.on = String(o.on);
    e.dataset.tripped = String(o.tripped);
    e.title = `OUTPUT${i}: ${fmt(o.volts, 2)} V, ${Number.isFinite(o.amps) ? fmt(o.amps * 1000, 0) + " mA" : "short"}${o.tripped ? ", tripped" : ""}`;
  });
  setText(id("fio-faults"), (fio.faults || []).join(", ") || "none");
  setText(id("analog-faults"), "analog processor faults: " + ((an.faults || []).join(", ") || "none"));
  an.outputs.forEach((o, n) => {
    setText(id(`aout-${n}`), fmt(o.volts, 3));
    setText(id(`ena-${n}`), o.enable ? "enabled" : "off");
  });
  d.encoders.forEach((e, n) => {
    setText(id(`enc-count-${n}`), String(e.count));
    setText(id(`enc-pos-${n}`), fmt(e.position, 3));
    setText(id(`enc-v-${n}`), fmt(e.velocity, 0));
    setText(id(`enc-cpr-${n}`), String(e.counts_per_rev));
  });
};

lbpkit.updateChannels = function (channels) {
  for (const ch of channels) {
    const n = ch.channel;
    const b = document.getElementById(`ch-${n}-cable`);
    b.dataset.connected = String(ch.cable_connected);
    b.textContent = ch.cable_connected ? "plugged: unplug" : "UNPLUGGED: plug in";
    setText(`ch-${n}-state`, ch.running ? "running" : "stopped");
    const cs = parseInt(ch.cs, 16);
    setText(`ch-${n}-cs`, `${ch.cs} (${(cs >>> 0).toString(2).padStart(32, "0").replace(/(.{8})/g, "$1 ").trim()})`);
    setText(`ch-${n}-faults`, (ch.remote_faults || []).join(", ") || "none");
    for (const k of ["to_remote", "from_remote", "dropped", "corrupted", "breaks"]) setText(`ch-${n}-${k}`, String(ch.link[k]));
  }
};
