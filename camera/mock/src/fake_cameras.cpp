#include "sensor_rig/camera/mock/fake_cameras.hpp"

#include <arpa/inet.h>
#include <arv.h>
#include <netinet/in.h>
#include <time.h>

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::camera::mock {
namespace {

void sleep_ms(int ms) {
  timespec ts{ms / 1000, static_cast<long>(ms % 1000) * 1'000'000};
  ::nanosleep(&ts, nullptr);
}

}  // namespace

namespace {

constexpr const char* kInprocessClock =
    "camera timestamp ns: CLOCK_REALTIME (UTC, microseconds) when the fake fills the frame: its exposure start";

// An in-process fake's truth record under rig chaos: one per camera for the whole run (a watchdog
// reopen makes a new fake device, whose frame ids start again at 1: a reboot of the units).
struct InprocessTruth {
  InprocessTruth(const ChaosArgs& chaos)
      : truth(chaos.truth, chaos.device, "camera", "in-process Aravis fake (ArvFakeDevice)", kInprocessClock) {}
  CameraTruth truth;
  std::mutex mutex;  // units: one fill at a time per device, but a reopen's new device may overlap the old
  FrameUnits units;
  bool opened_before = false;
};

// What one fake device's fill callback needs; freed with the device (g_object_set_data_full).
// `painter`: a second fake camera whose own fill paints the image. A fill callback cannot set the
// buffer's received size (private in Aravis 0.8: only the fake's built-in pattern sets it, and a
// frame without it is incomplete), so the painter's arv_fake_camera_fill_buffer does, with the
// device camera's geometry, and the frame's id and stamps are put back.
struct FillContext {
  FillContext(std::shared_ptr<InprocessTruth> t, ArvFakeCamera* cam) : truth(std::move(t)), camera(cam), painter(arv_fake_camera_new("RIGTRUTHPAINT")) {}
  ~FillContext() {
    if (painter != nullptr) g_object_unref(painter);
  }
  FillContext(const FillContext&) = delete;
  FillContext& operator=(const FillContext&) = delete;
  std::shared_ptr<InprocessTruth> truth;
  ArvFakeCamera* camera = nullptr;
  ArvFakeCamera* painter = nullptr;
};

void paint(FillContext& ctx, ArvBuffer* buffer) {
  for (const guint32 reg : {ARV_FAKE_CAMERA_REGISTER_WIDTH, ARV_FAKE_CAMERA_REGISTER_HEIGHT, ARV_FAKE_CAMERA_REGISTER_X_OFFSET,
                            ARV_FAKE_CAMERA_REGISTER_Y_OFFSET, ARV_FAKE_CAMERA_REGISTER_PIXEL_FORMAT,
                            ARV_FAKE_CAMERA_REGISTER_EXPOSURE_TIME_US, ARV_FAKE_CAMERA_REGISTER_GAIN_RAW}) {
    guint32 v = 0;
    if (arv_fake_camera_read_register(ctx.camera, reg, &v)) arv_fake_camera_write_register(ctx.painter, reg, v);
  }
  const guint64 frame_id = arv_buffer_get_frame_id(buffer);
  const guint64 stamp = arv_buffer_get_timestamp(buffer), system_stamp = arv_buffer_get_system_timestamp(buffer);
  arv_fake_camera_fill_buffer(ctx.painter, buffer, nullptr);
  arv_buffer_set_frame_id(buffer, frame_id);
  arv_buffer_set_timestamp(buffer, stamp);
  arv_buffer_set_system_timestamp(buffer, system_stamp);
}

// Replaces the fake's fill (arv_fake_camera_fill_buffer calls it after setting the frame's id and
// timestamp, before the stream hands the buffer on). One model for every Aravis fake (as
// rig-fake-gige-camera): the timestamp is the exposure start, and the frame leaves when its
// exposure ends, so the thread waits for that on CLOCK_MONOTONIC (a host clock step does not
// stretch an exposure), and says it arrived then. Painting later than the exposure's end (a loaded host) moves the exposure
// and the stamp later by as much: the frame still leaves at its exposure's end. The frame is
// recorded as made and sent (no network: an in-process frame is lost only where the rig loses it,
// or never made when the stream has no free buffer, which Aravis counts as an underrun).
void fill_and_record(ArvBuffer* buffer, void* data, guint32 exposure_time_us, guint32 /*gain*/, ArvPixelFormat /*format*/) {
  auto* ctx = static_cast<FillContext*>(data);
  // The exposure starts now (the fake set the stamp microseconds ago): its end is waited for on
  // CLOCK_MONOTONIC from here. Waiting until stamp + exposure by CLOCK_REALTIME held the frame, and
  // the fake's stream, as long as a host clock step back between the two (issue 27).
  const auto now = clock_pair_now();  // the truth's acquisition: one instant on both clocks
  const Nanos start_mono = now.monotonic_ns;
  Nanos acq = now.vehicle_ns;
  const guint64 frame_id = arv_buffer_get_frame_id(buffer);
  paint(*ctx, buffer);
  const Nanos exposure = Nanos{exposure_time_us} * 1000;
  const Nanos end_mono = start_mono + exposure;
  const timespec until{static_cast<time_t>(end_mono / 1'000'000'000), static_cast<long>(end_mono % 1'000'000'000)};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) == EINTR) {
  }
  acq += std::max<Nanos>(0, monotonic_now_ns() - end_mono);  // late: the exposure began that much later
  arv_buffer_set_timestamp(buffer, static_cast<guint64>(acq));
  // The host's receive time (what Aravis's GigE stream writes at the leader's arrival; the fake had
  // it equal to the timestamp, a frame arriving as its exposure began): the frame leaves now.
  arv_buffer_set_system_timestamp(buffer, static_cast<guint64>(vehicle_now_ns()));
  InprocessTruth& t = *ctx->truth;
  std::int64_t unit = 0;
  {
    std::lock_guard lock(t.mutex);
    unit = t.units.unit(frame_id);
  }
  t.truth.frame(unit, acq, acq, vehicle_now_ns(), truth::Fate::kSent, 0, exposure);
  t.truth.flush();  // on disk before the rig can publish the frame (a killed rig leaves no frame the truth lacks)
}

