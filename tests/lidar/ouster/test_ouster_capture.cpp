// The OS-1-32-G FW 2.1.1 LEGACY capture against ouster-sdk's digest of it
// (OS-1-32-G_v2.1.1_1024x10_digest.json, made by ouster.client.digest.StreamDigest):
//  - packet_hash: per field, MD5 over every packet of the field's array in its SDK dtype:
//    column headers TIMESTAMP u64, ENCODER_COUNT u32, MEASUREMENT_ID u16, STATUS u32, FRAME_ID u16
//    (one per column), channel fields (pixels x columns, row-major) RANGE u32, FLAGS u8,
//    REFLECTIVITY u8 (the SDK reads the low byte of LEGACY's 16-bit field), SIGNAL u16, NEAR_IR u16;
//  - scans[0]: the LidarScan of frame 638, staggered image (rows x 1024 columns, indexed by
//    measurement id): TIMESTAMP u64, STATUS u64, MEASUREMENT_ID u16, ENCODER_COUNT u64, RANGE
//    u32, SIGNAL u16, NEAR_IR u16, REFLECTIVITY u8, FRAME_ID as text.
// Every hash is reproduced from this project's packet accessors. The decoder's points are then
// compared one by one with that image: one point per non-zero range, in packet order, xyz from an
// independent double-precision projection, intensity = signal, ring, t and the scan stamp.
#include <gtest/gtest.h>
#include <openssl/evp.h>

#include <cmath>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>

#include "ouster_test_support.hpp"
#include "sensor_rig/lidar/ouster/decoder.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/ouster/packet.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"

namespace sensor_rig::lidar::ouster::test {
namespace {

class Md5 {
 public:
  Md5() : ctx_(EVP_MD_CTX_new(), &EVP_MD_CTX_free) { EVP_DigestInit_ex(ctx_.get(), EVP_md5(), nullptr); }
  template <typename T>
  void add(const std::vector<T>& v) {
    EVP_DigestUpdate(ctx_.get(), v.data(), v.size() * sizeof(T));
  }
  std::string hex() {
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int n = 0;
    EVP_DigestFinal_ex(ctx_.get(), md, &n);
    static const char* k = "0123456789abcdef";
    std::string s;
    for (unsigned i = 0; i < n; ++i) {
      s += k[md[i] >> 4];
      s += k[md[i] & 15];
    }
    return s;
  }

