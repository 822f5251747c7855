#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# lbpkit decode, lbpkit sim --trace, lbpkit remote --pty
# --trace and the Wireshark dissector (contrib/wireshark/lbp16.lua).
#
#   decode_test.sh sim       LBPKIT SOURCE_DIR   the sim's capture of `lbpkit discover`, decoded
#   decode_test.sh tshark    LBPKIT SOURCE_DIR   the same capture through tshark and lbp16.lua (77: no tshark)
#   decode_test.sh remote    LBPKIT SOURCE_DIR   a serial-line capture of `lbpkit wpd --serial`, decoded
#   decode_test.sh malformed LBPKIT SOURCE_DIR   damaged files and datagrams: clear errors, never a crash
#
# Each starts what it needs (a sim on a loopback address of its own, or a
# remote on a pty) and kills it on every way out.
set -euo pipefail

mode=$1
lbpkit=$2
src=$3
work=$(mktemp -d /tmp/lbpkit-decode-test.XXXXXX)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

fail() {
  echo "FAIL: $*" >&2
  exit 1
}
# expect FILE TEXT: FILE has a line containing TEXT (fixed string).
expect() {
  grep -qF -- "$2" "$1" || { echo "--- $1 (first 40 lines)" >&2; head -40 "$1" >&2; fail "no line with \"$2\" in $1"; }
}

# A sim with --trace on ADDRESS, `lbpkit discover` against it, the sim
# stopped: $work/sim.pcap.
capture_discover() {
  local address=$1
  "$lbpkit" sim --bind "$address" --no-api --no-realtime --state "$work/sim.eeprom" --trace "$work/sim.pcap" \
    >"$work/sim.log" 2>&1 &
  local sim=$!
  pids+=("$sim")
  for _ in $(seq 100); do
    grep -q 'packet trace:' "$work/sim.log" && break
    kill -0 "$sim" 2>/dev/null || { cat "$work/sim.log" >&2; fail "the sim did not start"; }
    sleep 0.1
  done
  "$lbpkit" discover --addr "$address" >"$work/discover.log" 2>&1 || { cat "$work/discover.log" >&2; fail "discover failed"; }
  kill -TERM "$sim"
  wait "$sim" || fail "the sim did not stop cleanly"
  expect "$work/sim.log" "the datagrams in and out are in $work/sim.pcap"
  # A capture that lost packets (the ring overflowed) lacks discover's last reads.
  if grep -q 'writer fell' "$work/sim.log"; then fail "the capture is incomplete: $(grep 'writer fell' "$work/sim.log")"; fi
  [[ -s $work/sim.pcap ]] || fail "no capture written"
}

