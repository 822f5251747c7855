// SPDX-License-Identifier: MIT
// The report of `lbpkit rehearse CONFIG.ini [--report DIR]`: one terminal
// line per check, and report.html, one self-contained page (inline style,
// Chart.js and data; no network, no file beside it) with a summary table
// and a plot of each check that recorded one. Pure functions of the report
// JSON; the command writes what they return.
//
// The report JSON:
//   {"lbpkit": "rehearse",
//    "configuration": "/home/u/mill/mill.ini",   the INI file rehearsed
//    "machine": "mill (derived from the configuration)",
//    "linear_units": "mm",                       distances in it, velocities in it per s
//    "verdict": "pass" | "fail",                 "fail" when any check failed
//    "checks": [ {
//      "id": "runaway.x.reversed-encoder.moving", unique, stable across runs
//      "check": "runaway",                       the kind: runaway, estop, limits, host, field-power, spindle
//      "title": "X: reversed encoder while moving at MAX_VELOCITY",
//      "verdict": "pass" | "fail" | "not applicable",
//      "reason": "",                             why it failed or does not apply
//      "cites": "7I77 manual, ...; LinuxCNC [JOINT_0]FERROR, joint.0.f-error",
//      "figures": {name: value, ...},            see below; may be empty
//      "plot": {                                 optional
//        "time_s": [t, ...],                     seconds from the start of the recording
//        "series": {name: [value, ...], ...},    each as long as time_s (null: no sample)
//        "units": {name: "mm", ...},             "" with values 0/1: an on/off signal
//        "events": [{"t": 0.5, "what": "reversed encoder"}, ...]}  the fault first
//    }, ...]}
// The figures this knows by name (others print as "name = value"):
//   time_to_disable_s, time_to_zero_volts_s, time_to_ena_off_s,
//   time_to_outputs_off_s (s from the fault); distance (travelled after the
//   fault), bound (what it may be), left_to_hard_stop, past_switch (in
//   linear_units); peak_velocity (linear_units/s); hit_hard_stop (bool);
//   error_counts ({name: count} or a count).
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>

namespace lbpkit::app::rehearse {

// One line for the terminal: the verdict ("pass", "FAIL", "n/a"), the
// check's title, its figures with their units, and the reason when there
// is one, e.g.
//   pass  X: reversed encoder while moving at MAX_VELOCITY — drives off after 0.021 s,
//         9.8 mm travelled (bound 12.0 mm), peak 510.0 mm/s, 310.2 mm left to the hard stop
// (one line). Distances are in `linearUnits` (the report's linear_units).
// Fields missing or of the wrong type are left out or shown as "?"; never
// throws. Control characters from the JSON are printed as spaces.
[[nodiscard]] std::string checkLine(const nlohmann::json& check, std::string_view linearUnits = "mm");

// report.html for the whole report: the summary table (verdict, title,
// figures, what the check cites) and a Chart.js line chart of each check's
// plot (its series against time, on/off signals stepped on a second axis,
// the events' times as dashed vertical lines). Everything from the JSON is
// escaped for HTML, and the plots' data for the <script> it sits in.
[[nodiscard]] std::string reportHtml(const nlohmann::json& report);

}  // namespace lbpkit::app::rehearse