void record_truth_of(ArvDevice* d, const std::shared_ptr<InprocessTruth>& truth) {
  ArvFakeCamera* cam = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(d));
  if (cam == nullptr) throw CameraError("aravis fake: no fake camera behind the device");
  {
    std::lock_guard lock(truth->mutex);
    if (truth->opened_before) truth->units.reboot();  // frame ids start again at 1
    truth->opened_before = true;
  }
  auto* ctx = new FillContext(truth, cam);
  if (ctx->painter == nullptr) {
    delete ctx;
    throw CameraError("aravis fake: arv_fake_camera_new failed");
  }
  g_object_set_data_full(G_OBJECT(d), "sensor-rig-truth", ctx, [](gpointer p) { delete static_cast<FillContext*>(p); });
  arv_fake_camera_set_fill_pattern(cam, fill_and_record, ctx);
}

}  // namespace

AravisDeviceOpener inprocess_fake_opener(const ChaosArgs& chaos) {
  // The truth file is created once, at the first open (not per reopen: that would truncate it).
  std::shared_ptr<InprocessTruth> truth = chaos.truth.empty() ? nullptr : std::make_shared<InprocessTruth>(chaos);
  return [truth](const std::string& device) -> void* {
    const std::string prefix = kFakePrefix;
    if (device.rfind(prefix, 0) != 0) return open_aravis_network_device(device);
    // Aravis loads the fake's GenICam XML lazily into a static without a lock: two cameras
    // opening at once get "Genicam data not found". One at a time.
    static std::mutex create_mutex;
    std::lock_guard lock(create_mutex);
    GError* err = nullptr;
    ArvDevice* d = arv_fake_device_new(device.substr(prefix.size()).c_str(), &err);
    if (d == nullptr) {
      std::string msg = err != nullptr ? err->message : "unknown error";
      if (err != nullptr) g_error_free(err);
      throw CameraError("aravis " + device + ": " + msg);
    }
    if (truth != nullptr) {
      try {
        record_truth_of(d, truth);
      } catch (...) {
        g_object_unref(d);
        throw;
      }
    }
    return d;
  };
}

