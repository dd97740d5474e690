// libFuzzer target for the ROS 1 bag v2.0 reader (issue 5: fuzz the bag readers). Any byte
// string must either open and iterate to the end (messages in non-decreasing time order, each
// with a defined connection, the count equal to the index's) or raise fuse::io::InputError;
// never a crash, an out-of-bounds read (ASan/UBSan build) or an unbounded allocation.
#include <cstdint>
#include <cstdio>

#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/ros1_bag_reader.hpp"
#include "rosbag_fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using fuse::fuzz::require;
  fuse::fuzz::quiet();
  const std::string path = fuse::fuzz::scratch_file(data, size, ".bag");
  try {
    fuse::rosbag::Ros1BagReader bag(path);
    bag.start();
    fuse::rosbag::Ros1Message m;
    std::uint64_t last = 0, n = 0;
    while (bag.next(m)) {
      require(m.connection != nullptr && bag.connections().count(m.connection->id) == 1);
      require(m.time_ns >= last);
      last = m.time_ns;
      ++n;
    }
    require(bag.salvage_mode() == false);  // salvage mode ends in InputError, never in false
    require(n == bag.message_count());
  } catch (const fuse::io::InputError& e) {
    require(e.what()[0] != '\0');
  }
  std::remove(path.c_str());
  return 0;
}
