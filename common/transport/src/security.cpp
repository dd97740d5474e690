#include "fuse/transport/security.hpp"

#include <fstream>
#include <stdexcept>

#include "fuse/core/plain_name.hpp"
#include "fuse/transport/qos.hpp"
#include "fuse/transport/rpc.hpp"

namespace fuse::transport {

void SecurityConfig::load(ConfigNode& node) {
  node.get("enabled", enabled).get("keystore", keystore).get("identity", identity).get("private_key", private_key);
  node.check(!enabled || !keystore.empty(), "keystore", "must name the keystore directory when security is enabled");
  node.check(identity.size() <= 64 && has_only_plain_name_chars(identity), "identity",
             "must be at most 64 letters, digits, '_', '-' or '.' (empty: the process's name)");
  node.finish();
}

namespace {

void require_readable(const std::string& what, const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("transport.security: cannot read the " + what + " " + path);
}

}  // namespace

std::string security_identity(const SecurityConfig& config, const std::string& participant_name) {
  return config.identity.empty() ? participant_name : config.identity;
}

std::string security_refusal_hint(const std::string& identity, const std::string& what) {
  if (identity.empty()) return "";
  return " (security on: identity '" + identity + "' may " + what +
         " a topic only when its grant allows it; `fuse-keystore roles` lists the grants)";
}

SecurityFiles security_files(const SecurityConfig& config, const std::string& participant_name) {
  SecurityFiles f;
  f.identity = security_identity(config, participant_name);
  if (config.keystore.empty()) throw std::runtime_error("transport.security.keystore is empty");
  if (f.identity.empty() || !has_only_plain_name_chars(f.identity)) {
    throw std::runtime_error("transport.security: '" + f.identity + "' is not an identity name");
  }
  const std::string dir = config.keystore + "/identities/" + f.identity + "/";
  f.identity_ca = config.keystore + "/ca.cert.pem";
  f.permissions_ca = f.identity_ca;
  f.governance = config.keystore + "/governance.p7s";
  f.certificate = dir + "cert.pem";
  f.permissions = dir + "permissions.p7s";
  f.private_key = config.private_key.empty() ? dir + "key.pem" : config.private_key;
  require_readable("identity CA", f.identity_ca);
  require_readable("governance", f.governance);
  require_readable("certificate of identity '" + f.identity + "'", f.certificate);
  require_readable("permissions of identity '" + f.identity + "'", f.permissions);
  require_readable("private key of identity '" + f.identity + "'", f.private_key);
  return f;
}

// ---- roles -----------------------------------------------------------------------------------

namespace {

void add_server(Grant& g, const char* service) {
  g.subscribe.push_back(request_topic(service));
  g.publish.push_back(reply_topic(service));
}
void add_client(Grant& g, const char* service) {
  g.publish.push_back(request_topic(service));
  g.subscribe.push_back(reply_topic(service));
}

}  // namespace

const std::vector<std::string>& roles() {
  static const std::vector<std::string> r{"ingest", "state", "update", "map", "planner",
                                          "operator", "recorder", "monitor", "viz"};
  return r;
}

Grant role_grant(const std::string& role) {
  using namespace topics;
  // ROS 2's topics ("rt/" + the ROS name, fuse/transport/ros2.hpp): what a service publishes for
  // ROS 2 (ros2.enabled) and what fuse-ingest --ros2 reads; the names are config, so a pattern.
  const std::string ros2_topics = "rt/*";
  Grant g;
  if (role == "ingest") {
    g.publish = {kImu, kLidarScan, kHealth};
    g.subscribe = {kCorrection, kHealth, ros2_topics};
  } else if (role == "state") {
    g.publish = {kOdometry, kCorrected, kHealth, ros2_topics};
    g.subscribe = {kImu, kCorrection, kHealth};
    add_server(g, services::kQuery);
    add_server(g, services::kHistory);
  } else if (role == "update") {
    g.publish = {kCorrection, kObservation, kWorldScan, kHealth, ros2_topics};
    g.subscribe = {kLidarScan, kCorrected, kMapChunk, kMapStatus, kHealth};
    add_client(g, services::kHistory);
    add_server(g, services::kSetPose);
  } else if (role == "map") {
    g.publish = {kMapChunk, kMapStatus, kHealth, ros2_topics};
    g.subscribe = {kObservation, kHealth};
    add_server(g, services::kMapControl);
  } else if (role == "planner") {
    g.subscribe = {kOdometry};
    add_client(g, services::kQuery);
  } else if (role == "operator") {
    g.subscribe = {kMapStatus, kHealth};
    add_client(g, services::kMapControl);
    add_client(g, services::kSetPose);
  } else if (role == "recorder") {
    g.subscribe = {kImu,        kLidarScan, kOdometry,  kCorrected, kCorrection,
                   kObservation, kWorldScan, kMapChunk, kMapStatus, kHealth};
    for (const char* s : {services::kQuery, services::kHistory, services::kMapControl, services::kSetPose}) {
      g.subscribe.push_back(request_topic(s));
      g.subscribe.push_back(reply_topic(s));
    }
  } else if (role == "monitor") {
    g.subscribe = {kHealth, kCorrected, kCorrection, kMapStatus};
  } else if (role == "viz") {
    g.subscribe = {kLidarScan, kOdometry, kCorrected, kCorrection, kWorldScan, kMapChunk, kMapStatus, kHealth};
  } else {
    throw std::invalid_argument("unknown role '" + role + "'");
  }
  return g;
}

const std::vector<std::pair<std::string, std::string>>& default_identities() {
  static const std::vector<std::pair<std::string, std::string>> ids{
      {"fuse-ingest", "ingest"},   {"fuse-state", "state"},       {"fuse-update", "update"},
      {"fuse-map", "map"},         {"fuse-query", "planner"},     {"fuse-map-ctl", "operator"},
      {"fuse-record", "recorder"}, {"fuse-launch", "monitor"},    {"fuse-viz", "viz"}};
  return ids;
}

// ---- documents -------------------------------------------------------------------------------

namespace {

constexpr const char* kDomains =
    "<domains><id_range><min>0</min><max>101</max></id_range></domains>";

std::string xml_escape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string topic_list(const std::vector<std::string>& topics) {
  std::string out = "<topics>";
  for (const auto& t : topics) out += "<topic>" + xml_escape(t) + "</topic>";
  return out + "</topics>";
}

}  // namespace

std::string governance_xml() {
  // One rule per depth of '/' in a topic name: some implementations match topic expressions
  // with fnmatch(FNM_PATHNAME), where '*' stops at '/'.
  std::string topic_rules;
  for (const char* expr : {"*", "*/*", "*/*/*", "*/*/*/*"}) {
    topic_rules += std::string("<topic_rule><topic_expression>") + expr +
                   "</topic_expression>"
                   "<enable_discovery_protection>true</enable_discovery_protection>"
                   "<enable_liveliness_protection>true</enable_liveliness_protection>"
                   "<enable_read_access_control>true</enable_read_access_control>"
                   "<enable_write_access_control>true</enable_write_access_control>"
                   "<metadata_protection_kind>ENCRYPT</metadata_protection_kind>"
                   "<data_protection_kind>ENCRYPT</data_protection_kind>"
                   "</topic_rule>\n";
  }
  return std::string(
             "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
             "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
             "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd\">\n"
             "<domain_access_rules><domain_rule>") +
         kDomains +
         "\n<allow_unauthenticated_participants>false</allow_unauthenticated_participants>"
         "<enable_join_access_control>true</enable_join_access_control>"
         "<discovery_protection_kind>ENCRYPT</discovery_protection_kind>"
         "<liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>"
         "<rtps_protection_kind>NONE</rtps_protection_kind>\n"
         "<topic_access_rules>\n" +
         topic_rules + "</topic_access_rules></domain_rule></domain_access_rules></dds>\n";
}

std::string permissions_xml(const std::string& identity, const Grant& grant, const std::string& system_name,
                            const Validity& validity) {
  const std::string partitions =
      system_name.empty() ? "" : "<partitions><partition>" + xml_escape(system_name) + "</partition></partitions>";
  std::string rules;
  if (!grant.publish.empty()) rules += "<allow_rule>" + std::string(kDomains) + "<publish>" + topic_list(grant.publish) + partitions + "</publish></allow_rule>\n";
  if (!grant.subscribe.empty()) rules += "<allow_rule>" + std::string(kDomains) + "<subscribe>" + topic_list(grant.subscribe) + partitions + "</subscribe></allow_rule>\n";
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
         "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd\">\n"
         "<permissions><grant name=\"" + xml_escape(identity) + "\">\n"
         "<subject_name>CN=" + xml_escape(identity) + "</subject_name>\n"
         "<validity><not_before>" + validity.not_before + "</not_before><not_after>" + validity.not_after +
         "</not_after></validity>\n" + rules +
         "<default>DENY</default></grant></permissions></dds>\n";
}

}  // namespace fuse::transport
