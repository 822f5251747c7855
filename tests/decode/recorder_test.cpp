// SPDX-License-Identifier: MIT
// The packet recorder behind `--trace` (no allocation on
// the recording thread, a pcap libpcap reads back, a full ring drops rather
// than waits) and the decoder's register names and SSLBP commands.
#include <gtest/gtest.h>
#include <pcap/pcap.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <new>
#include <string>
#include <vector>

#include "daemon/packet_ring.hpp"
#include "daemon/pcap_recorder.hpp"
#include "lbpkit/decode.hpp"
#include "lbpkit/wire/lbp16.hpp"
#include "sim_card/sim_transport.hpp"
#include "support/allocation_counter.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace server = lbpkit::server;

using testing_alloc::tAllocations;  // this thread's own: the writer thread allocates

namespace {

std::string tempFile(const std::string& name) {
  return (std::filesystem::temp_directory_path() / (name + "-" + std::to_string(::getpid()) + ".pcap")).string();
}

TEST(PacketTrace, RecordingDoesNotAllocateAndLibpcapReadsItBack) {
  const auto path = tempFile("lbpkit-recorder");
  {
    server::PcapRecorder rec(path, server::PcapRecorder::Link::Ipv4Udp, {}, 8192);
    const std::vector<std::uint8_t> request = {0x01, 0x42, 0x00, 0x01};  // read hm2 0x0100, one word
    const server::PcapRecorder::Endpoint host{0x7F000001, 40000}, card{0x7F001203, 27181};
    const auto before = tAllocations;
    for (int i = 0; i < 2000; ++i) {  // 4000 packets: within the ring, whatever the writer does
      rec.udp(1'000'000'000LL + i * 1000, host, card, request);
      rec.lbp(1'000'000'000LL + i * 1000, true, request);
    }
    EXPECT_EQ(tAllocations - before, 0U) << "the recording thread allocated";
    EXPECT_EQ(rec.dropped(), 0U);
  }
  char err[PCAP_ERRBUF_SIZE] = {};
  pcap_t* p = pcap_open_offline_with_tstamp_precision(path.c_str(), PCAP_TSTAMP_PRECISION_NANO, err);
  ASSERT_NE(p, nullptr) << err;
  EXPECT_EQ(pcap_datalink(p), DLT_RAW);
  pcap_pkthdr* h = nullptr;
  const u_char* data = nullptr;
  ASSERT_EQ(pcap_next_ex(p, &h, &data), 1);
  EXPECT_EQ(h->ts.tv_sec, 1);
  EXPECT_EQ(h->ts.tv_usec, 0);  // nanoseconds
  ASSERT_EQ(h->caplen, 20U + 8U + 4U);
  EXPECT_EQ(data[0], 0x45);  // IPv4, 20-byte header
  EXPECT_EQ(data[9], 17);    // UDP
  EXPECT_EQ(data[19], 0x03);  // to 127.0.18.3
  EXPECT_EQ(data[22] << 8 | data[23], 27181);
  EXPECT_EQ(data[28], 0x01);
  // The IPv4 header checksum sums to 0xFFFF.
  std::uint32_t sum = 0;
  for (int i = 0; i < 20; i += 2) sum += static_cast<std::uint32_t>(data[i] << 8 | data[i + 1]);
  while (sum >> 16) sum = (sum & 0xFFFF) + (sum >> 16);
  EXPECT_EQ(sum, 0xFFFFU);
  int packets = 1;
  while (pcap_next_ex(p, &h, &data) == 1) ++packets;
  EXPECT_EQ(packets, 4000);
  pcap_close(p);
  std::filesystem::remove(path);
}

TEST(PacketTrace, AFullRingDropsAndCountsNeverWaits) {
  server::PacketRing ring(4);
  for (int i = 0; i < 4; ++i) {
    auto* s = ring.claim();
    ASSERT_NE(s, nullptr);
    s->ns = i;
    ring.commit();
  }
  EXPECT_EQ(ring.claim(), nullptr);
  EXPECT_EQ(ring.dropped(), 1U);
  std::vector<std::int64_t> seen;
  ring.drain([&](const server::PacketRing::Slot& s) { seen.push_back(s.ns); });
  EXPECT_EQ(seen, (std::vector<std::int64_t>{0, 1, 2, 3}));
  EXPECT_NE(ring.claim(), nullptr);  // room again
}

TEST(PacketTrace, AFileThatCannotBeMadeIsNamed) {
  try {
    server::PcapRecorder rec("/nonexistent-dir/x.pcap", server::PcapRecorder::Link::LbpStream, {});
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--trace /nonexistent-dir/x.pcap"), std::string::npos) << e.what();
  }
}

lbpkit::CardInfo defaultCard() {
  lbpkit::SimTransport t;
  return lbpkit::readCardInfo(t);
}

TEST(DecodeNames, RegistersAreNamedFromTheIdrom) {
  const lbpkit::decode::RegisterNames names(defaultCard());
  EXPECT_EQ(names.name(0x0100), "idrom.cookie");
  EXPECT_EQ(names.name(0x0C00), "watchdog.timer");
  EXPECT_EQ(names.name(0x0E00), "watchdog.reset");
  EXPECT_EQ(names.name(0x350C), "encoder.03.count");
  EXPECT_EQ(names.name(0x3604), "encoder.01.control");
  EXPECT_EQ(names.name(0x1104), "ioport.1.ddr");
  EXPECT_EQ(names.name(0x5A00), "sserial.0.command");
  EXPECT_EQ(names.name(0x5C08), "sserial.0.ch2.cs");
  EXPECT_EQ(names.name(0x5E04), "sserial.0.ch1.interface1");
  EXPECT_EQ(names.name(0x0444), "idrom.module[0].word1");
  EXPECT_EQ(names.name(0x7000), "");
  EXPECT_EQ(lbpkit::decode::localRegisterName(0xD7), "FaultStatus");
  EXPECT_EQ(lbpkit::decode::localRegisterName(0xF7), "LEDs");
  EXPECT_EQ(lbpkit::decode::localRegisterName(0xEC), "NVAccess");
}

std::vector<std::uint8_t> write32(std::uint16_t address, std::uint32_t value) {
  const std::uint16_t w = lbpkit::wire::lbp16::hm2Write(1);
  return {static_cast<std::uint8_t>(w), static_cast<std::uint8_t>(w >> 8), static_cast<std::uint8_t>(address),
          static_cast<std::uint8_t>(address >> 8), static_cast<std::uint8_t>(value),
          static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value >> 16),
          static_cast<std::uint8_t>(value >> 24)};
}

TEST(DecodeSslbp, ASetupModeLocalWriteIsNamedAtItsDoit) {
  lbpkit::decode::Lbp16Decoder d(defaultCard());
  std::vector<lbpkit::decode::Event> out;
  d.request(1, write32(0x5A00, 0x0F01), out);  // setup START channel 0
  d.request(2, write32(0x5C00, 0xEC000000), out);
  d.request(3, write32(0x5D00, 0x01), out);
  d.request(4, write32(0x5A00, 0x1001), out);
  d.request(5, write32(0x5A00, 0x0800), out);
  ASSERT_EQ(out.size(), 5U);
  EXPECT_EQ(out[0].text, "> write hm2 0x5A00  sserial.0.command = 0x00000F01  SSLBP setup START channels 0");
  EXPECT_EQ(out[1].text, "> write hm2 0x5C00  sserial.0.ch0.cs = 0xEC000000  (setup-mode access: local write NVAccess)");
  EXPECT_EQ(out[3].text,
            "> write hm2 0x5A00  sserial.0.command = 0x00001001  SSLBP DOIT channels 0; ch0: remote local write 0xEC "
            "NVAccess = 0x01");
  EXPECT_EQ(out[4].text, "> write hm2 0x5A00  sserial.0.command = 0x00000800  SSLBP STOP ALL");
  EXPECT_EQ(out[3].ns, 4);
  for (const auto& e : out) EXPECT_FALSE(e.malformed) << e.text;
}

TEST(DecodeSslbp, ReadsAreToldWithTheirReplyOrWithoutOne) {
  lbpkit::decode::Lbp16Decoder d(defaultCard());
  std::vector<lbpkit::decode::Event> out;
  const std::uint16_t w = lbpkit::wire::lbp16::hm2Read(1);
  const std::vector<std::uint8_t> read = {static_cast<std::uint8_t>(w), static_cast<std::uint8_t>(w >> 8), 0x00, 0x01};
  d.request(1, read, out);
  EXPECT_TRUE(out.empty());
  d.reply(2, std::vector<std::uint8_t>{0xFE, 0xCA, 0xAA, 0x55}, out);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0].text, "< read  hm2 0x0100  idrom.cookie = 0x55AACAFE");
  EXPECT_EQ(d.registersRead().at(0x0100), 0x55AACAFEU);
  d.request(3, read, out);
  d.finish(out);
  ASSERT_EQ(out.size(), 2U);
  EXPECT_EQ(out[1].text, "< read  hm2 0x0100  idrom.cookie = ?  (no reply)");
  // A short reply says so.
  d.request(4, read, out);
  d.reply(5, std::vector<std::uint8_t>{0xFE, 0xCA}, out);
  ASSERT_EQ(out.size(), 4U);
  EXPECT_TRUE(out[2].malformed);
  EXPECT_EQ(out[3].text, "< reply of 2 bytes, 4 expected: truncated");
}

}  // namespace