case $mode in
  sim)
    capture_discover 127.0.18.1
    "$lbpkit" decode "$work/sim.pcap" >"$work/decoded.txt" 2>"$work/decoded.err" || fail "decode failed: $(cat "$work/decoded.err")"
    out=$work/decoded.txt
    # The IDROM came from the capture, read as the host read it.
    expect "$out" "card 127.0.18.1:27181: register names from the IDROM read in the capture (MESA7I92, "
    expect "$out" "< read  hm2 0x0100  idrom.cookie = 0x55AACAFE"
    expect "$out" "< read  hm2 0x010C  idrom.offset = 0x00000400"
    expect "$out" "< read  hm2 0x0400 x16  idrom.type = 0x00000003 .. idrom.register_stride1 = 0x00000100"
    # SSLBP as lbpkit discover drives it: STOP ALL, setup START, setup-mode
    # reads by DOIT on channel 0, the remote's answer in interface 0.
    expect "$out" "> write hm2 0x5A00  sserial.0.command = 0x00000800  SSLBP STOP ALL"
    expect "$out" "> write hm2 0x5A00  sserial.0.command = 0x00000F3F  SSLBP setup START channels 0,1,2,3,4,5"
    expect "$out" "SSLBP local read 0x004 GP_INPUTS (channel block start)"
    expect "$out" "> write hm2 0x5C00  sserial.0.ch0.cs = 0x47000658  (setup-mode access: read 8 bytes, 2-byte address 0x0658)"
    expect "$out" "sserial.0.command = 0x00001001  SSLBP DOIT channels 0; ch0: remote read 8 bytes at 0x0658 (LBP 0x47)"
    # The unit number after START (whether the decoder has seen a DOIT with
    # a remote read on the channel by then depends on how many times the
    # host polled: timing), and the answers of the DOITs' remote reads.
    expect "$out" "< read  hm2 0x5D00  sserial.0.ch0.interface0 = 0x12000AEE"
    expect "$out" "< read  hm2 0x5D00  sserial.0.ch0.interface0 = 0x0047504D  (the remote's answer)"
    # A channel with nobody on it: CS says why.
    expect "$out" "sserial.0.ch5.cs = 0x0001E188  (TimeoutError TooManyErrors RemoteFault CommunicationError NoRemoteID CommunicationNotReady)"
    # Times: every line starts with seconds since the first packet.
    head -2 "$out" | tail -1 | grep -qE '^ +0\.000000  ' || fail "the first packet is not at 0.000000"
    if grep -q '^ *[0-9.]*  !' "$out"; then fail "a packet of the sim's own capture was judged malformed"; fi
    # Names from the default card's IDROM agree (it is the same card).
    "$lbpkit" decode --idrom default "$work/sim.pcap" >"$work/default.txt"
    expect "$work/default.txt" "register names from the default virtual 7I92 + 7I77's IDROM (as asked)"
    expect "$work/default.txt" "sserial.0.command = 0x00000800  SSLBP STOP ALL"
    ;;

  tshark)
    command -v tshark >/dev/null || { echo "SKIP: tshark is not installed (Debian: tshark)"; exit 77; }
    capture_discover 127.0.18.2
    export HOME=$work  # tshark's profile, not the user's
    lua=$src/contrib/wireshark/lbp16.lua
    ts() { tshark -X "lua_script:$lua" -r "$work/sim.pcap" "$@" 2>"$work/tshark.err"; }
    # Without the dissector, tshark still sees UDP to 27181 (the capture's
    # IPv4/UDP headers are right).
    tshark -r "$work/sim.pcap" -T fields -e udp.dstport -c 1 2>/dev/null >"$work/udp.txt"
    [[ $(cat "$work/udp.txt") == 27181 ]] || fail "tshark does not see UDP port 27181: $(cat "$work/udp.txt")"
    # Frame 3 is readCardInfo's first request: cookie, name and IDROM offset.
    ts -Y 'frame.number == 3' -T fields -E separator=' ' -e lbp16.space -e lbp16.address -e lbp16.count >"$work/f3.txt"
    expect "$work/f3.txt" "0,0,0,4,4 0x0100,0x0104,0x010c,0x0010,0x0010 1,2,1,1,1"
    # Its reply, split by the request: the cookie and "HOSTMOT2".
    ts -Y 'lbp16.reply_to == 3' -T fields -e lbp16.value >"$work/r3.txt"
    expect "$work/r3.txt" "0x55aacafe,0x54534f48,0x32544f4d,0x00000400"
    # The SSLBP commands lbpkit discover writes, in order.
    ts -Y lbp16.sslbp -T fields -e lbp16.sslbp >"$work/sslbp.txt"
    [[ $(head -1 "$work/sslbp.txt") == "STOP ALL" ]] || fail "first SSLBP command: $(head -1 "$work/sslbp.txt")"
    expect "$work/sslbp.txt" "setup START channels 0x3F"
    expect "$work/sslbp.txt" "DOIT channels 0x01"
    expect "$work/sslbp.txt" "local read 0x004"
    # -V: the tree, with no Lua error anywhere.
    ts -V -c 20 >"$work/tree.txt"
    expect "$work/tree.txt" "Memory space: HostMot2 (0)"
    expect "$work/tree.txt" "Transfer size: 32-bit (2)"
    if grep -qi 'lua error\|malformed' "$work/tree.txt" "$work/tshark.err"; then
      cat "$work/tshark.err" >&2
      fail "tshark reports a Lua error or a malformed packet"
    fi
    ;;

  remote)
    "$lbpkit" remote --pty --setup --state "$work/remote.eeprom" --trace "$work/remote.pcap" >"$work/remote.log" 2>&1 &
    remote=$!
    pids+=("$remote")
    pty=
    for _ in $(seq 100); do
      pty=$(grep -o '/dev/pts/[0-9]*' "$work/remote.log" | head -1 || true)
      [[ -n $pty ]] && break
      sleep 0.1
    done
    [[ -n $pty ]] || { cat "$work/remote.log" >&2; fail "the remote did not start"; }
    "$lbpkit" wpd NVWATCHDOGTIME 100 --serial "$pty" >"$work/wpd.log" 2>&1 || { cat "$work/wpd.log" >&2; fail "wpd failed"; }
    kill -TERM "$remote"
    wait "$remote" || fail "the remote did not stop cleanly"
    expect "$work/remote.log" "the LBP trace is in $work/remote.pcap"
    "$lbpkit" decode "$work/remote.pcap" >"$work/decoded.txt"
    out=$work/decoded.txt
    expect "$out" "LBP on a serial line"
    expect "$out" "> LBP 0xBB RPC 0xBB Discovery  CRC ok  < 05 02 5C 06 66 06 (RXSize 5, TXSize 2, PTOCP 0x065C, GTOCP 0x0666)  CRC ok"
    expect "$out" "> LBP 0x47 read 8 bytes, 2-byte address at 0x0658  CRC ok  < 4D 50 47 00"
    expect "$out" "> LBP 0xEC local write NVAccess = 0x01  CRC ok  < (no data)  CRC ok"
    expect "$out" "> LBP 0x65 write 2 bytes, 2-byte address at 0x0308 = 64 00  CRC ok"
    expect "$out" "> LBP 0x45 read 2 bytes, 2-byte address at 0x0308  CRC ok  < 64 00 (0x0064)  CRC ok"
    expect "$out" "> LBP 0xEC local write NVAccess = 0x00"
    if grep -q 'CRC BAD\|no answer\|incomplete' "$out"; then fail "a clean exchange decoded as damaged"; fi
    # The tshark sees the file as USER0 records.
    if command -v tshark >/dev/null; then
      HOME=$work tshark -r "$work/remote.pcap" -T fields -e frame.protocols -c 1 2>/dev/null | grep -q 'user' ||
        fail "tshark does not read the LBP trace as USER0 records"
    fi
    ;;

  malformed)
    # decode_case NAME EXPECTED_STATUS TEXT: decode $work/NAME, its status
    # and a line of its output (stdout and stderr) with TEXT. A crash is a
    # status above 128.
    decode_case() {
      local status=0
      "$lbpkit" decode "$work/$1" >"$work/$1.out" 2>&1 || status=$?
      ((status < 128)) || fail "$1: lbpkit decode crashed (status $status)"
      [[ $status == "$2" ]] || { cat "$work/$1.out" >&2; fail "$1: status $status, expected $2"; }
      expect "$work/$1.out" "$3"
    }
    python3 - "$work" <<'EOF'
