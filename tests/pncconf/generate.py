# SPDX-License-Identifier: MIT
"""PNCconf's own writer makes lbpkit's corpus of 7I77 configurations.

PNCconf, the wizard most 7I77 users make their LinuxCNC configuration
with, ships in Debian's linuxcnc-uspace (/usr/bin/pncconf and the Python
package pncconf). This script drives it without a person: for each entry
of MATRIX it constructs PNCconf's App, sets the answers a user gives on
its pages (the card and its firmware, the 7I77's pins, axes, units,
homing, spindle, E-stop) in its data, and saves them as a `.pncconf`
file; then a fresh App loads that file (`Data.load`) and runs the app's
own build step (`App.buid_config`: the INI, the HAL files, custom.hal,
the tool table), exactly as a user's "Modify Existing Configuration" and
"Apply" do. Each configuration lands in OUTDIR/NAME/ with the `.pncconf`
it came from.

The cards: PNCconf's internal firmware data offers a 7I77 with the
5I25/6I25 (`7i77x2 With One 7i77`) and the 7I92 (`7i77x2 with on 7i77`);
the 7I96S and the 7I80HD it offers only through its Discovery Option,
which reads what mesaflash says of the board. discovery/7i96s.txt and
discovery/7i80hd-25.txt are that text, mesaflash's answer to
`lbpkit sim --card 7I96S` (resp. `7I80HD-25`):

    mesaflash --device 7i96s --addr 127.0.0.7; mesaflash ... --sserial; mesaflash ... --readhmid

Run it with Debian's Python (it has `gi`) under an X server of its own:

    xvfb-run -a /usr/bin/python3 tests/pncconf/generate.py tests/pncconf/configs

PNCconf writes into ~/linuxcnc and ~/.pncconf-preferences; this script
gives it a HOME of its own, /tmp/lbpkit-pncconf-home, and removes it, so
nothing of the user's is touched. The matrix and what each configuration covers are in
tests/pncconf/README.md.
"""

import importlib.machinery
import importlib.util
import os
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
PNCCONF = "/usr/bin/pncconf"
HOME = "/tmp/lbpkit-pncconf-home"

# The 7I77 on PNCconf's smart-serial tabs (its daughter data "7i77-m0"):
# field inputs 0..15 are combo pins 0..15 and 16..31 are 24..39; outputs
# 0..7 are 16..23 and 8..15 are 40..47; the analog outputs are channel 1's
# combo pins 48 (enable), 49 + 2k (analogout k) and 50 + 2k.
def input_pin(n):
    return n if n < 16 else n + 8


def output_pin(n):
    return 16 + n if n < 8 else 32 + n


def analogout_pin(k):
    return 49 + 2 * k


# Field inputs by function (the 7I77's TB7/TB8 inputs).
INPUTS = {
    "x": (0, 1, 2),   # home, min, max
    "y": (3, 4, 5),
    "z": (6, 7, 8),
    "a": (9, None, None),
    "y2": (10, 11, 12),
    "estop-ext": 13,
}
OUTPUTS = {"estop-out": 0, "machine-is-enabled": 1, "coolant-flood": 2}

# Axes (PNCconf's `axes`: 0 XYZ, 1 XYZA) and the tandem Y2 joint; each
# joint's drive on the analog output and the muxed encoder of its number.
DRIVES = {"x": 0, "y": 1, "y2": 2, "z": 3, "a": 4}
SPINDLE_ANALOGOUT = 5
SPINDLE_ENCODER = 5

