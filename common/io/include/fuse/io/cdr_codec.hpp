// CDR encoding of the recorded samples: fuse::ImuSample / fuse::LidarScan <-> the generated
// fuse_msgs types, serialised by Fast CDR as XCDR1 plain CDR with the 4-byte encapsulation
// header (00 01 00 00 = CDR little-endian), i.e. exactly a DDS sample of that type.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fuse/core/types.hpp"

namespace fuse::io {

/// MCAP schema names (the IDL's fully scoped type names) and encodings.
inline constexpr const char* kImuSchemaName = "fuse_msgs::ImuSample";
inline constexpr const char* kLidarScanSchemaName = "fuse_msgs::LidarScan";
inline constexpr const char* kSchemaEncoding = "omgidl";
inline constexpr const char* kMessageEncoding = "cdr";

/// Throws std::invalid_argument when the frame name or point count exceeds the IDL bounds.
std::vector<std::uint8_t> encode_imu(const ImuSample& imu, const std::string& frame);
std::vector<std::uint8_t> encode_scan(const LidarScan& scan, const std::string& frame);

/// Decodes one CDR sample after checking the schema name, the encapsulation and that the byte
/// count matches the layout the lengths inside announce (up to 3 bytes of end padding).
/// Anything else -> InputError. `frame`, when given, receives the frame name.
ImuSample decode_imu(const std::string& schema_name, const std::uint8_t* data, std::size_t size,
                     std::string* frame = nullptr);
LidarScan decode_scan(const std::string& schema_name, const std::uint8_t* data, std::size_t size,
                      std::string* frame = nullptr);

}  // namespace fuse::io