import struct, sys
work = sys.argv[1]

def pcap(name, records, link=101, magic=0xA1B2C3D4):
    with open(f"{work}/{name}", "wb") as f:
        f.write(struct.pack("<IHHiIII", magic, 2, 4, 0, 0, 65535, link))
        for ts, data, length in records:
            f.write(struct.pack("<IIII", ts, 0, len(data), length if length else len(data)))
            f.write(data)

def udp(payload, src=("127.0.0.1", 40000), dst=("127.0.18.9", 27181), claimed=None):
    ip = lambda a: bytes(int(x) for x in a.split("."))
    ulen = 8 + (claimed if claimed is not None else len(payload))
    total = 20 + ulen
    h = struct.pack("!BBHHHBBH4s4s", 0x45, 0, total, 0, 0x4000, 64, 17, 0, ip(src[0]), ip(dst[0]))
    return h + struct.pack("!HHHH", src[1], dst[1], ulen, 0) + payload

open(f"{work}/text.pcap", "w").write("this is not a capture\n")
open(f"{work}/empty.pcap", "wb").close()
# A good request, then a record cut in the middle of its data.
good = udp(struct.pack("<HH", 0x4201, 0x0100))
pcap("cut.pcap", [(1, good, 0)])
with open(f"{work}/cut.pcap", "ab") as f:
    f.write(struct.pack("<IIII", 2, 0, 60, 60) + good[:10])
