#include "fuse/io/sensor_source.hpp"

#include <filesystem>

#include "fuse/io/mcap_source.hpp"
#include "fuse/io/seqdir_source.hpp"

namespace fuse::io {

std::unique_ptr<SensorSource> open_sensor_source(const std::string& path, const TimeGateConfig& clock) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status)) throw InputError("'" + path + "': no such file or directory");
  if (fs::is_directory(status)) return std::make_unique<SeqdirSource>(path, clock);
  if (fs::is_regular_file(status)) return std::make_unique<McapSource>(path, clock);
  throw InputError("'" + path + "' is neither an MCAP file nor a sequence directory");
}

}  // namespace fuse::io
