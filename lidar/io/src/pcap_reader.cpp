#include "sensor_rig/lidar/pcap_reader.hpp"

#include <pcap/pcap.h>

namespace sensor_rig::lidar {

struct PcapReader::Impl {
  struct Closer {
    void operator()(pcap_t* p) const noexcept { pcap_close(p); }
  };
  std::unique_ptr<pcap_t, Closer> handle;
  std::string path;
  std::string error;
  PcapStats stats;
  int linktype = 0;
  bool done = false;
};

PcapReader::PcapReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  char errbuf[PCAP_ERRBUF_SIZE] = {};
  pcap_t* p = pcap_open_offline_with_tstamp_precision(path.c_str(), PCAP_TSTAMP_PRECISION_NANO, errbuf);
  if (p == nullptr) throw PcapError("cannot read pcap " + path + ": " + errbuf);
  impl_->handle.reset(p);
  impl_->linktype = pcap_datalink(p);
  if (!linktype_supported(impl_->linktype)) {
    const char* name = pcap_datalink_val_to_name(impl_->linktype);
    throw PcapError("pcap " + path + ": link type " + std::to_string(impl_->linktype) + " (" +
                    (name ? name : "unknown") + ") is not supported (Ethernet, Linux SLL/SLL2, raw IPv4)");
  }
}

PcapReader::~PcapReader() = default;
PcapReader::PcapReader(PcapReader&&) noexcept = default;
PcapReader& PcapReader::operator=(PcapReader&&) noexcept = default;

std::optional<PcapRecord> PcapReader::next() {
  auto& d = *impl_;
  while (!d.done) {
    pcap_pkthdr* hdr = nullptr;
    const u_char* data = nullptr;
    const int rc = pcap_next_ex(d.handle.get(), &hdr, &data);
    if (rc == PCAP_ERROR_BREAK) {
      d.done = true;
      break;
    }
    if (rc != 1) {
      d.done = true;
      d.error = "pcap " + d.path + ": read error after " + std::to_string(d.stats.records) +
                " records: " + pcap_geterr(d.handle.get());
      break;
    }
    ++d.stats.records;
    const std::span<const std::byte> frame(reinterpret_cast<const std::byte*>(data), hdr->caplen);
    const UdpFrame f = parse_udp_frame(d.linktype, frame);
    switch (f.status) {
      case FrameStatus::kOk: {
        ++d.stats.udp;
        PcapRecord r;
        r.packet.data = f.payload;
        // Opened with nanosecond precision: tv_usec holds nanoseconds.
        r.packet.rx_ns = static_cast<Nanos>(hdr->ts.tv_sec) * 1'000'000'000LL + static_cast<Nanos>(hdr->ts.tv_usec);
        r.packet.dst_port = f.dst_port;
        r.src_port = f.src_port;
        r.src_ip = f.src_ip;
        r.dst_ip = f.dst_ip;
        return r;
      }
      case FrameStatus::kFragment: ++d.stats.fragments; break;
      case FrameStatus::kTruncated: ++d.stats.truncated; break;
      case FrameStatus::kNotIpv4:
      case FrameStatus::kNotUdp: ++d.stats.not_udp; break;
      case FrameStatus::kBadHeader:
      case FrameStatus::kUnsupportedLink: ++d.stats.bad; break;
    }
  }
  return std::nullopt;
}

const std::string& PcapReader::error() const noexcept { return impl_->error; }
const PcapStats& PcapReader::stats() const noexcept { return impl_->stats; }
int PcapReader::linktype() const noexcept { return impl_->linktype; }
const std::string& PcapReader::path() const noexcept { return impl_->path; }

}  // namespace sensor_rig::lidar
