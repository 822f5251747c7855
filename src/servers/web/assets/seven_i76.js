// SPDX-License-Identifier: MIT
// The 7I76 on the 7I77+7I76 firmwares: its field I/O processor
// on its SSerial channel, as GET /api/state lists it among the daughtercards
// ("type": "7I76"): 32 inputs, 16 sourcing outputs, field power and the
// spindle interface (SpinOut volts, SpinEna, SpinDir: LinuxCNC sserial(9)'s
// spinout, spinena, spindir). No public 7I76 manual text names its
// terminals here, so the page names the signals, not pins. Built once, then
// updated from each frame; every control is an ordinary POST of the control API.
"use strict";
(function () {
  const L = window.lbpkit;
  const el = L.el;
  const kInputs = 32, kOutputs = 16;

  L.build76 = function (root, d) {
    const c = d.connector;
    const card = el("div", { class: "card i76", id: "i76-card" });
    const field = el("input", { type: "range", min: "0", max: "36", step: "0.5", id: "i76-field",
      title: "drag: POST /api/field {connector, volts}" });
    field.onchange = () => L.post("field", { connector: c, volts: Number(field.value) });
    card.append(el("div", { class: "left" },
      el("h3", { text: `7I76 on connector ${c} (${d.connector_name}), SSerial channel ${d.channel}` }),
      el("div", { class: "blk" }, el("h3", { text: "Field power" }),
        el("div", {}, "VFIELD ", el("b", { id: "i76-vfield" }), " V ", field)),
      el("div", { class: "blk" }, el("h3", { text: "Field I/O processor" }), el("div", { id: "i76-device" }),
        el("div", {}, "faults: ", el("span", { class: "faults", id: "i76-faults" }))),
      el("div", { class: "blk" }, el("h3", { text: "Spindle interface" }),
        el("table", { id: "i76-spindle" },
          el("tr", {}, el("th", { text: "SPINOUT" }), el("td", { id: "i76-spinout" }), el("td", { text: "V (0..10)" })),
          el("tr", {}, el("th", { text: "SPINENA" }), el("td", { id: "i76-spinena" })),
          el("tr", {}, el("th", { text: "SPINDIR" }), el("td", { id: "i76-spindir" }))))));
    // Inputs in two columns of 16, outputs in one: lamps as on the 7I77.
    const io = el("div", { class: "io i76-io" });
    for (const base of [0, 16]) {
      const col = el("div", { class: "tb" }, el("h3", { text: `inputs ${base}..${base + 15}` }));
      for (let i = base; i < base + 16; ++i) {
        const p = el("div", { class: "pin input", id: `i76-in-${i}`, title: "click: POST /api/input {connector, input, on}" },
          el("span", { class: "no", text: String(i) }), el("span", { class: "lamp" }), el("span", { text: `INPUT${i}` }));
        p.onclick = () => L.post("input", { connector: c, input: i, on: !p.classList.contains("on") });
        col.append(p);
      }
      io.append(col);
    }
    const outs = el("div", { class: "tb" }, el("h3", { text: "outputs 0..15 (sourcing)" }));
    for (let o = 0; o < kOutputs; ++o)
      outs.append(el("div", { class: "pin output", id: `i76-out-${o}` }, el("span", { class: "no", text: String(o) }),
        el("span", { class: "lamp" }), el("span", { text: `OUTPUT${o}` })));
    io.append(outs);
    card.append(el("div", { class: "right blk" }, el("h3", { text: "FIELD INPUTS AND OUTPUTS" }), io));
    root.append(card);
  };

  L.update76 = function (d) {
    const fio = d.field_io, sp = d.spindle;
    L.setText("i76-vfield", L.fmt(fio.field_voltage, 1));
    const f = document.getElementById("i76-field");
    if (document.activeElement !== f) f.value = fio.field_voltage;
    L.setText("i76-device", `${fio.powered ? "powered" : "UNPOWERED"}, mode ${fio.mode}, unit ${fio.unit_number}, ` +
      `watchdog ${fio.watchdog_ms} ms, ${fio.baud} baud`);
    L.setText("i76-faults", (fio.faults || []).join(", ") || "none");
    for (let i = 0; i < kInputs && i < fio.inputs.length; ++i) {
      const e = document.getElementById(`i76-in-${i}`);
      e.classList.toggle("on", fio.inputs[i].on);
      e.dataset.on = String(fio.inputs[i].on);
    }
    for (let o = 0; o < kOutputs && o < fio.outputs.length; ++o) {
      const out = fio.outputs[o], e = document.getElementById(`i76-out-${o}`);
      e.classList.toggle("on", out.on);
      e.dataset.on = String(out.on);
      e.title = `OUTPUT${o}: ${L.fmt(out.volts, 2)} V`;
    }
    L.setText("i76-spinout", L.fmt(sp.volts, 3));
    L.setText("i76-spinena", sp.enable ? "enabled" : "off");
    L.setText("i76-spindir", sp.direction ? "on" : "off");
  };
})();
