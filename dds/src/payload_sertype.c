// A topic whose sertype sizes iceoryx chunks without serializing the sample (payload_sertype.h).
//
// Cyclone 0.10.2 writes a variable-size sample over shared memory in two passes over the whole
// sample: the chunk's size comes from sertype_default_get_serialized_size, which serializes it into
// a throw-away serdata (malloc, copy, free), and serialize_into then serializes it again into the
// chunk. For a 1.2 MB PointCloud2 the first pass is a second full copy on the writer's thread.
// (Upstream replaced it with a size walk after 0.10.x: cyclonedds e72194259.)
//
// This sertype is Cyclone's default one in every respect (same serdata ops, same wire format, same
// type information; built as ddsi_sertype_default_init builds it) except for the size function:
// it serializes a copy of the sample whose trailing byte sequence is cut to at most 3 bytes, and
// adds the bytes cut. That is exact when the sequence is followed only by 1-byte members
// (PointCloud2: is_dense; Image, CompressedImage: nothing), so everything after it keeps its
// alignment; tests/dds/payload_sertype_test.cpp checks it against Cyclone's own size.
//
// C, not C++: the domain's serdata pool is only reachable through ddsi_domaingv.h (a C header).
#include "sensor_rig/dds/payload_sertype.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "dds/ddsi/ddsi_cdrstream.h"
#include "dds/ddsi/ddsi_domaingv.h"
#include "dds/ddsi/ddsi_serdata_default.h"
#include "dds/ddsi/ddsi_sertype.h"
#include "dds/ddsrt/heap.h"
#include "dds/ddsrt/misc.h"
#include "dds/ddsrt/string.h"
#include "dds/ddsrt/sync.h"

// Type name -> offset of the trailing sequence<uint8> in the C sample. Derived sertypes (Cyclone
// copies a sertype for another data representation) keep the ops but not extra fields, so the
// offset is looked up by type name rather than stored beside the sertype.
enum { kMaxPayloadTypes = 16 };
struct payload_type {
  char name[128];
  size_t offset;
};
static struct payload_type payload_types[kMaxPayloadTypes];
static uint32_t n_payload_types;
static ddsrt_mutex_t payload_lock;  // guards payload_types and the serpool hand-over below

static size_t payload_offset_locked(const char* type_name) {
  for (uint32_t i = 0; i < n_payload_types; i++)
    if (strcmp(payload_types[i].name, type_name) == 0) return payload_types[i].offset;
  return SIZE_MAX;
}

static bool payload_register_locked(const char* type_name, size_t offset) {
  const size_t known = payload_offset_locked(type_name);
  if (known != SIZE_MAX) return known == offset;
  if (n_payload_types == kMaxPayloadTypes || strlen(type_name) >= sizeof payload_types[0].name) return false;
  strcpy(payload_types[n_payload_types].name, type_name);
  payload_types[n_payload_types].offset = offset;
  n_payload_types++;
  return true;
}

// The largest C sample copied on the stack (the C structs hold pointers: PointCloud2 is ~100 bytes).
enum { kMaxSampleBytes = 1024 };

static size_t payload_get_serialized_size(const struct ddsi_sertype* type, const void* sample) {
  const struct ddsi_sertype_default* st = (const struct ddsi_sertype_default*)type;
  ddsrt_mutex_lock(&payload_lock);
  const size_t offset = payload_offset_locked(type->type_name);
  ddsrt_mutex_unlock(&payload_lock);
  if (offset == SIZE_MAX || st->type.size > kMaxSampleBytes || offset + sizeof(dds_sequence_t) > st->type.size)
    return ddsi_sertype_ops_default.get_serialized_size(type, sample);
  // A shallow copy whose payload keeps only its first length % 4 bytes (nothing in it is freed or
  // kept). Cyclone's size is padded to a multiple of 4; dropping a multiple of 4 bytes from the
  // payload moves every later member by that much and keeps their alignment, so the full size is
  // the shallow copy's plus the bytes dropped.
  _Alignas(max_align_t) unsigned char shallow[kMaxSampleBytes];
  memcpy(shallow, sample, st->type.size);
  dds_sequence_t payload;
  memcpy(&payload, shallow + offset, sizeof payload);
  const uint32_t dropped = payload._length & ~UINT32_C(3);
  payload._length -= dropped;
  memcpy(shallow + offset, &payload, sizeof payload);
  return ddsi_sertype_ops_default.get_serialized_size(type, shallow) + dropped;
}