# LBP16 datagrams that are wrong inside.
pcap("lbp16.pcap", [
    (1, udp(b"\x01"), 0),                                          # 1 byte: no command word
    (2, udp(struct.pack("<H", 0xC201) + b"\x00"), 0),              # write wants an address: 1 byte
    (3, udp(struct.pack("<HH", 0xC282, 0x5A00) + b"\x00\x08\x00\x00"), 0),  # 4 data bytes of 8
    (4, udp(b"", claimed=None), 0),                                # an empty datagram
    (5, udp(struct.pack("<HH", 0x4201, 0x0100))[:30], 48),         # snap length cut it
    (6, udp(b"\x00\x00", claimed=40), 0),                          # UDP length beyond the packet
])
# A reply with no request.
pcap("reply.pcap", [(1, udp(b"\xfe\xca\xaa\x55", src=("127.0.18.9", 27181), dst=("127.0.0.1", 40000)), 0)])
# A link type lbpkit does not read (802.11).
pcap("wifi.pcap", [(1, b"\x00" * 24, 0)], link=105)
# LBP stream records: a bad direction byte, an empty record, a bad CRC, a
# command cut short at the end, a non-command byte.
pcap("stream.pcap", [
    (1, b"\x07\xbb\x00", 0),
    (2, b"", 0),
    (3, b"\x00\xdf\x00", 0),   # 0xDF with CRC 0x00: wrong
    (4, b"\x01\x5a\x00", 0),
    (5, b"\x00\x12\x34", 0),   # 0x12 is not a command
    (6, b"\x00\x47\x58", 0),   # read 8 bytes at an address: the address and CRC never come
], link=147)
EOF
    decode_case text.pcap 1 "decode $work/text.pcap: unknown file format"
    decode_case empty.pcap 1 "decode $work/empty.pcap: truncated dump file"
    decode_case cut.pcap 1 "packet 2: truncated dump file"
    decode_case wifi.pcap 1 "link type 105 (IEEE802_11) is not one lbpkit reads"
    decode_case lbp16.pcap 0 "> truncated datagram: 1 byte (0x01) at offset 0 where a 2-byte command word should be"
    expect "$work/lbp16.pcap.out" "> truncated datagram: command 0xC201 at offset 0 wants a 2-byte address, 1 byte left"
    expect "$work/lbp16.pcap.out" "> truncated datagram: write 0xC282 at offset 0 carries 4 data bytes of 8"
    expect "$work/lbp16.pcap.out" "> empty datagram: no LBP16 command"
    expect "$work/lbp16.pcap.out" "! packet 5: truncated datagram: 2 of its 4 LBP16 bytes captured (the capture's snap length cut it)"
    expect "$work/lbp16.pcap.out" "! packet 6: truncated datagram: 2 of its 40 LBP16 bytes captured (the file is damaged)"
    expect "$work/lbp16.pcap.out" "lbpkit decode: 6 malformed packets or commands"
    decode_case reply.pcap 0 "< reply of 4 bytes with no read waiting for one"
    decode_case stream.pcap 0 "! packet 1: LBP stream record with direction byte 0x07 (0 to the remote, 1 from it)"
    expect "$work/stream.pcap.out" "! packet 2: an empty LBP stream record (no direction byte)"
    expect "$work/stream.pcap.out" "> LBP 0xDF local read Cookie  CRC BAD (0x00, should be 0x"
    expect "$work/stream.pcap.out" "< 5A (the cookie)"
    expect "$work/stream.pcap.out" "> 0x12 is not an LBP command (bits 7..6 are 00); 2 bytes skipped: 12 34"
    expect "$work/stream.pcap.out" "> incomplete command at the end of the capture: 47 58"
    ;;

  *) fail "unknown mode $mode" ;;
esac
echo "PASS: decode $mode"