 private:
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx_;
};

template <typename T>
std::string md5_of(const std::vector<T>& v) {
  Md5 m;
  m.add(v);
  return m.hex();
}

struct Capture {
  SensorMetadata meta;
  std::vector<std::vector<std::byte>> packets;  // data packets, in file order
};

class OusterCapture : public ::testing::Test {
 protected:
  void SetUp() override {
    pcap_ = ouster_file("OS-1-32-G_v2.1.1_1024x10.pcap");
    const auto meta = ouster_file("OS-1-32-G_v2.1.1_1024x10.json");
    const auto digest = ouster_file("OS-1-32-G_v2.1.1_1024x10_digest.json");
    if (!exists(pcap_) || !exists(meta) || !exists(digest))
      GTEST_SKIP() << "Ouster capture, metadata or digest not found under " << data_dir() << "/lidar/ouster";
    cap_.meta = parse_metadata(read_text(meta), meta);
    digest_ = nlohmann::json::parse(read_text(digest));
    PcapReader reader(pcap_);
    while (auto r = reader.next()) {
      if (r->packet.dst_port != cap_.meta.udp_port_lidar) continue;
      cap_.packets.emplace_back(r->packet.data.begin(), r->packet.data.end());
    }
  }
  std::string pcap_;
  Capture cap_;
  nlohmann::json digest_;
};

TEST_F(OusterCapture, PacketDigestMatchesOusterSdk) {
  const auto l = cap_.meta.layout();
  ASSERT_EQ(cap_.packets.size(), 64U);
  std::map<std::string, Md5> h;
  for (const auto& pkt : cap_.packets) {
    ASSERT_EQ(check_packet(pkt, l), PacketStatus::kOk);
    std::vector<std::uint64_t> ts;
    std::vector<std::uint32_t> enc, status;
    std::vector<std::uint16_t> mid, fid;
    for (std::size_t c = 0; c < l.columns_per_packet; ++c) {
      const auto ch = read_column_header(pkt, l, c);
      ASSERT_TRUE(ch);
      ts.push_back(ch->timestamp_ns);
      enc.push_back(ch->encoder_count);
      mid.push_back(ch->measurement_id);
      status.push_back(ch->status);
      fid.push_back(ch->frame_id);
    }
    h["TIMESTAMP"].add(ts);
    h["ENCODER_COUNT"].add(enc);
    h["MEASUREMENT_ID"].add(mid);
    h["STATUS"].add(status);
    h["FRAME_ID"].add(fid);
    std::vector<std::uint32_t> range;
    std::vector<std::uint8_t> flags, refl;
    std::vector<std::uint16_t> signal, nir;
    for (std::size_t px = 0; px < l.pixels_per_column; ++px) {
      for (std::size_t c = 0; c < l.columns_per_packet; ++c) {
        range.push_back(static_cast<std::uint32_t>(*read_field(pkt, l, c, px, Field::kRange)));
        flags.push_back(static_cast<std::uint8_t>(*read_field(pkt, l, c, px, Field::kFlags)));
        refl.push_back(static_cast<std::uint8_t>(*read_field(pkt, l, c, px, Field::kReflectivity)));
        signal.push_back(static_cast<std::uint16_t>(*read_field(pkt, l, c, px, Field::kSignal)));
        nir.push_back(static_cast<std::uint16_t>(*read_field(pkt, l, c, px, Field::kNearIr)));
      }
    }
    h["RANGE"].add(range);
    h["FLAGS"].add(flags);
    h["REFLECTIVITY"].add(refl);
    h["SIGNAL"].add(signal);
    h["NEAR_IR"].add(nir);
  }
  const auto& want = digest_.at("packet_hash");
  ASSERT_EQ(want.size(), h.size());
  for (auto& [name, md5] : h) EXPECT_EQ(md5.hex(), want.at(name).get<std::string>()) << name;
}

// The staggered LidarScan image of the capture's frame, from the packet accessors.
struct Image {
  std::uint32_t frame_id = 0;
  std::vector<std::uint64_t> ts, status, encoder;
  std::vector<std::uint16_t> mid;
  std::vector<std::uint32_t> range;
  std::vector<std::uint16_t> signal, nir;
  std::vector<std::uint8_t> refl;
};

Image make_image(const Capture& cap) {
  const auto l = cap.meta.layout();
  const std::size_t w = static_cast<std::size_t>(cap.meta.columns_per_frame);
  const std::size_t hgt = l.pixels_per_column;
  Image im;
  im.ts.assign(w, 0);
  im.status.assign(w, 0);
  im.encoder.assign(w, 0);
  im.mid.assign(w, 0);
  im.range.assign(w * hgt, 0);
  im.signal.assign(w * hgt, 0);
  im.nir.assign(w * hgt, 0);
  im.refl.assign(w * hgt, 0);
  for (const auto& pkt : cap.packets) {
    im.frame_id = read_packet_header(pkt, l)->frame_id;
    for (std::size_t c = 0; c < l.columns_per_packet; ++c) {
      const auto ch = *read_column_header(pkt, l, c);
      const std::size_t m = ch.measurement_id;
      im.ts[m] = ch.timestamp_ns;
      im.status[m] = ch.status;
      im.encoder[m] = ch.encoder_count;
      im.mid[m] = ch.measurement_id;
      for (std::size_t px = 0; px < hgt; ++px) {
        im.range[px * w + m] = static_cast<std::uint32_t>(*read_field(pkt, l, c, px, Field::kRange));
        im.signal[px * w + m] = static_cast<std::uint16_t>(*read_field(pkt, l, c, px, Field::kSignal));
        im.nir[px * w + m] = static_cast<std::uint16_t>(*read_field(pkt, l, c, px, Field::kNearIr));
        im.refl[px * w + m] = static_cast<std::uint8_t>(*read_field(pkt, l, c, px, Field::kReflectivity));
      }
    }
  }
  return im;
}

TEST_F(OusterCapture, ScanDigestMatchesOusterSdk) {
  const Image im = make_image(cap_);
  ASSERT_EQ(digest_.at("scans").size(), 1U);
  const auto& want = digest_.at("scans")[0];
  EXPECT_EQ(std::to_string(im.frame_id), want.at("FRAME_ID").get<std::string>());
  EXPECT_EQ(md5_of(im.ts), want.at("TIMESTAMP").get<std::string>());
  EXPECT_EQ(md5_of(im.status), want.at("STATUS").get<std::string>());
  EXPECT_EQ(md5_of(im.mid), want.at("MEASUREMENT_ID").get<std::string>());
  EXPECT_EQ(md5_of(im.encoder), want.at("ENCODER_COUNT").get<std::string>());
  EXPECT_EQ(md5_of(im.range), want.at("RANGE").get<std::string>());
  EXPECT_EQ(md5_of(im.signal), want.at("SIGNAL").get<std::string>());
  EXPECT_EQ(md5_of(im.nir), want.at("NEAR_IR").get<std::string>());
  EXPECT_EQ(md5_of(im.refl), want.at("REFLECTIVITY").get<std::string>());
}

TEST_F(OusterCapture, DecodedPointsMatchTheImage) {
  const Image im = make_image(cap_);  // checked against the SDK digest above
  DecoderConfig cfg;
  cfg.metadata = cap_.meta;
  Decoder dec(cfg);
  std::vector<Scan> scans;
  std::vector<std::uint16_t> packet_mids;  // measurement ids in packet order
  for (const auto& pkt : cap_.packets) {
    const auto t = dec.first_column_time(pkt);
    ASSERT_TRUE(t);
    for (std::size_t c = 0; c < 16; ++c) packet_mids.push_back(read_column_header(pkt, dec.layout(), c)->measurement_id);
    if (auto s = dec.push(PacketView{pkt, 0, 7502}, static_cast<Nanos>(*t))) scans.push_back(std::move(*s));
  }
  EXPECT_FALSE(dec.flush()) << "the frame's last packet already ended the scan";
  ASSERT_EQ(scans.size(), 1U) << "the capture holds exactly frame 638, starting at measurement id 0";
  const Scan& s = scans[0];
  EXPECT_EQ(s.packets, 64U);
  EXPECT_EQ(s.dropped, 0U);
  EXPECT_EQ(s.stamp, static_cast<Nanos>(im.ts[0]));
  EXPECT_EQ(dec.stats().invalid_columns, 0U);

  const auto& m = cap_.meta;
  const std::size_t w = 1024;
  const std::size_t hgt = 32;
  const double pi = std::numbers::pi;
  std::size_t k = 0;
  double max_err = 0.0;
  for (const std::uint16_t mid : packet_mids) {
    for (std::size_t row = 0; row < hgt; ++row) {
      const std::uint32_t r = im.range[row * w + mid];
      if (r == 0) continue;
      ASSERT_LT(k, s.points.size());
      const auto& p = s.points[k++];
      // ouster-sdk's projection, in double: encoder angle, beam azimuth/altitude, beam origin offset.
      const double e = 2 * pi * (1.0 - mid / 1024.0);
      const double a = -m.beam_azimuth_deg[row] * pi / 180;
      const double al = m.beam_altitude_deg[row] * pi / 180;
      const double n = m.beam_to_lidar[3];
      const double lx = (r - n) * std::cos(e + a) * std::cos(al) + n * std::cos(e);
      const double ly = (r - n) * std::sin(e + a) * std::cos(al) + n * std::sin(e);
      const double lz = (r - n) * std::sin(al);
      const double x = -lx / 1000.0;  // lidar_to_sensor: diag(-1, -1, 1), z + 36.18 mm
      const double y = -ly / 1000.0;
      const double z = (lz + 36.18) / 1000.0;
      max_err = std::max({max_err, std::abs(static_cast<double>(p.x) - x), std::abs(static_cast<double>(p.y) - y), std::abs(static_cast<double>(p.z) - z)});
      ASSERT_EQ(p.intensity, static_cast<float>(im.signal[row * w + mid]));
      ASSERT_EQ(p.t, static_cast<std::uint32_t>(im.ts[mid] - im.ts[0]));
      ASSERT_EQ(p.return_type, kReturnStrongest);
      ASSERT_EQ(p.ring, dec.ring_of_beam(row));
    }
  }
  EXPECT_EQ(k, s.points.size());
  EXPECT_EQ(s.points.size(), 27310U);
  EXPECT_LT(max_err, 5e-5) << "metres";
  // Beam 0 is the highest (12.75 deg), beam 31 the lowest (-15.32 deg).
  EXPECT_EQ(dec.ring_of_beam(0), 31);
  EXPECT_EQ(dec.ring_of_beam(31), 0);
  // The scan covers a full turn: points in every quadrant around the sensor.
  int quad[4] = {0, 0, 0, 0};
  for (const auto& p : s.points) ++quad[(p.x >= 0 ? 0 : 1) + (p.y >= 0 ? 0 : 2)];
  for (const int q : quad) EXPECT_GT(q, 1000);
}

}  // namespace
}  // namespace sensor_rig::lidar::ouster::test