MATRIX = [
    # name, card, axes, tandem Y, units, homing, shared home/limit, spindle, E-stop, board IP
    dict(name="5i25-xyz-mm-switch", card="5i25", axes="xyz", tandem=False, units="mm", homing="switch",
         shared=False, spindle="encoder", estop="input", ip=None),
    dict(name="5i25-xyza-inch-index", card="5i25", axes="xyza", tandem=False, units="inch", homing="index",
         shared=False, spindle="open-loop", estop="input-inverted", ip=None),
    dict(name="5i25-xyyz-mm-shared", card="5i25", axes="xyz", tandem=True, units="mm", homing="switch",
         shared=True, spindle="none", estop="input-and-output", ip=None),
    dict(name="7i92-xyz-inch-in-place", card="7i92", axes="xyz", tandem=False, units="inch", homing="in-place",
         shared=False, spindle="encoder", estop="none", ip="10.10.10.31"),
    dict(name="7i92-xyyz-mm-index-shared", card="7i92", axes="xyz", tandem=True, units="mm", homing="index",
         shared=True, spindle="open-loop", estop="input", ip="10.10.10.32"),
    dict(name="7i92-xyyza-mm-switch", card="7i92", axes="xyza", tandem=True, units="mm", homing="switch",
         shared=False, spindle="encoder", estop="input-and-output", ip="10.10.10.33"),
    dict(name="7i96s-xyz-mm-switch", card="7i96s", axes="xyz", tandem=False, units="mm", homing="switch",
         shared=False, spindle="encoder", estop="input", ip="10.10.10.34"),
    dict(name="7i96s-xyza-inch-shared", card="7i96s", axes="xyza", tandem=False, units="inch", homing="index",
         shared=True, spindle="open-loop", estop="none", ip="10.10.10.35"),
    dict(name="7i80hd-xyz-inch-index", card="7i80hd", axes="xyz", tandem=False, units="inch", homing="index",
         shared=False, spindle="encoder", estop="input-inverted", ip="10.10.10.36"),
    dict(name="7i80hd-xyyza-mm-in-place", card="7i80hd", axes="xyza", tandem=True, units="mm", homing="in-place",
         shared=False, spindle="open-loop", estop="input-and-output", ip="10.10.10.37"),
]

# Per unit: travel (min, max), the home switch's position and where
# LinuxCNC calls home, counts per unit (a 2000-line encoder on a 5 mm or
# 0.2 in screw), velocity at 10 V, max velocity and acceleration. A is a
# rotary table with soft limits two turns each way: the display's G53 moves
# turn it across them in seconds.
AXES = {
    "mm": dict(x=(0, 400), y=(0, 300), z=(-100, 0), a=(-360, 360),
               counts=1600, at10v=250, maxvel=50, maxacc=500, search=10, latch=1, back=5),
    "inch": dict(x=(0, 16), y=(0, 12), z=(-4, 0), a=(-360, 360),
                 counts=40640, at10v=10, maxvel=2, maxacc=20, search=0.4, latch=0.04, back=0.2),
}