namespace {
// execv takes a path: find a bare program name on $PATH.
std::string find_program(const std::string& program) {
  if (program.find('/') != std::string::npos) return program;
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    std::string candidate = (dir.empty() ? std::string(".") : dir) + "/" + program;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return program;
}
}  // namespace

std::string gige_fake_serial(const std::string& address) {
  // "RIG" and the IPv4 address in hex: unique per address and 11 characters for every address.
  // "RIG127_4_188_208" (the address spelt out) was 16, one more than Aravis holds: such a fake
  // never streamed, ~1 in 10 of the tests' leased 127.x.y.z addresses.
  in_addr a{};
  if (::inet_pton(AF_INET, address.c_str(), &a) != 1) throw std::runtime_error("gige fake: '" + address + "' is not an IPv4 address");
  char text[16];
  std::snprintf(text, sizeof text, "RIG%08X", ntohl(a.s_addr));
  return text;
}

std::vector<std::string> gige_fake_command(const GigeFakeOptions& o) {
  const std::string serial = o.serial.empty() ? gige_fake_serial(o.address) : o.serial;
  std::vector<std::string> argv{find_program(o.program), "-i", o.address, "-s", serial};
  if (o.lost_packets_per_thousand > 0) argv.insert(argv.end(), {"-r", std::to_string(o.lost_packets_per_thousand)});
  if (!o.genicam.empty()) argv.insert(argv.end(), {"-g", o.genicam});
  if (o.realtime_priority > 0) argv.insert(argv.end(), {"--realtime-priority", std::to_string(o.realtime_priority)});
  if (!o.chaos.plan.empty()) argv.insert(argv.end(), {"--fault-plan", o.chaos.plan});
  if (!o.chaos.device.empty()) argv.insert(argv.end(), {"--device", o.chaos.device});
  if (!o.chaos.truth.empty()) argv.insert(argv.end(), {"--truth", o.chaos.truth});
  return argv;
}

std::string device_genicam_xml(const std::string& device) {
  auto* dev = static_cast<ArvDevice*>(open_aravis_network_device(device));  // throws CameraError
  std::size_t size = 0;
  const char* xml = arv_device_get_genicam_xml(dev, &size);
  std::string out = xml != nullptr ? std::string(xml, size) : std::string();
  g_object_unref(dev);
  if (out.empty()) throw CameraError("aravis " + device + ": no GenICam XML");
  return out;
}

namespace {
// A 32-bit register of the fake's memory (big endian, never cached) as a GenICam IntReg.
std::string test_register(const std::string& name, const std::string& address, const std::string& access) {
  return "  <IntReg Name=\"" + name + "\" NameSpace=\"Custom\">\n    <Address>" + address +
         "</Address>\n    <Length>4</Length>\n    <AccessMode>" + access +
         "</AccessMode>\n    <pPort>Device</pPort>\n    <Cachable>NoCache</Cachable>\n"
         "    <Sign>Unsigned</Sign>\n    <Endianess>BigEndian</Endianess>\n  </IntReg>\n";
}

// @ENABLE@ / @STATUS@ / @LATCH@: PtpEnable / PtpStatus / PtpDataSetLatch or the GevIEEE1588 names
// (the latch writes 1 to PtpLatchTestRegister, for a test to see it was run). The enable
// writes its register through a converter: true keeps a fault a test put in bits 8..31 (a servo
// still faulty after enable), false clears the register (what the reset's disable repairs).
constexpr const char* kPtpNodes = R"(
  <Boolean Name="@ENABLE@" NameSpace="Standard">
    <pValue>PtpEnableValue</pValue>
    <OnValue>1</OnValue>
    <OffValue>0</OffValue>
  </Boolean>
  <IntConverter Name="PtpEnableValue" NameSpace="Custom">
    <pVariable Name="R">PtpTestRegister</pVariable>
    <FormulaTo>FROM ? ((R &gt;&gt; 8) &lt;&lt; 8) + 1 : 0</FormulaTo>
    <FormulaFrom>TO &amp; 1</FormulaFrom>
    <pValue>PtpTestRegister</pValue>
  </IntConverter>
  <Command Name="@LATCH@" NameSpace="Standard">
    <pValue>PtpLatchTestRegister</pValue>
    <CommandValue>1</CommandValue>
  </Command>
  <IntSwissKnife Name="PtpStatusValue" NameSpace="Custom">
    <pVariable Name="R">PtpTestRegister</pVariable>
    <Formula>R = 0 ? 2 : (R = 1 ? 5 : (R = 2 ? 3 : 1))</Formula>
  </IntSwissKnife>
  <Enumeration Name="@STATUS@" NameSpace="Standard">
    <EnumEntry Name="Initializing" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <EnumEntry Name="Faulty" NameSpace="Standard"><Value>1</Value></EnumEntry>
    <EnumEntry Name="Disabled" NameSpace="Standard"><Value>2</Value></EnumEntry>
    <EnumEntry Name="Listening" NameSpace="Standard"><Value>3</Value></EnumEntry>
    <EnumEntry Name="Master" NameSpace="Standard"><Value>4</Value></EnumEntry>
    <EnumEntry Name="Slave" NameSpace="Standard"><Value>5</Value></EnumEntry>
    <pValue>PtpStatusValue</pValue>
  </Enumeration>
)";