static struct ddsi_sertype_ops payload_ops;  // Cyclone's default ops but the size function
static ddsrt_once_t payload_once = DDSRT_ONCE_INIT;
static void payload_init(void) {
  ddsrt_mutex_init(&payload_lock);
  payload_ops = ddsi_sertype_ops_default;
  payload_ops.get_serialized_size = payload_get_serialized_size;
}

// As ddsi_sertype_default_init does for a keyless XCDR1 type, with payload_ops; serpool is set
// once the sertype is registered (the domain's pool, which outlives every topic).
// With `ops` = Cyclone's own, exactly the sertype dds_create_topic makes (rig_create_cdr_topic).
static struct ddsi_sertype_default* payload_sertype_new(const dds_topic_descriptor_t* desc,
                                                       const struct ddsi_sertype_ops* ops) {
  enum ddsi_sertype_extensibility ext;
  if (!dds_stream_extensibility(desc->m_ops, &ext)) return NULL;
  struct ddsi_sertype_default* st = ddsrt_malloc(sizeof *st);
  memset(st, 0, sizeof *st);
  ddsi_sertype_init(&st->c, desc->m_typename, ops, &ddsi_serdata_ops_cdr_nokey, true);
  st->c.iox_size = desc->m_size;
  st->c.fixed_size = (st->c.fixed_size || (desc->m_flagset & DDS_TOPIC_FIXED_SIZE)) ? 1u : 0u;
  st->c.allowed_data_representation = (desc->m_flagset & DDS_TOPIC_RESTRICT_DATA_REPRESENTATION)
                                          ? desc->restrict_data_representation
                                          : DDS_DATA_REPRESENTATION_RESTRICT_DEFAULT;
  st->encoding_format = ddsi_sertype_extensibility_enc_format(ext);
  st->write_encoding_version = CDR_ENC_VERSION_1;
  st->serpool = NULL;
  st->type.size = desc->m_size;
  st->type.align = desc->m_align;
  st->type.flagset = desc->m_flagset;
  st->type.keys.nkeys = 0;
  st->type.keys.keys = NULL;
  st->type.ops.nops = dds_stream_countops(desc->m_ops, desc->m_nkeys, desc->m_keys);
  st->type.ops.ops = ddsrt_memdup(desc->m_ops, st->type.ops.nops * sizeof *st->type.ops.ops);
  if (desc->m_flagset & DDS_TOPIC_XTYPES_METADATA) {
    if (desc->type_information.sz == 0 || desc->type_information.data == NULL || desc->type_mapping.sz == 0 ||
        desc->type_mapping.data == NULL) {
      ddsi_sertype_unref(&st->c);
      return NULL;
    }
    st->type.typeinfo_ser.data = ddsrt_memdup(desc->type_information.data, desc->type_information.sz);
    st->type.typeinfo_ser.sz = desc->type_information.sz;
    st->type.typemap_ser.data = ddsrt_memdup(desc->type_mapping.data, desc->type_mapping.sz);
    st->type.typemap_ser.sz = desc->type_mapping.sz;
  }
  st->opt_size_xcdr1 = (st->c.allowed_data_representation & DDS_DATA_REPRESENTATION_FLAG_XCDR1)
                           ? dds_stream_check_optimize(&st->type, CDR_ENC_VERSION_1)
                           : 0;
  st->opt_size_xcdr2 = (st->c.allowed_data_representation & DDS_DATA_REPRESENTATION_FLAG_XCDR2)
                           ? dds_stream_check_optimize(&st->type, CDR_ENC_VERSION_2)
                           : 0;
  return st;
}

