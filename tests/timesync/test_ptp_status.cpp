#include "sensor_rig/timesync/ptp_status.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>

namespace sensor_rig::timesync {
namespace {

// Output of `pmc -u -b 0 'GET TIME_STATUS_NP'` (linuxptp 3.x) on a slave port.
constexpr std::string_view kSlave =
    "sending: GET TIME_STATUS_NP\n"
    "\t90e2ba.fffe.20c7f8-0 seq 0 RESPONSE MANAGEMENT TIME_STATUS_NP \n"
    "\t\tmaster_offset              -37\n"
    "\t\tingress_time               1795255200034372012\n"
    "\t\tcumulativeScaledRateOffset +0.000012345\n"
    "\t\tscaledLastGmPhaseChange    0\n"
    "\t\tgmTimeBaseIndicator        0\n"
    "\t\tlastGmPhaseChange          0x0000'0000000000000000.0000\n"
    "\t\tgmPresent                  true\n"
    "\t\tgmIdentity                 0050c2.fffe.d0d000\n"
    "\n";

TEST(PmcTimeStatus, ParsesASlaveResponse) {
  const PtpParseResult r = parse_pmc_time_status(kSlave);
  ASSERT_EQ(r.status, PtpParseStatus::kOk) << r.error;
  ASSERT_EQ(r.responses.size(), 1u);
  const PtpTimeStatus& s = r.responses[0];
  EXPECT_EQ(s.port_identity, "90e2ba.fffe.20c7f8-0");
  EXPECT_EQ(s.master_offset_ns, -37);
  EXPECT_EQ(s.ingress_time_ns, 1795255200034372012);
  EXPECT_DOUBLE_EQ(s.cumulative_scaled_rate_offset, 0.000012345);
  EXPECT_EQ(s.gm_time_base_indicator, 0);
  EXPECT_EQ(s.last_gm_phase_change, "0x0000'0000000000000000.0000");
  EXPECT_TRUE(s.gm_present);
  EXPECT_EQ(s.gm_identity, "0050c2.fffe.d0d000");
  EXPECT_TRUE(ptp_synchronised(s, 1000));
  EXPECT_TRUE(ptp_synchronised(s, 37));
  EXPECT_FALSE(ptp_synchronised(s, 36));
}

TEST(PmcTimeStatus, GrandmasterAbsent) {
  // ptp4l running as its own master (no GM found): offset 0, gmPresent false, own identity.
  const std::string text =
      "sending: GET TIME_STATUS_NP\n"
      "\t001122.fffe.334455-0 seq 0 RESPONSE MANAGEMENT TIME_STATUS_NP\n"
      "\t\tmaster_offset              0\n"
      "\t\tingress_time               0\n"
      "\t\tcumulativeScaledRateOffset +0.000000000\n"
      "\t\tscaledLastGmPhaseChange    0\n"
      "\t\tgmTimeBaseIndicator        0\n"
      "\t\tlastGmPhaseChange          0x0000'0000000000000000.0000\n"
      "\t\tgmPresent                  false\n"
      "\t\tgmIdentity                 001122.fffe.334455\n";
  const PtpParseResult r = parse_pmc_time_status(text);
  ASSERT_EQ(r.status, PtpParseStatus::kOk) << r.error;
  EXPECT_FALSE(r.responses[0].gm_present);
  EXPECT_FALSE(ptp_synchronised(r.responses[0], 1'000'000));
}

TEST(PmcTimeStatus, NoResponseWhenPtp4lIsNotRunning) {
  const PtpParseResult r = parse_pmc_time_status("sending: GET TIME_STATUS_NP\n");
  EXPECT_EQ(r.status, PtpParseStatus::kNoResponse);
  EXPECT_TRUE(r.responses.empty());
  EXPECT_EQ(parse_pmc_time_status("").status, PtpParseStatus::kNoResponse);
}

TEST(PmcTimeStatus, SeveralResponsesAndOtherTlvs) {
  std::string text(kSlave);
  text += "\taabbcc.fffe.ddeeff-1 seq 0 RESPONSE MANAGEMENT PORT_DATA_SET\n"
          "\t\tportIdentity            aabbcc.fffe.ddeeff-1\n"
          "\t\tportState               SLAVE\n";
  text += "\taabbcc.fffe.ddeeff-2 seq 0 RESPONSE MANAGEMENT TIME_STATUS_NP\n"
          "\t\tmaster_offset              123456\n"
          "\t\tingress_time               5\n"
          "\t\tgmPresent                  true\n"
          "\t\tgmIdentity                 0050c2.fffe.d0d000\n"
          "\t\tsomeFutureField            42\n";
  const PtpParseResult r = parse_pmc_time_status(text);
  ASSERT_EQ(r.status, PtpParseStatus::kOk) << r.error;
  ASSERT_EQ(r.responses.size(), 2u);
  EXPECT_EQ(r.responses[1].port_identity, "aabbcc.fffe.ddeeff-2");
  EXPECT_EQ(r.responses[1].master_offset_ns, 123456);
  EXPECT_FALSE(ptp_synchronised(r.responses[1], 100'000));
}

TEST(PmcTimeStatus, MalformedValuesNameTheLine) {
  std::string text(kSlave);
  text.replace(text.find("-37"), 3, "-3x");
  PtpParseResult r = parse_pmc_time_status(text);
  EXPECT_EQ(r.status, PtpParseStatus::kMalformed);
  EXPECT_NE(r.error.find("line 3"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("master_offset"), std::string::npos) << r.error;

  text = std::string(kSlave);
  text.replace(text.find("true"), 4, "yes!");
  r = parse_pmc_time_status(text);
  EXPECT_EQ(r.status, PtpParseStatus::kMalformed);
  EXPECT_NE(r.error.find("gmPresent"), std::string::npos) << r.error;

  // A response cut short (pmc killed mid-output).
  text = std::string(kSlave.substr(0, kSlave.find("\t\tgmPresent")));
  r = parse_pmc_time_status(text);
  EXPECT_EQ(r.status, PtpParseStatus::kMalformed);
  EXPECT_TRUE(r.responses.empty());

  r = parse_pmc_time_status("garbage\x01\xff line\n");
  EXPECT_EQ(r.status, PtpParseStatus::kMalformed);
}

TEST(PmcTimeStatus, ManagementErrorIsReported) {
  const PtpParseResult r = parse_pmc_time_status(
      "sending: GET TIME_STATUS_NP\n"
      "\t90e2ba.fffe.20c7f8-0 seq 0 RESPONSE MANAGEMENT_ERROR_STATUS TIME_STATUS_NP\n"
      "\t\tERROR: NOT_SUPPORTED\n");
  EXPECT_EQ(r.status, PtpParseStatus::kMalformed);
  EXPECT_NE(r.error.find("management error"), std::string::npos) << r.error;
}

TEST(PmcTimeStatus, ExtremeOffsetsDoNotOverflow) {
  PtpTimeStatus s;
  s.gm_present = true;
  s.master_offset_ns = INT64_MIN;
  EXPECT_FALSE(ptp_synchronised(s, INT64_MAX - 1));
  s.master_offset_ns = -5;
  EXPECT_TRUE(ptp_synchronised(s, 6));
}

}  // namespace
}  // namespace sensor_rig::timesync