// The fake's own GenICam XML, read from a default fake started on `address` for the moment.
std::string fake_genicam_xml(const std::string& address) {
  GigeFakeOptions o;
  o.address = address;
  auto plain = start_gige_fake(o);
  std::string xml = device_genicam_xml(o.address);
  plain.stop(500);
  if (xml.rfind("</RegisterDescription>") == std::string::npos)
    throw std::runtime_error("the fake's GenICam data is not a RegisterDescription");
  return xml;
}

// Inserts `nodes` before the closing tag of the top element.
void add_nodes(std::string& xml, const std::string& nodes) { xml.insert(xml.rfind("</RegisterDescription>"), nodes); }

// Adds an EnumEntry to the Enumeration `name` (before its pValue); throws when it has it already.
void add_enum_entry(std::string& xml, const std::string& name, const std::string& entry, int value) {
  const auto at = xml.find("<Enumeration Name=\"" + name + "\"");
  const auto pvalue = at == std::string::npos ? at : xml.find("<pValue>", at);
  if (pvalue == std::string::npos) throw std::runtime_error("the fake has no Enumeration " + name);
  if (xml.find("<EnumEntry Name=\"" + entry + "\"", at) < pvalue)
    throw std::runtime_error("the fake's " + name + " has " + entry + " of its own now");
  xml.insert(pvalue, "<EnumEntry Name=\"" + entry + "\" NameSpace=\"Standard\"><Value>" + std::to_string(value) +
                         "</Value></EnumEntry>\n    ");
}

std::string write_temporary_genicam(const std::string& xml) {
  char path[] = "/tmp/rig_fake_genicam_XXXXXX.xml";
  const int fd = ::mkstemps(path, 4);
  if (fd < 0) throw std::runtime_error(std::string("mkstemps: ") + std::strerror(errno));
  ::close(fd);
  std::ofstream out(path);
  out << xml;
  if (!out.flush()) throw std::runtime_error(std::string("cannot write ") + path);
  return path;
}

}  // namespace

std::string write_ptp_fake_genicam(const std::string& address, bool gev_ieee1588) {
  std::string xml = fake_genicam_xml(address);
  const std::string enable = gev_ieee1588 ? "GevIEEE1588" : "PtpEnable";
  if (xml.find('"' + enable + '"') != std::string::npos)
    throw std::runtime_error("the fake has " + enable + " of its own now");
  std::string nodes = kPtpNodes;
  const auto put = [&nodes](const std::string& mark, const std::string& name) {
    nodes.replace(nodes.find(mark), mark.size(), name);
  };
  put("@ENABLE@", enable);
  put("@STATUS@", gev_ieee1588 ? "GevIEEE1588Status" : "PtpStatus");
  put("@LATCH@", gev_ieee1588 ? "GevIEEE1588DataSetLatch" : "PtpDataSetLatch");
  nodes += test_register("PtpTestRegister", "0x8000", "RW") + test_register("PtpLatchTestRegister", "0x8004", "RW");
  add_nodes(xml, nodes);
  return write_temporary_genicam(xml);
}

