// libFuzzer target for the rosbag2 MCAP storage reader and the CDR message decoders behind it
// (issue 5: fuzz the bag/MCAP readers). Any byte string must open and iterate, or raise
// fuse::io::InputError; every message is offered to the Imu, PointCloud2 and Livox decoders, which
// must decode it or raise InputError. Never a crash or an out-of-bounds read (ASan/UBSan build).
#include <cstdint>
#include <cstdio>

#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/rosbag2_storage.hpp"
#include "fuse/rosbag/scan_conversion.hpp"
#include "fuse/rosbag/sensor_msgs.hpp"
#include "rosbag_fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using fuse::fuzz::require;
  using namespace fuse::rosbag;
  fuse::fuzz::quiet();
  const std::string path = fuse::fuzz::scratch_file(data, size, ".mcap");
  try {
    auto bag = open_mcap_storage(path);
    bag->start();
    BagMessage m;
    std::uint64_t last = 0;
    while (bag->next(m)) {
      require(m.topic < bag->topics().size());
      require(m.time_ns >= last);
      last = m.time_ns;
      const Serialization s = bag->topics()[m.topic].serialization;
      try {
        decode_imu(m.data.data(), m.data.size(), s, "fuzz");
      } catch (const fuse::io::InputError&) {
      }
      try {
        PointCounts counts;
        cloud_to_scan(decode_point_cloud2(m.data.data(), m.data.size(), s, "fuzz"), "", counts, "fuzz");
      } catch (const fuse::io::InputError&) {
      }
      try {
        PointCounts counts;
        livox_to_scan(decode_livox_custom(m.data.data(), m.data.size(), s, "fuzz"), counts);
      } catch (const fuse::io::InputError&) {
      }
    }
  } catch (const fuse::io::InputError& e) {
    require(e.what()[0] != '\0');
  }
  std::remove(path.c_str());
  return 0;
}
