// DDS Security (OMG DDS Security 1.1, builtin plugins) for both backends: who may join the bus
// and what each identity may publish and subscribe to.
//
// A keystore (made by fuse-keystore) is a directory:
//   ca.cert.pem                      identity CA and permissions CA (one self-signed EC CA)
//   private/ca.key.pem               the CA's key (0600), needed only to add identities
//   governance.xml, governance.p7s   the domain rule, signed by the CA
//   identities/NAME/cert.pem         the identity's certificate, subject "CN=NAME"
//   identities/NAME/key.pem          its private key (0600)
//   identities/NAME/permissions.xml, permissions.p7s   its grant, signed by the CA
// A process joins as identity `security.identity` (empty: its participant name, e.g.
// "fuse-state"), so every service and client tool has its own certificate and grant.
//
// Nothing here includes a DDS header: the backends turn SecurityFiles into their properties.
#pragma once

#include <string>
#include <vector>

#include "fuse/core/config.hpp"

namespace fuse::transport {

struct SecurityConfig {
  /// Off: plain RTPS (development). On: authentication (PKI-DH), access control and AES-GCM
  /// encryption; a participant without a valid certificate and grant sees nothing of FUSE.
  bool enabled = false;
  std::string keystore;     ///< directory made by `fuse-keystore init` (required when enabled)
  std::string identity;     ///< identity to join as; empty: the process's participant name
  /// The identity's private key; empty: <keystore>/identities/<identity>/key.pem. The systemd
  /// units pass a copy only the service can read (LoadCredential=, %d/dds-key.pem).
  std::string private_key;
  void load(ConfigNode& node);
};

/// The files a secured participant is configured with (absolute or as given, never empty).
struct SecurityFiles {
  std::string identity;  ///< the identity name (subject CN of its certificate)
  std::string identity_ca;
  std::string certificate;
  std::string private_key;
  std::string permissions_ca;
  std::string governance;   ///< signed (S/MIME) governance document
  std::string permissions;  ///< signed (S/MIME) permissions document
};

/// The identity a process joins as: `config.identity`, or its participant name when empty.
std::string security_identity(const SecurityConfig& config, const std::string& participant_name);

/// "" when security is off (identity empty); otherwise " (security on: identity 'X' may not
/// <what> this topic unless its grant says so; fuse-keystore roles)", for a refused endpoint.
std::string security_refusal_hint(const std::string& identity, const std::string& what);

/// The files for joining as `config.identity` (or `participant_name` when that is empty).
/// Throws std::runtime_error naming the first file that is missing or unreadable.
SecurityFiles security_files(const SecurityConfig& config, const std::string& participant_name);

// ---- roles and the documents fuse-keystore signs -------------------------------------------

/// What an identity may do: DDS topic names it may publish (write) and subscribe to (read).
/// RPCs are their two topics: a client publishes "rpc/S/request" and reads "rpc/S/reply".
struct Grant {
  std::vector<std::string> publish;
  std::vector<std::string> subscribe;
};

/// The roles, in a stable order: ingest, state, update, map (the services), planner (query
/// and odometry), operator (map control, set-pose), recorder (reads everything), monitor (fuse-launch:
/// health and progress), viz (reads state, map and scans; no control, no RPC).
const std::vector<std::string>& roles();

/// The grant of a role; std::invalid_argument for an unknown role.
Grant role_grant(const std::string& role);

/// The identities `fuse-keystore init` creates, as {identity, role}: one per service and one
/// per client tool, each named as the process's participant.
const std::vector<std::pair<std::string, std::string>>& default_identities();

/// Validity of a permissions grant, as ISO 8601 UTC times ("2026-11-27T00:00:00").
struct Validity {
  std::string not_before;
  std::string not_after;
};

/// Governance for domains 0..101: no unauthenticated participant, join and per-topic
/// read/write access control, discovery, liveliness, metadata and data all ENCRYPTed.
std::string governance_xml();

/// The permissions document of `identity` (certificate subject "CN=identity"): `grant` on
/// domains 0..101 in partition `system_name` (empty: the default partition only), deny the rest.
std::string permissions_xml(const std::string& identity, const Grant& grant, const std::string& system_name,
                            const Validity& validity);

}  // namespace fuse::transport
