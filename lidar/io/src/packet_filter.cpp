#include "sensor_rig/lidar/packet_filter.hpp"

#include <netinet/in.h>

#include <cstddef>

namespace sensor_rig::lidar {
namespace {

constexpr std::uint32_t kIpProtoOffset = 9;
constexpr std::uint32_t kIpSrcOffset = 12;
constexpr std::uint32_t kIpFragOffset = 6;
constexpr std::uint32_t kFragmentBits = 0x3fff;  // more-fragments flag | fragment offset: any fragment

// Instructions with symbolic jump targets, resolved to relative offsets at the end.
struct Asm {
  struct Insn {
    std::uint16_t code;
    std::uint32_t k;
    int jt = -1, jf = -1;  // label ids, -1 = next instruction
  };
  std::vector<Insn> insns;
  std::vector<std::size_t> labels;

  int label() {
    labels.push_back(0);
    return static_cast<int>(labels.size() - 1);
  }
  void place(int l) { labels[static_cast<std::size_t>(l)] = insns.size(); }
  void op(std::uint16_t code, std::uint32_t k) { insns.push_back({code, k}); }
  void jump(std::uint16_t code, std::uint32_t k, int jt, int jf) { insns.push_back({code, k, jt, jf}); }

  std::vector<sock_filter> finish() const {
    std::vector<sock_filter> out;
    for (std::size_t i = 0; i < insns.size(); ++i) {
      const auto& in = insns[i];
      auto rel = [&](int l) {
        return static_cast<std::uint8_t>(l < 0 ? 0 : labels[static_cast<std::size_t>(l)] - (i + 1));
      };
      out.push_back(sock_filter{in.code, rel(in.jt), rel(in.jf), in.k});
    }
    return out;
  }
};

}  // namespace

std::vector<sock_filter> build_sensor_filter(const SensorFilter& f) {
  Asm a;
  const int accept = a.label();
  const int reject = a.label();
  a.op(BPF_LD | BPF_B | BPF_ABS, kIpProtoOffset);
  a.jump(BPF_JMP | BPF_JEQ | BPF_K, IPPROTO_UDP, -1, reject);
  if (f.src_host != 0) {
    a.op(BPF_LD | BPF_W | BPF_ABS, kIpSrcOffset);
    a.jump(BPF_JMP | BPF_JEQ | BPF_K, f.src_host, -1, reject);
  }
  a.op(BPF_LD | BPF_H | BPF_ABS, kIpFragOffset);
  // Any fragment: later ones carry no UDP header, and the first alone cannot tell whether the
  // datagram completes; the reassembler, then the port check after it, decide.
  a.jump(BPF_JMP | BPF_JSET | BPF_K, kFragmentBits, accept, -1);
  a.op(BPF_LDX | BPF_B | BPF_MSH, 0);                                 // X = IPv4 header length
  a.op(BPF_LD | BPF_H | BPF_IND, 2);                                  // UDP destination port
  if (f.second_port != 0 && f.second_port != f.dst_port) a.jump(BPF_JMP | BPF_JEQ | BPF_K, f.second_port, accept, -1);
  a.jump(BPF_JMP | BPF_JEQ | BPF_K, f.dst_port, accept, reject);
  a.place(accept);
  a.op(BPF_RET | BPF_K, kFilterAcceptBytes);
  a.place(reject);
  a.op(BPF_RET | BPF_K, 0);
  return a.finish();
}

std::uint32_t run_classic_bpf(std::span<const sock_filter> program, std::span<const std::byte> p) noexcept {
  auto load = [&](std::uint32_t at, std::uint32_t bytes, std::uint32_t& out) {
    if (static_cast<std::uint64_t>(at) + bytes > p.size()) return false;
    out = 0;
    for (std::uint32_t i = 0; i < bytes; ++i) out = (out << 8) | std::to_integer<std::uint32_t>(p[at + i]);
    return true;
  };
  std::uint32_t a = 0;
  std::uint32_t x = 0;
  for (std::size_t pc = 0; pc < program.size(); ++pc) {
    const auto& in = program[pc];
    switch (in.code) {
      case BPF_LD | BPF_B | BPF_ABS:
        if (!load(in.k, 1, a)) return 0;
        break;
      case BPF_LD | BPF_H | BPF_ABS:
        if (!load(in.k, 2, a)) return 0;
        break;
      case BPF_LD | BPF_W | BPF_ABS:
        if (!load(in.k, 4, a)) return 0;
        break;
      case BPF_LD | BPF_H | BPF_IND:
        if (!load(x + in.k, 2, a)) return 0;
        break;
      case BPF_LDX | BPF_B | BPF_MSH:
        if (!load(in.k, 1, x)) return 0;
        x = (x & 0x0f) * 4;
        break;
      case BPF_JMP | BPF_JEQ | BPF_K:
        pc += a == in.k ? in.jt : in.jf;
        break;
      case BPF_JMP | BPF_JSET | BPF_K:
        pc += (a & in.k) != 0 ? in.jt : in.jf;
        break;
      case BPF_RET | BPF_K:
        return in.k;
      default:
        return 0;
    }
  }
  return 0;  // fell off the end: the kernel's checker refuses such a program
}

}  // namespace sensor_rig::lidar