namespace {
constexpr const char* kChaosPtpNodes = R"(
  <Boolean Name="@ENABLE@" NameSpace="Standard">
    <pValue>ChaosPtpEnableRegister</pValue>
    <OnValue>1</OnValue>
    <OffValue>0</OffValue>
  </Boolean>
  <Command Name="@LATCH@" NameSpace="Standard">
    <pValue>ChaosPtpLatchRegister</pValue>
    <CommandValue>1</CommandValue>
  </Command>
  <Enumeration Name="@STATUS@" NameSpace="Standard">
    <EnumEntry Name="Initializing" NameSpace="Standard"><Value>0</Value></EnumEntry>
    <EnumEntry Name="Faulty" NameSpace="Standard"><Value>1</Value></EnumEntry>
    <EnumEntry Name="Disabled" NameSpace="Standard"><Value>2</Value></EnumEntry>
    <EnumEntry Name="Listening" NameSpace="Standard"><Value>3</Value></EnumEntry>
    <EnumEntry Name="Master" NameSpace="Standard"><Value>4</Value></EnumEntry>
    <EnumEntry Name="Slave" NameSpace="Standard"><Value>5</Value></EnumEntry>
    <EnumEntry Name="Uncalibrated" NameSpace="Standard"><Value>6</Value></EnumEntry>
    <pValue>ChaosPtpStatusRegister</pValue>
  </Enumeration>
)";

std::string hex(std::uint32_t v) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%x", v);
  return b;
}
}  // namespace

std::string fake_camera_genicam_xml() {
  ArvFakeCamera* cam = arv_fake_camera_new("RIGCHAOSXML");
  if (cam == nullptr) throw std::runtime_error("arv_fake_camera_new failed");
  std::size_t size = 0;
  const char* data = arv_fake_camera_get_genicam_xml(cam, &size);
  std::string xml = data != nullptr ? std::string(data, size) : std::string();
  g_object_unref(cam);
  return xml;
}

namespace {
constexpr const char* kFakePayloadFormula = "<Formula>WIDTH * HEIGHT * ((PIXELFORMAT>>16)&amp;0xFF) / 8</Formula>";
constexpr const char* kChaosChunkNodes = R"(
  <Boolean Name="ChunkModeActive" NameSpace="Standard">
    <pValue>ChaosChunkModeRegister</pValue>
    <OnValue>1</OnValue>
    <OffValue>0</OffValue>
  </Boolean>
  <IntReg Name="ChunkTimestamp" NameSpace="Standard">
    <Address>0x0</Address>
    <Length>8</Length>
    <AccessMode>RO</AccessMode>
    <pPort>ChaosChunkTimestampPort</pPort>
    <Cachable>NoCache</Cachable>
    <Sign>Unsigned</Sign>
    <Endianess>BigEndian</Endianess>
  </IntReg>
  <Port Name="ChaosChunkTimestampPort"><ChunkID>@TIMESTAMP@</ChunkID></Port>
  <FloatReg Name="ChunkExposureTime" NameSpace="Standard">
    <Address>0x0</Address>
    <Length>8</Length>
    <AccessMode>RO</AccessMode>
    <pPort>ChaosChunkExposurePort</pPort>
    <Cachable>NoCache</Cachable>
    <Endianess>BigEndian</Endianess>
  </FloatReg>
  <Port Name="ChaosChunkExposurePort"><ChunkID>@EXPOSURE@</ChunkID></Port>
)";
}  // namespace

