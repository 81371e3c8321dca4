#pragma once
// Cyclone + iceoryx shared memory: whether an endpoint uses it, loans of fixed-size samples on the
// writer side, and the zero-copy take on the reader side. Cyclone 0.10's dds_take with a loan
// copies the sample into a reader-owned buffer; the take here hands out the serdata that
// references the iceoryx chunk itself, as rmw_cyclonedds does for loaned messages.
#include <cstdint>
#include <type_traits>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dds/entity.hpp"

namespace sensor_rig::dds {

bool uses_shared_memory(dds_entity_t endpoint) noexcept;
bool loan_available(dds_entity_t writer) noexcept;
// A writer-owned chunk to fill and pass to write(); nullptr when none (the caller counts it).
void* loan_sample(dds_entity_t writer) noexcept;
// Blocks until the writer's samples are acknowledged or timeout_ns passed.
void wait_for_acks(dds_entity_t writer, Nanos timeout_ns) noexcept;

struct TakeCounts {
  std::uint64_t zero_copy = 0;  // read in place from the iceoryx chunk
  std::uint64_t copied = 0;     // came another way (network, serialized chunk): deserialized into scratch
  std::uint64_t serialized_chunk = 0;  // of the copied: came through iceoryx, serialized in the chunk
};

// Takes every available sample of `reader` and calls fn(ctx, sample) with a pointer valid during
// the call: the chunk itself when it holds the raw sample, else `scratch` (a T) deserialized.
int take_in_place(dds_entity_t reader, void* scratch, void (*fn)(void* ctx, const void* sample), void* ctx,
                  TakeCounts& counts);

template <class T, class F>
int take_in_place(dds_entity_t reader, T& scratch, TakeCounts& counts, F&& fn) {
  using Fn = std::remove_reference_t<F>;
  auto call = [](void* ctx, const void* sample) { (*static_cast<Fn*>(ctx))(*static_cast<const T*>(sample)); };
  return take_in_place(reader, &scratch, call, const_cast<void*>(static_cast<const void*>(&fn)), counts);
}

}  // namespace sensor_rig::dds
