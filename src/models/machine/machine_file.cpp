// SPDX-License-Identifier: MIT
#include "machine/machine_file.hpp"

#include <cstdint>
#include <string>
#include <utility>

namespace lbpkit::model::machine {

namespace {

// A velocity-mode servo drive as commonly set up for analog +-10 V: 300 rpm
// per volt, so 10 V is 3000 rpm.
DriveDescription servo(unsigned channel, std::uint32_t lines = 2000) {
  DriveDescription d;
  d.analogOutput = channel;
  d.enable = channel;
  d.encoderInput = channel;
  d.amplifier.mode = AmplifierMode::Velocity;
  d.amplifier.gain = 5.0;    // rev/s per volt (300 rpm/V)
  d.amplifier.limit = 55.0;  // rev/s: 3300 rpm
  d.amplifier.peakTorque = 7.0;
  d.amplifier.bandwidthHz = 100.0;
  d.encoder = EncoderParameters{lines, true, false};
  return d;
}

AxisDescription linear(std::string name, std::vector<DriveDescription> drives, double pitch, double mass, double min,
                       double max, double initial) {
  AxisDescription a;
  a.name = std::move(name);
  a.drives = std::move(drives);
  a.screwPitch = pitch;
  a.massKg = mass;
  a.travelMin = min;
  a.travelMax = max;
  a.initialPosition = initial;
  return a;
}

// Home switch (normally open, a cam that holds it closed from `home` to the
// end of travel towards it), min and max limits (normally closed, on the
// field supply: on while the axis is inside them), `beyond` past the travel.
void addAxisSwitches(MachineDescription& m, const AxisDescription& a, unsigned homeInput, unsigned minInput,
                     unsigned maxInput, double home, bool homeAtMax, double beyond = 2.0) {
  m.switches.push_back({a.name + "-home", SwitchKind::Home, homeInput, Contact::NormallyOpen, a.name, home, homeAtMax});
  m.switches.push_back(
      {a.name + "-min", SwitchKind::MinLimit, minInput, Contact::NormallyClosed, a.name, a.travelMin - beyond, false});
  m.switches.push_back(
      {a.name + "-max", SwitchKind::MaxLimit, maxInput, Contact::NormallyClosed, a.name, a.travelMax + beyond, true});
}

}  // namespace

MachineDescription mill() {
  MachineDescription m;
  m.name = "mill";
  m.axes.push_back(linear("x", {servo(0)}, 5.0, 150.0, 0.0, 400.0, 200.0));
  m.axes.push_back(linear("y", {servo(1)}, 5.0, 250.0, 0.0, 300.0, 150.0));
  AxisDescription z = linear("z", {servo(2)}, 5.0, 60.0, -150.0, 0.0, -75.0);
  z.vertical = true;
  z.brakeOutput = 2;  // output on: brake released
  z.brakeTorque = 4.0;
  m.axes.push_back(z);
  // Home at X max, Y max, Z top: the home cams hold their switches closed
  // over the last 5 mm.
  addAxisSwitches(m, m.axes[0], 0, 1, 2, 395.0, true);
  addAxisSwitches(m, m.axes[1], 3, 4, 5, 295.0, true);
  addAxisSwitches(m, m.axes[2], 6, 7, 8, -5.0, true);
  m.switches.push_back({"estop", SwitchKind::Estop, 9, Contact::NormallyClosed, "", 0.0, true});
  // A touch probe; also a touch plate on the table that the probe meets at Z -140.
  m.switches.push_back({"probe", SwitchKind::Probe, 10, Contact::NormallyOpen, "z", -140.0, false});
  SpindleDescription s;
  s.vfd.rpmPerVolt = 2400.0;  // 24000 rpm at 10 V
  s.vfd.maxRpm = 24000.0;
  s.vfd.accelerationRpmPerSecond = 8000.0;
  // 256 lines: 410 k counts/s at 24000 rpm, within what the muxed counters
  // resolve with the input filter on (LinuxCNC's default, about 520 k counts/s
  // at the power-up mux rate; manual: MAXIMUM ENCODER COUNT RATE).
  s.encoder = EncoderParameters{256, true, false};
  m.spindle = s;
  m.outputs = {{"coolant", 0, 480}, {"lube", 1, 480}, {"z-brake-release", 2, 240}};
  return m;
}

MachineDescription lathe() {
  MachineDescription m;
  m.name = "lathe";
  m.axes.push_back(linear("x", {servo(0)}, 4.0, 40.0, -5.0, 100.0, 50.0));
  m.axes.push_back(linear("z", {servo(1)}, 5.0, 120.0, -500.0, 0.0, -250.0));
  addAxisSwitches(m, m.axes[0], 0, 1, 2, 95.0, true);
  addAxisSwitches(m, m.axes[1], 3, 4, 5, -5.0, true);
  m.switches.push_back({"estop", SwitchKind::Estop, 9, Contact::NormallyClosed, "", 0.0, true});
  m.switches.push_back({"probe", SwitchKind::Probe, 10, Contact::NormallyOpen, "", 0.0, true});
  SpindleDescription s;
  s.vfd.rpmPerVolt = 300.0;  // 3000 rpm at 10 V
  s.vfd.maxRpm = 3000.0;
  s.vfd.accelerationRpmPerSecond = 1000.0;
  s.encoder = EncoderParameters{1024, true, false};  // index for threading
  m.spindle = s;
  m.outputs = {{"coolant", 0, 480}};
  return m;
}

MachineDescription gantry() {
  MachineDescription m;
  m.name = "gantry";
  m.axes.push_back(linear("x", {servo(0)}, 10.0, 80.0, 0.0, 1200.0, 600.0));
  // Y: one beam, a motor and encoder on each side (AOUT1/ENC1, AOUT2/ENC2),
  // rigidly coupled through the beam.
  m.axes.push_back(linear("y", {servo(1), servo(2)}, 10.0, 300.0, 0.0, 2400.0, 1200.0));
  AxisDescription z = linear("z", {servo(3)}, 5.0, 40.0, -200.0, 0.0, -100.0);
  z.vertical = true;
  z.brakeOutput = 2;
  z.brakeTorque = 4.0;
  m.axes.push_back(z);
  addAxisSwitches(m, m.axes[0], 0, 1, 2, 1195.0, true);
  addAxisSwitches(m, m.axes[1], 3, 4, 5, 2395.0, true);
  addAxisSwitches(m, m.axes[2], 6, 7, 8, -5.0, true);
  m.switches.push_back({"estop", SwitchKind::Estop, 9, Contact::NormallyClosed, "", 0.0, true});
  m.switches.push_back({"probe", SwitchKind::Probe, 10, Contact::NormallyOpen, "z", -190.0, false});
  // The second Y side's home switch, for squaring the beam.
  m.switches.push_back({"y2-home", SwitchKind::Home, 11, Contact::NormallyOpen, "y", 2395.0, true});
  SpindleDescription s;
  s.vfd.rpmPerVolt = 2400.0;
  s.vfd.maxRpm = 24000.0;
  s.vfd.accelerationRpmPerSecond = 6000.0;
  s.encoder = EncoderParameters{256, true, false};
  m.spindle = s;
  m.outputs = {{"coolant", 0, 480}, {"lube", 1, 480}, {"z-brake-release", 2, 240}};
  return m;
}

}  // namespace lbpkit::model::machine