std::string chaos_chunk_genicam_xml(std::string xml) {
  const auto payload = xml.find("<IntSwissKnife Name=\"PayloadSize\"");
  const auto formula = payload == std::string::npos ? payload : xml.find(kFakePayloadFormula, payload);
  if (formula == std::string::npos || xml.rfind("</RegisterDescription>") == std::string::npos)
    throw std::runtime_error("the fake's PayloadSize is not WIDTH * HEIGHT * bits / 8 any more");
  char chunk_bytes[16];
  std::snprintf(chunk_bytes, sizeof chunk_bytes, "%zu", kChaosChunkTrailerBytes);
  xml.replace(formula, std::string(kFakePayloadFormula).size(),
              std::string("<pVariable Name=\"PAD\">ChaosRowPaddingRegister</pVariable>\n"
                          "\t\t<pVariable Name=\"CHUNKMODE\">ChaosChunkModeRegister</pVariable>\n"
                          "\t\t<pVariable Name=\"CHUNKPLAN\">ChaosChunkPlanRegister</pVariable>\n"
                          "\t\t<Formula>WIDTH * HEIGHT * ((PIXELFORMAT>>16)&amp;0xFF) / 8 + HEIGHT * PAD + ((CHUNKMODE | CHUNKPLAN) &amp; 1) * ") +
                  chunk_bytes + "</Formula>");
  std::string nodes = kChaosChunkNodes;
  const auto put = [&nodes](const std::string& mark, std::uint32_t id) {
    char text[16];
    std::snprintf(text, sizeof text, "%08X", id);
    nodes.replace(nodes.find(mark), mark.size(), text);
  };
  put("@TIMESTAMP@", kChaosChunkIdTimestamp);
  put("@EXPOSURE@", kChaosChunkIdExposure);
  nodes += test_register("ChaosChunkModeRegister", hex(kChaosChunkModeRegister), "RW") +
           test_register("ChaosRowPaddingRegister", hex(kChaosRowPaddingRegister), "RO") +
           test_register("ChaosChunkPlanRegister", hex(kChaosChunkPlanRegister), "RO");
  add_nodes(xml, nodes);
  return xml;
}

std::string chaos_ptp_genicam_xml(bool gev_ieee1588) {
  std::string xml = fake_camera_genicam_xml();
  if (xml.rfind("</RegisterDescription>") == std::string::npos)
    throw std::runtime_error("the fake's GenICam data is not a RegisterDescription");
  std::string nodes = kChaosPtpNodes;
  const auto put = [&nodes](const std::string& mark, const std::string& name) { nodes.replace(nodes.find(mark), mark.size(), name); };
  put("@ENABLE@", gev_ieee1588 ? "GevIEEE1588" : "PtpEnable");
  put("@STATUS@", gev_ieee1588 ? "GevIEEE1588Status" : "PtpStatus");
  put("@LATCH@", gev_ieee1588 ? "GevIEEE1588DataSetLatch" : "PtpDataSetLatch");
  nodes += test_register("ChaosPtpEnableRegister", hex(kChaosPtpEnableRegister), "RW") +
           test_register("ChaosPtpLatchRegister", hex(kChaosPtpLatchRegister), "RW") +
           test_register("ChaosPtpStatusRegister", hex(kChaosPtpStatusRegister), "RO");
  add_nodes(xml, nodes);
  return xml;
}

std::string write_line_trigger_fake_genicam(const std::string& address) {
  std::string xml = fake_genicam_xml(address);
  add_enum_entry(xml, "TriggerSource", "Line1", 2);
  add_enum_entry(xml, "TriggerActivation", "FallingEdge", 1);
  // A readable view of the fake's write-only TriggerSoftware register.
  add_nodes(xml, test_register("TriggerSoftwareTestRegister", "0x30c", "RO"));
  return write_temporary_genicam(xml);
}

bool gvcp_port_bound(const std::string& address) {
  in_addr a{};
  if (::inet_pton(AF_INET, address.c_str(), &a) != 1) return false;
  // /proc/net/udp: local address as hex of the in-memory (network order) u32, then :port hex.
  char want[32];
  std::snprintf(want, sizeof want, "%08X:%04X", a.s_addr, 3956u);
  std::ifstream in("/proc/net/udp");
  std::string line;
  while (std::getline(in, line))
    if (line.find(want) != std::string::npos) return true;
  return false;
}

ChildProcess start_gige_fake(const GigeFakeOptions& o, std::chrono::milliseconds timeout) {
  ChildProcess p(gige_fake_command(o));
  const Nanos deadline = monotonic_now_ns() + static_cast<Nanos>(timeout.count()) * 1'000'000;
  while (!gvcp_port_bound(o.address)) {
    if (!p.running())
      throw std::runtime_error("arv-fake-gv-camera on " + o.address + " exited with status " + std::to_string(p.exit_status()));
    if (monotonic_now_ns() > deadline) {
      p.stop(500);
      throw std::runtime_error("arv-fake-gv-camera on " + o.address + " did not bind GVCP port 3956");
    }
    sleep_ms(10);
  }
  return p;
}

}  // namespace sensor_rig::camera::mock
