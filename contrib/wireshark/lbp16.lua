-- SPDX-License-Identifier: MIT
-- Wireshark / tshark dissector for LBP16, the register protocol of Mesa's
-- Ethernet cards (7I92 and kin, and `lbpkit sim`) on UDP port 27181.
--
-- Written for lbpkit from the protocol as docs/protocol-facts.md (LBP16)
-- describes it: a request datagram holds commands back to back, each a 16-bit
-- little-endian command word (bit 15 write, 14 address follows, 13 info area,
-- 12..10 memory space, 9..8 transfer size 1/2/4/8 bytes, 7 auto-increment,
-- 6..0 count), then a 16-bit little-endian address when bit 14 is set, then
-- the data of a write. A reply holds the data of the request's reads, in
-- order, and nothing else; this dissector pairs each reply with the request
-- before it in the same conversation to split it.
--
-- Use:  tshark -X lua_script:contrib/wireshark/lbp16.lua -r capture.pcap -V
--       wireshark -X lua_script:contrib/wireshark/lbp16.lua capture.pcap
-- or copy it to ~/.local/lib/wireshark/plugins/.
--
-- SSLBP: 32-bit writes to a smart-serial COMMAND register at the usual
-- HostMot2 addresses (0x5A00 + 0x40 x instance; IDROMConst.vhd) are named
-- (STOP, START, setup START, DOIT, local read/write). `lbpkit decode` names
-- every register from the card's own IDROM.

local bit = bit32 or bit

local lbp16 = Proto("lbp16", "Mesa LBP16")

local spaces = { [0] = "HostMot2", [1] = "Ethernet chip", [2] = "EEPROM", [3] = "flash",
                 [4] = "timer", [5] = "space 5", [6] = "comm control", [7] = "board info" }
local sizes = { [0] = "8-bit", [1] = "16-bit", [2] = "32-bit", [3] = "64-bit" }

local f = {
  command = ProtoField.uint16("lbp16.command", "Command", base.HEX),
  write = ProtoField.bool("lbp16.write", "Write", 16, nil, 0x8000),
  has_address = ProtoField.bool("lbp16.has_address", "Address follows", 16, nil, 0x4000),
  info_area = ProtoField.bool("lbp16.info_area", "Info area", 16, nil, 0x2000),
  space = ProtoField.uint16("lbp16.space", "Memory space", base.DEC, spaces, 0x1C00),
  size = ProtoField.uint16("lbp16.size", "Transfer size", base.DEC, sizes, 0x0300),
  autoinc = ProtoField.bool("lbp16.autoinc", "Auto-increment", 16, nil, 0x0080),
  count = ProtoField.uint16("lbp16.count", "Count", base.DEC, nil, 0x007F),
  address = ProtoField.uint16("lbp16.address", "Address", base.HEX),
  data = ProtoField.bytes("lbp16.data", "Data"),
  value = ProtoField.uint32("lbp16.value", "Value", base.HEX),
  sslbp = ProtoField.string("lbp16.sslbp", "SSLBP command"),
  reply_to = ProtoField.framenum("lbp16.reply_to", "Reply to the request in frame"),
  read_address = ProtoField.uint16("lbp16.read_address", "Read address", base.HEX),
}
lbp16.fields = f

local ef_truncated = ProtoExpert.new("lbp16.truncated", "LBP16 datagram cut short", expert.group.MALFORMED,
                                     expert.severity.ERROR)
local ef_unpaired = ProtoExpert.new("lbp16.unpaired", "LBP16 reply with no request before it",
                                    expert.group.SEQUENCE, expert.severity.WARN)
lbp16.experts = { ef_truncated, ef_unpaired }

-- Reads of the last request per conversation (first pass), and per reply
-- frame the request it answers (kept for the later passes).
local last_request = {}
local reply_of = {}

function lbp16.init()
  last_request = {}
  reply_of = {}
end

local function decode_word(w)
  return {
    write = bit.band(w, 0x8000) ~= 0,
    has_address = bit.band(w, 0x4000) ~= 0,
    info = bit.band(w, 0x2000) ~= 0,
    space = bit.band(bit.rshift(w, 10), 7),
    size = bit.lshift(1, bit.band(bit.rshift(w, 8), 3)),
    autoinc = bit.band(w, 0x0080) ~= 0,
    count = bit.band(w, 0x007F),
  }
end

local function sslbp_command(v)
  -- COMMAND register (manual: SSLBP, COMMAND REGISTER; docs/protocol-facts.md).
  if bit.band(v, 0x80000000) ~= 0 then return "ignored (bit 31)" end
  local mask = bit.band(v, 0xFF)
  if bit.band(v, 0x2000) ~= 0 then
    local rw = bit.band(v, 0x8000) ~= 0 and "local write" or "local read"
    return string.format("%s 0x%03X", rw, bit.band(v, 0x3FF))
  end
  local t = bit.band(v, 0xFF00)
  if t == 0x0800 then return mask == 0 and "STOP ALL" or string.format("STOP channels 0x%02X", mask) end
  if t == 0x0900 then return string.format("START channels 0x%02X", mask) end
  if t == 0x0F00 then return string.format("setup START channels 0x%02X", mask) end
  if t == 0x1000 then return string.format("DOIT channels 0x%02X", mask) end
  if t == 0x4000 then return "processor reset" end
  return nil
