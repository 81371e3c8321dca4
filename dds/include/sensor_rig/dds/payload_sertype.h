#pragma once
// Topics for variable-size types with a large trailing byte sequence (PointCloud2, Image,
// CompressedImage): Cyclone's default sertype but for the size of an iceoryx chunk, computed
// without serializing the sample a second time (payload_sertype.c says why and when it is exact).
#include <stddef.h>

#include "dds/dds.h"

#if defined(__cplusplus)
extern "C" {
#endif

// As dds_create_topic, for a type whose last variable-size member is a sequence<uint8> at
// `payload_offset` in the C sample, followed only by 1-byte members. Types this cannot reproduce
// exactly (keys, XCDR2-only, a data representation in `qos`), and any type when the environment
// has RIG_DDS_DEFAULT_SERTYPE set (for before/after measurements), get Cyclone's own sertype.
dds_entity_t rig_create_payload_topic(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                                      const char* name, const dds_qos_t* qos, size_t payload_offset);

// For tests: the chunk size of `sample` from this sertype and from Cyclone's default size function,
// through a topic `name` created and deleted on `participant`. DDS_RETCODE_UNSUPPORTED when the
// type (or the environment) gets Cyclone's own sertype.
int rig_payload_sizes_for_test(dds_entity_t participant, const dds_topic_descriptor_t* desc, const char* name,
                               size_t payload_offset, const void* sample, size_t* ours, size_t* cyclone);

struct ddsi_sertype;
// As dds_create_topic (Cyclone's default sertype in every respect, built as dds_create_topic builds
// it) for a keyless type, and *sertype = the topic's sertype, valid while the topic lives: what
// ddsi_serdata_from_ser_iov needs to turn received CDR bytes back into a sample to write
// (dds/raw_topic.hpp). Cyclone 0.10.2 has no call that returns an entity's sertype.
dds_entity_t rig_create_cdr_topic(dds_entity_t participant, const dds_topic_descriptor_t* desc, const char* name,
                                  const dds_qos_t* qos, const struct ddsi_sertype** sertype);

#if defined(__cplusplus)
}
#endif
