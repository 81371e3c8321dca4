#pragma once
// Which unit of a device's truth a published sample is (chaos_check.cpp): a LIDAR scan by its
// first packet's arrival, a flagged camera frame by its frame id, anything else by its stamp.
// Each returns nullptr where no unit qualifies; the caller decides what that means.
#include <cstdint>
#include <vector>

#include "chaos_units.hpp"

namespace sensor_rig::rig::chaos {

// The unit whose first part was sent last before the sample's first packet arrived, within
// `tolerance`; of units sent at one host time (a clock step back), the first after `after_unit`
// (the unit of the sample's previous seq: scans are published in order). nullptr: no arrival
// in the record, or no unit sent within the tolerance before it.
// `doubled_arrival`: the arrival lies in host time a clock step back made happen twice.
UnitTruth* unit_by_arrival(std::vector<UnitTruth>& units, const SampleRecord& s, Nanos tolerance,
                           const std::vector<HeldInterval>& held, std::int64_t after_unit, bool doubled_arrival = false);

// The unit with the sample's frame id (a camera's 16-bit GVSP block id, a V4L2 sequence: the low
// 16 bits of the truth's unit) nearest its first packet's arrival, within 1 s, or within 1 s of
// one of the campaign's host clock steps (`host_steps`, their sizes) from it: the truth's
// acquisition and the arrival are host times, and a frame made just before a -2 s step was undone
// arrived "2.01 s" after it (matched by its slewed stamp to a frame 31 s later: "published twice",
// rig chaos seed 9 with drawn parameters). Not within the largest step whatever the distance: a
// camera's ids begin again after a restart, and a frame 20 s after another of its id took that
// one's unit (seed 4: "published twice (seq 248 and 248)"). Ids repeat after 65,535 frames (109 min
// at 10 Hz), or after a restart: the nearest wins.
UnitTruth* unit_by_frame_id(std::vector<UnitTruth>& units, const SampleRecord& s, const std::vector<Nanos>& host_steps = {});

// The one unit whose send brackets `t`: its acquisition (the clock read just before the send) at or
// before it, its part's send return (`last_tx`) at or after it. A CAN frame's sample is stamped by
// the receiver's kernel at the send's instant, inside that bracket however long the sender was
// descheduled around it; nearest-acquisition gave a frame sent 5 ms late the next frame's unit
// ("published twice", CI, dbw campaign seed 4). nullptr: no bracket or two (a record without the
// return, or time a clock step back made happen twice).
UnitTruth* unit_by_send(std::vector<UnitTruth>& units, Nanos t);

// The unit whose acquisition is nearest `t`, within `tolerance` (units in acquisition order).
UnitTruth* unit_nearest(std::vector<UnitTruth>& units, Nanos t, Nanos tolerance);

// The same, but where the nearest unit has its sample already, the nearest one without a sample
// whose acquisition lies within `burst` of it: units delivered in one burst (the CAN frames a
// host.network_delay held, leaving together behind the last held one when it ends) have acquisitions
// (their receive times) microseconds apart, closer than the rig's stamps of them are to the sends;
// nearest alone gave one unit several samples ("published twice") and its neighbours none.
UnitTruth* unit_nearest_free(std::vector<UnitTruth>& units, Nanos t, Nanos tolerance, Nanos burst);

}  // namespace sensor_rig::rig::chaos