end

local function conversation(pinfo, request)
  if request then
    return tostring(pinfo.src) .. ":" .. pinfo.src_port .. ">" .. tostring(pinfo.dst) .. ":" .. pinfo.dst_port
  end
  return tostring(pinfo.dst) .. ":" .. pinfo.dst_port .. ">" .. tostring(pinfo.src) .. ":" .. pinfo.src_port
end

local function dissect_request(buf, pinfo, tree)
  local at, n = 0, buf:len()
  local reads, summary = {}, {}
  while at < n do
    if n - at < 2 then
      tree:add_proto_expert_info(ef_truncated, "1 byte left where a command word should be")
      break
    end
    local w = buf(at, 2):le_uint()
    local c = decode_word(w)
    local nbytes = c.size * c.count
    local len = 2 + (c.has_address and 2 or 0) + (c.write and nbytes or 0)
    local cmd = tree:add(lbp16, buf(at, math.min(len, n - at)),
                         string.format("%s %s%s, %d x %d bytes", c.write and "Write" or "Read", spaces[c.space],
                                       c.info and " info area" or "", c.count, c.size))
    cmd:add_le(f.command, buf(at, 2))
    cmd:add_le(f.write, buf(at, 2))
    cmd:add_le(f.has_address, buf(at, 2))
    cmd:add_le(f.info_area, buf(at, 2))
    cmd:add_le(f.space, buf(at, 2))
    cmd:add_le(f.size, buf(at, 2))
    cmd:add_le(f.autoinc, buf(at, 2))
    cmd:add_le(f.count, buf(at, 2))
    at = at + 2
    local address = nil
    if c.has_address then
      if n - at < 2 then
        cmd:add_proto_expert_info(ef_truncated, "the address is missing")
        break
      end
      address = buf(at, 2):le_uint()
      cmd:add_le(f.address, buf(at, 2))
      at = at + 2
    end
    local where = address and string.format("0x%04X", address) or "ptr"
    table.insert(summary, string.format("%s %s %s x%d", c.write and "W" or "R", spaces[c.space], where, c.count))
    if c.write then
      if n - at < nbytes then
        cmd:add_proto_expert_info(ef_truncated, string.format("%d data bytes of %d", n - at, nbytes))
        break
      end
      if nbytes > 0 then cmd:add(f.data, buf(at, nbytes)) end
      if c.size == 4 then
        for i = 0, c.count - 1 do
          local v = buf(at + 4 * i, 4):le_uint()
          cmd:add_le(f.value, buf(at + 4 * i, 4))
          local a = address and (address + (c.autoinc and 4 * i or 0)) or nil
          if c.space == 0 and not c.info and a and a >= 0x5A00 and a < 0x5B00 and a % 0x40 == 0 then
            local s = sslbp_command(v)
            if s then
              cmd:add(f.sslbp, buf(at + 4 * i, 4), s)
              table.insert(summary, "SSLBP " .. s)
            end
          end
        end
      end
      at = at + nbytes
    else
      table.insert(reads, { word = w, address = address, size = c.size, count = c.count, autoinc = c.autoinc })
    end
  end
  if not pinfo.visited then last_request[conversation(pinfo, true)] = { frame = pinfo.number, reads = reads } end
  return table.concat(summary, "; ")
end

local function dissect_reply(buf, pinfo, tree)
  local req = reply_of[pinfo.number]
  if not pinfo.visited then
    local key = conversation(pinfo, false)
    req = last_request[key]
    last_request[key] = nil
    reply_of[pinfo.number] = req
  end
  if not req then
    tree:add_proto_expert_info(ef_unpaired)
    tree:add(f.data, buf())
    return string.format("reply, %d bytes", buf:len())
  end
  tree:add(f.reply_to, req.frame)
  local at, n = 0, buf:len()
  for _, r in ipairs(req.reads) do
    local nbytes = r.size * r.count
    if n - at < nbytes then
      tree:add_proto_expert_info(ef_truncated, string.format("%d bytes of the %d a read wants", n - at, nbytes))
      break
    end
    local sub = tree:add(lbp16, buf(at, math.max(nbytes, 0)),
                         string.format("Data of read %s x%d", r.address and string.format("0x%04X", r.address) or "ptr",
                                       r.count))
    if r.address then sub:add(f.read_address, r.address) end
    if nbytes > 0 then sub:add(f.data, buf(at, nbytes)) end
    if r.size == 4 then
      for i = 0, r.count - 1 do sub:add_le(f.value, buf(at + 4 * i, 4)) end
    end
    at = at + nbytes
  end
  return string.format("reply to frame %d, %d bytes", req.frame, n)
end

function lbp16.dissector(buf, pinfo, tree)
  pinfo.cols.protocol = "LBP16"
  local subtree = tree:add(lbp16, buf(), "Mesa LBP16")
  local request = pinfo.dst_port == 27181
  local info = request and dissect_request(buf, pinfo, subtree) or dissect_reply(buf, pinfo, subtree)
  pinfo.cols.info = (request and "LBP16 " or "LBP16 ") .. info
  return buf:len()
end

DissectorTable.get("udp.port"):add(27181, lbp16)
