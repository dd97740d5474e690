// IDL names of the generated wire types (the DDS type names both vendors register).
#pragma once

#include "fuse_msgs.h"
#include "fuse/transport/typed.hpp"

namespace fuse::transport {

#define FUSE_TRANSPORT_MSG(T) \
  template <>                 \
  struct MsgName<fuse_msgs::T> { static constexpr const char* value = "fuse_msgs::" #T; };
FUSE_TRANSPORT_MSG(ImuSample)
FUSE_TRANSPORT_MSG(LidarScan)
FUSE_TRANSPORT_MSG(StateEstimate)
FUSE_TRANSPORT_MSG(Correction)
FUSE_TRANSPORT_MSG(MapObservation)
FUSE_TRANSPORT_MSG(WorldScan)
FUSE_TRANSPORT_MSG(MapChunk)
FUSE_TRANSPORT_MSG(MapStatus)
FUSE_TRANSPORT_MSG(Health)
FUSE_TRANSPORT_MSG(QueryRequest)
FUSE_TRANSPORT_MSG(QueryReply)
FUSE_TRANSPORT_MSG(HistoryRequest)
FUSE_TRANSPORT_MSG(HistoryReply)
FUSE_TRANSPORT_MSG(MapControlRequest)
FUSE_TRANSPORT_MSG(MapControlReply)
FUSE_TRANSPORT_MSG(SetPoseRequest)
FUSE_TRANSPORT_MSG(SetPoseReply)
#undef FUSE_TRANSPORT_MSG

}  // namespace fuse::transport