// Creates the topic; *out is its sertype when it is ours (else NULL), valid while the topic lives.
static dds_entity_t create_payload_topic(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                                         const char* name, const dds_qos_t* qos, size_t payload_offset,
                                         const struct ddsi_sertype** out) {
  *out = NULL;
  ddsrt_once(&payload_once, payload_init);
  // Only what this sertype reproduces exactly: keyless, XCDR1-capable, variable size, default data
  // representation. Anything else gets Cyclone's own sertype.
  const bool plain = desc->m_nkeys == 0 && !(desc->m_flagset & DDS_TOPIC_FIXED_SIZE) &&
                     dds_stream_minimum_xcdr_version(desc->m_ops) == CDR_ENC_VERSION_1 &&
                     !(desc->m_flagset & DDS_TOPIC_RESTRICT_DATA_REPRESENTATION) &&
                     !(qos != NULL && dds_qget_data_representation(qos, NULL, NULL));
  if (!plain || getenv("RIG_DDS_DEFAULT_SERTYPE") != NULL)
    return dds_create_topic(participant, desc, name, qos, NULL);

  ddsrt_mutex_lock(&payload_lock);
  if (!payload_register_locked(desc->m_typename, payload_offset)) {
    ddsrt_mutex_unlock(&payload_lock);
    return dds_create_topic(participant, desc, name, qos, NULL);
  }
  struct ddsi_sertype_default* st = payload_sertype_new(desc, &payload_ops);
  if (st == NULL) {
    ddsrt_mutex_unlock(&payload_lock);
    return DDS_RETCODE_BAD_PARAMETER;
  }
  struct ddsi_sertype* registered = &st->c;
  // Either registers st or swaps in (and releases st for) an equal one registered before, which
  // already has its pool. The lock keeps every sertype of ours from being used before it has one.
  const dds_entity_t topic = dds_create_topic_sertype(participant, name, &registered, qos, NULL, NULL);
  if (topic < 0) {
    ddsi_sertype_unref(registered);
  } else {
    struct ddsi_sertype_default* reg = (struct ddsi_sertype_default*)registered;
    if (reg->serpool == NULL) {
      const struct ddsi_domaingv* gv = ddsrt_atomic_ldvoidp(&registered->gv);
      reg->serpool = gv->serpool;
    }
    if (registered->ops == &payload_ops) *out = registered;
  }
  ddsrt_mutex_unlock(&payload_lock);
  return topic;
}

dds_entity_t rig_create_payload_topic(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                                      const char* name, const dds_qos_t* qos, size_t payload_offset) {
  const struct ddsi_sertype* st;
  return create_payload_topic(participant, desc, name, qos, payload_offset, &st);
}

int rig_payload_sizes_for_test(dds_entity_t participant, const dds_topic_descriptor_t* desc, const char* name,
                               size_t payload_offset, const void* sample, size_t* ours, size_t* cyclone) {
  const struct ddsi_sertype* st;
  const dds_entity_t topic = create_payload_topic(participant, desc, name, NULL, payload_offset, &st);
  if (topic < 0) return topic;
  if (st == NULL) {
    dds_delete(topic);
    return DDS_RETCODE_UNSUPPORTED;
  }
  *ours = ddsi_sertype_get_serialized_size(st, sample);
  *cyclone = ddsi_sertype_ops_default.get_serialized_size(st, sample);
  dds_delete(topic);
  return DDS_RETCODE_OK;
}

dds_entity_t rig_create_cdr_topic(dds_entity_t participant, const dds_topic_descriptor_t* desc, const char* name,
                                  const dds_qos_t* qos, const struct ddsi_sertype** sertype) {
  *sertype = NULL;
  ddsrt_once(&payload_once, payload_init);
  if (desc->m_nkeys != 0) return DDS_RETCODE_UNSUPPORTED;  // a keyed serdata needs the keyed serdata ops
  struct ddsi_sertype_default* st = payload_sertype_new(desc, &ddsi_sertype_ops_default);
  if (st == NULL) return DDS_RETCODE_BAD_PARAMETER;
  struct ddsi_sertype* registered = &st->c;
  // As in create_payload_topic: the lock keeps a sertype of ours from being used before it has a pool.
  ddsrt_mutex_lock(&payload_lock);
  const dds_entity_t topic = dds_create_topic_sertype(participant, name, &registered, qos, NULL, NULL);
  if (topic < 0) {
    ddsi_sertype_unref(registered);
  } else {
    struct ddsi_sertype_default* reg = (struct ddsi_sertype_default*)registered;
    if (reg->serpool == NULL) {
      const struct ddsi_domaingv* gv = ddsrt_atomic_ldvoidp(&registered->gv);
      reg->serpool = gv->serpool;
    }
    *sertype = registered;
  }
  ddsrt_mutex_unlock(&payload_lock);
  return topic;
}