def load_pncconf():
    sys.argv = [PNCCONF]
    loader = importlib.machinery.SourceFileLoader("pncconf_app", PNCCONF)
    spec = importlib.util.spec_from_loader("pncconf_app", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    # PNCconf's hook opens a dialog on an exception; a script reports it.
    sys.excepthook = sys.__excepthook__
    return module


def new_app(module):
    app = module.App("")
    # Dialogs would wait for a person: answer them, print what they said.
    def answer(message, is_ok_type):
        print("PNCconf says: %s" % message, file=sys.stderr)
        return True
    app.warning_dialog = answer
    return app


def choose_board(app, title):
    """The board chosen on PNCconf's Mesa page (it looks up the board's
    metadata by that title). A discovered 7I80HD's IDROM says "MESA7I80",
    which PNCconf has no metadata for: it asks the user (its board
    metadata dialog), who answers what the card is, an Ethernet card
    with three 24-pin connectors."""
    name = title.lower()
    app.origname[0] = name
    if name == "discovered:7i80":
        app._p.MESA_BOARD_META[name] = {"DRIVER": "hm2_eth", "PINS_PER_CONNECTOR": 24, "TOTAL_CONNECTORS": 3}


def firmware(app, card):
    P = app._p
    internal = {"5i25": ("5i25-Internal Data", "7i77x2 With One 7i77"),
                "7i92": ("7i92-Internal Data", "7i77x2 with on 7i77")}
    if card in internal:
        title, name = internal[card]
        for f in P.MESA_INTERNAL_FIRMWAREDATA:
            if f[P._BOARDTITLE] == title and f[P._FIRMWARE] == name:
                return f
        raise SystemExit("PNCconf has no %s firmware %s" % (title, name))
    device = {"7i96s": "7i96s", "7i80hd": "7i80hd-25"}[card]
    with open(os.path.join(HERE, "discovery", device + ".txt")) as f:
        info = f.read() + "\n ETH"
    driver, boardname, firmname, path = app.parse_discovery(info, boardnum=0)
    if driver is None:
        raise SystemExit("PNCconf could not read discovery/%s.txt" % device)
    return app.parse_xml(driver, "Discovered:%s" % boardname, firmname, path, 0)


def joints(entry):
    letters = ["x", "y"] + (["y2"] if entry["tandem"] else []) + ["z"] + (["a"] if entry["axes"] == "xyza" else [])
    return letters


def configure(app, entry):
    """Sets in PNCconf's data what a user answers on its pages."""
    d, P = app.d, app._p
    metric = entry["units"] == "mm"
    u = AXES[entry["units"]]
    d.machinename = entry["name"].replace("-", "_")
    d.units = P._METRIC if metric else P._IMPERIAL
    d.set_axis_unit_defaults(not metric)
    d.axes = 1 if entry["axes"] == "xyza" else 0
    d.available_axes = ["x", "y", "z"] + (["a"] if entry["axes"] == "xyza" else []) + ["s"]
    d.number_pports = 0
    d.frontend = P._AXIS
    d.include_spindle = entry["spindle"] != "none"

    # The card, its firmware and how many of each module it loads.
    f = firmware(app, entry["card"])
    d.number_mesa = 1
    d.mesa0_currentfirmwaredata = f
    d.mesa0_boardtitle = f[P._BOARDTITLE]
    d.mesa0_firmware = f[P._FIRMWARE]
    d.mesa0_card_addrs = entry["ip"] or "10.10.10.10"
    choose_board(app, d.mesa0_boardtitle)
    # As many of each module as the firmware has (PNCconf's default).
    d.mesa0_numof_encodergens = f[P._MAXENC]
    d.mesa0_numof_pwmgens = f[P._MAXPWM]
    d.mesa0_numof_tppwmgens = f[P._MAXTPPWM]
    d.mesa0_numof_stepgens = f[P._MAXSTEP]
    d.mesa0_numof_resolvers = f[P._MAXRES]
    d.mesa0_numof_sserialports = 1
    d.mesa0_numof_sserialchannels = f[P._MAXSSERIALCHANNELS]

    encoder_of = {n: letter for letter, n in DRIVES.items() if letter in joints(entry)}
    if entry["spindle"] == "encoder":
        encoder_of[SPINDLE_ENCODER] = "s"
    # The card's connectors: muxed encoders where the firmware has them,
    # the 7I77's smart-serial channels set to its mode 0, the rest unused.
    for concount, connector in enumerate(f[P._NUMOFCNCTRS]):
        for pin in range(24):
            ptype, compnum = f[P._STARTOFDATA + pin + concount * 24]
            key = "mesa0c%dpin%d" % (connector, pin)
            d[key + "inv"] = False
            if ptype in (P.MXE0, P.MXE1):
                n = compnum * 2 + (1 if ptype == P.MXE1 else 0)
                d[key + "type"] = ptype
                d[key] = encoder_of[n] + "-encoder-a" if n in encoder_of else P.UNUSED_ENCODER
            elif ptype in (P.MXEI, P.MXEM, P.MXES):
                d[key + "type"] = ptype
                d[key] = P.UNUSED_ENCODER
            elif ptype in (P.SS7I77M0, P.SS7I77M1, P.TXDATA0, P.TXDATA1):
                d[key + "type"] = ptype
                d[key] = P.I7I77_M0_T
            elif ptype in (P.TXDATA2, P.TXDATA3, P.RXDATA0, P.RXDATA1, P.RXDATA2, P.RXDATA3,
                           P.TXEN0, P.TXEN1, P.TXEN2, P.TXEN3):
                d[key + "type"] = ptype
                d[key] = P.UNUSED_UNUSED
            elif ptype in (P.SSR0, P.OUTM0, P.GPIOO):
                d[key + "type"] = ptype
                d[key] = P.UNUSED_OUTPUT
            elif ptype in (P.STEPA, P.STEPB):
                d[key + "type"] = ptype
                d[key] = P.UNUSED_STEPGEN
            elif ptype in (P.PWMP, P.PWMD, P.PWME):
                d[key + "type"] = ptype
                d[key] = P.UNUSED_PWM
            elif ptype == P.NUSED:
                d[key + "type"] = P.NUSED
                d[key] = P.UNUSED_UNUSED
            else:  # GPIO and InM inputs
                d[key + "type"] = P.INM0 if ptype == P.INM0 else P.GPIOI
                d[key] = P.UNUSED_INPUT

    # The 7I77 on smart-serial channels 0 (field I/O) and 1 (analog), both
    # in PNCconf's mode 0.
    daughter = next(x for x in P.MESA_DAUGHTERDATA if x[P._SUBFIRMNAME] == "7i77-m0")
    for channel in (0, 1):
        d["mesa0sserial0_%dsubboard" % channel] = "7i77-m0"
        for pin in range(P._SSCOMBOLEN):
            ptype, compnum = daughter[P._SUBSTARTOFDATA + pin]
            key = "mesa0sserial0_%dpin%d" % (channel, pin)
            d[key + "type"] = ptype
            d[key + "inv"] = False
            d[key] = {P.GPIOI: P.UNUSED_INPUT, P.GPIOO: P.UNUSED_OUTPUT}.get(ptype, P.UNUSED_PWM)
            if ptype == P.NUSED:
                d[key] = P.UNUSED_UNUSED

    def field_input(n, signal, inverted=False):
        key = "mesa0sserial0_0pin%d" % input_pin(n)
        d[key] = signal
        d[key + "inv"] = inverted

    def field_output(n, signal):
        d["mesa0sserial0_0pin%d" % output_pin(n)] = signal

    def analog(k, letter):
        d["mesa0sserial0_1pin%d" % analogout_pin(k)] = letter + "-pwm-pulse"

    # Joints: drive, encoder, switches, scales, homing.
    for letter in joints(entry):
        analog(DRIVES[letter], letter)
        home, lo, hi = INPUTS[letter]
        base = letter[0]
        if letter == "a":
            if entry["homing"] != "in-place":
                field_input(home, "home-a")
        else:
            if entry["homing"] == "in-place":
                field_input(lo, "min-" + letter)
                field_input(hi, "max-" + letter)
            elif entry["shared"]:
                # The home switch is the limit switch at the end homing searches towards.
                field_input(lo, "min-" + letter)
                field_input(hi, "max-home-" + letter)
            else:
                field_input(home, "home-" + letter)
                field_input(lo, "min-" + letter)
                field_input(hi, "max-" + letter)
        if letter == "y2":
            continue  # the tandem joint takes Y's settings
        lo_travel, hi_travel = u[base]
        if base == "a":
            d["aencoderscale"] = 100.0  # counts per degree
            d["aoutputscale"] = 1000.0  # degrees per second at 10 V
            d["amaxvel"] = 90.0
            d["amaxacc"] = 900.0
            d["ahomepos"] = 0.0
            d["ahomesw"] = 0.0
            d["ahomesearchvel"] = 20.0
            d["ahomelatchvel"] = 2.0
            d["aminlim"], d["amaxlim"] = lo_travel, hi_travel
            d["aminferror"], d["amaxferror"] = 0.5, 5.0
        else:
            d[base + "encoderscale"] = float(u["counts"])
            d[base + "outputscale"] = float(u["at10v"])
            d[base + "maxvel"] = float(u["maxvel"])
            d[base + "maxacc"] = float(u["maxacc"])
            d[base + "minlim"], d[base + "maxlim"] = float(lo_travel), float(hi_travel)
            # Home switches at the top of travel, searched upwards; home
            # a little below them.
            d[base + "homesw"] = float(hi_travel)
            d[base + "hometandemsw"] = float(hi_travel)
            d[base + "homepos"] = float(hi_travel - u["back"])
            d[base + "homesearchvel"] = float(u["search"])
            d[base + "homelatchvel"] = float(u["latch"])
            d[base + "homefinalvel"] = 0.0
            d[base + "minferror"] = 1.0 if metric else 0.04
            d[base + "maxferror"] = 10.0 if metric else 0.4
        d[base + "searchdir"] = 1
        d[base + "latchdir"] = 0
        d[base + "usehomeindex"] = 1 if entry["homing"] == "index" else 0
        # The servo loop as a user tunes it on PNCconf's axis page: P in
        # units per second of velocity command per unit of error. The 7I77's
        # DAC moves in steps of OUTPUT_SCALE / 4096 (about 100 counts of
        # error at P = 1 for every axis here), so P must be over ~100 for
        # the loop to hold an axis within a count; 200 holds it within half
        # of one, and at a 1 ms servo period (loop gain 0.2 a period) is
        # well inside stability. FF1 = 1: OUTPUT_SCALE is the velocity at
        # 10 V.
        d[base + "P"] = 200.0
        # The analog output's limits in the PID's units, as the axis page
        # sets them: PNCconf's default of +-10 suits an OUTPUT_SCALE of 10
        # only. Left at 10 with a scale of 250 mm/s, the drive is held to
        # 10 mm/s and every faster move ends in a following error, on a
        # real 7I77 as on lbpkit's.
        scale = d[base + "outputscale"]
        d[base + "outputminlimit"], d[base + "outputmaxlimit"] = -scale, scale
        d[base + "FF1"] = 1.0
        d[base + "invertmotor"] = 0
        d[base + "invertencoder"] = 0

    # The spindle on analog output 5 (its own enable, spinena), with or
    # without an encoder.
    if entry["spindle"] != "none":
        analog(SPINDLE_ANALOGOUT, "s")
        d.soutputscale = 3000
        d.smaxoutput = 3000
        d.soutputmaxvoltage = 10
        d.susenegativevoltage = True
        d.sencoderscale = 4000.0 if entry["spindle"] == "encoder" else 0
        d.suseatspeed = entry["spindle"] == "encoder"
    field_output(OUTPUTS["coolant-flood"], "coolant-flood")

    # The E-stop chain.
    estop = entry["estop"]
    if estop in ("input", "input-and-output"):
        field_input(INPUTS["estop-ext"], "estop-ext")
    elif estop == "input-inverted":
        field_input(INPUTS["estop-ext"], "estop-ext", inverted=True)
    if estop == "input-and-output":
        field_output(OUTPUTS["estop-out"], "estop-out")
        field_output(OUTPUTS["machine-is-enabled"], "machine-is-enabled")


def generate(module, entry, home, outdir):
    os.environ["HOME"] = home
    # The user's answers, saved as PNCconf saves them.
    app = new_app(module)
    configure(app, entry)
    app.save()
    name = app.d.machinename
    configs = os.path.join(home, "linuxcnc", "configs")
    saved = os.path.join(configs, name + ".pncconf")
    folder = os.path.join(outdir, entry["name"])
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    shutil.copy(saved, os.path.join(folder, name + ".pncconf"))
    shutil.rmtree(os.path.join(configs, name))
    # A fresh PNCconf loads that file and builds the configuration.
    app = new_app(module)
    app.d.load(os.path.join(folder, name + ".pncconf"), app, force=True)
    choose_board(app, app.d.mesa0_boardtitle)
    app.buid_config()
    built = os.path.join(configs, name)
    for f in sorted(os.listdir(built)):
        src = os.path.join(built, f)
        if os.path.isfile(src):
            shutil.copy(src, os.path.join(folder, f))
    return folder


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    outdir = os.path.abspath(sys.argv[1])
    os.makedirs(outdir, exist_ok=True)
    # A HOME of a fixed name: PNCconf writes it into the INI (PROGRAM_PREFIX),
    # so the corpus comes out the same each time.
    home = HOME
    if os.path.exists(home):
        raise SystemExit("%s exists: another run of this script, or one that did not finish (remove it)" % home)
    os.makedirs(home)
    module = load_pncconf_in(home)
    try:
        for entry in MATRIX:
            folder = generate(module, entry, home, outdir)
            print("%s: %s" % (entry["name"], " ".join(sorted(os.listdir(folder)))))
    finally:
        shutil.rmtree(home, ignore_errors=True)


def load_pncconf_in(home):
    # PNCconf makes ~/linuxcnc/configs when it is imported.
    os.environ["HOME"] = home
    return load_pncconf()


if __name__ == "__main__":
    main()
