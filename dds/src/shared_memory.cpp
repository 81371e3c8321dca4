#include "sensor_rig/dds/shared_memory.hpp"

#include <dds/ddsc/dds_loan_api.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_shm_transport.h>

namespace sensor_rig::dds {

bool uses_shared_memory(dds_entity_t endpoint) noexcept { return dds_is_shared_memory_available(endpoint); }

bool loan_available(dds_entity_t writer) noexcept { return dds_is_loan_available(writer); }

void* loan_sample(dds_entity_t writer) noexcept {
  void* sample = nullptr;
  if (dds_loan_sample(writer, &sample) != DDS_RETCODE_OK) return nullptr;
  return sample;
}

void wait_for_acks(dds_entity_t writer, Nanos timeout_ns) noexcept { (void)dds_wait_for_acks(writer, timeout_ns); }

int take_in_place(dds_entity_t reader, void* scratch, void (*fn)(void* ctx, const void* sample), void* ctx,
                  TakeCounts& counts) {
  int n = 0;
  for (;;) {
    ddsi_serdata* sd = nullptr;
    dds_sample_info_t si{};
    if (dds_takecdr(reader, &sd, 1, &si, DDS_ANY_STATE) <= 0 || sd == nullptr) break;
    if (si.valid_data) {
      if (sd->iox_chunk != nullptr && shm_get_data_state(sd->iox_chunk) == IOX_CHUNK_CONTAINS_RAW_DATA) {
        fn(ctx, sd->iox_chunk);
        ++counts.zero_copy;
      } else if (ddsi_serdata_to_sample(sd, scratch, nullptr, nullptr)) {
        fn(ctx, scratch);
        ++counts.copied;
        if (sd->iox_chunk != nullptr) ++counts.serialized_chunk;  // variable-size types over shm
      }
      ++n;
    }
    ddsi_serdata_unref(sd);
  }
  return n;
}

}  // namespace sensor_rig::dds
