// fuse-keystore: creates the DDS Security keystore of a FUSE-SLAM system (security.hpp has the
// layout): a CA, the signed governance, and per identity a key, a certificate and a signed grant.
//
//   fuse-keystore init DIR [--system NAME] [--days N]          CA, governance, default identities
//   fuse-keystore add-identity DIR NAME --role ROLE [--days N] one more identity (e.g. a planner)
//   fuse-keystore permissions DIR NAME --role ROLE [--days N]  re-sign an identity's grant
//   fuse-keystore roles                                        what each role may publish and read
//
// Keys are EC P-256, made by the openssl command (nothing is sent anywhere); private keys are
// created 0600 under umask 077. The system name (init --system) is kept in DIR/system_name and
// written into every grant as its only partition, so an identity of one system cannot join
// another. Exit codes: 0 done, 1 openssl or the file system failed, 2 usage (e.g. an existing
// keystore or identity, an unknown role).
#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "fuse/cli/cli.hpp"
#include "fuse/core/plain_name.hpp"
#include "fuse/transport/security.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
namespace tr = fuse::transport;
constexpr int kExitDone = 0, kExitFailed = 1, kExitUsage = 2;

struct Failure : std::runtime_error {
  using std::runtime_error::runtime_error;
};
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Runs openssl with `args` (no shell); its stderr is shown only when it fails.
void openssl(const std::vector<std::string>& args) {
  std::vector<std::string> all{"openssl"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const fs::path err = fs::temp_directory_path() / ("fuse-keystore-" + std::to_string(::getpid()) + ".err");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, "openssl", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw Failure("cannot run openssl (is the openssl package installed?)");
  int status = 0;
  waitpid(pid, &status, 0);
  std::ifstream in(err);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::remove(err);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw Failure("openssl " + args.front() + " failed: " + text);
  }
}

void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  if (!out.flush()) throw Failure("cannot write " + path.string());
}

std::string utc(std::chrono::system_clock::time_point t) {
  const std::time_t s = std::chrono::system_clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&s, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

struct Keystore {
  fs::path dir;
  int days = 3650;

  fs::path ca_cert() const { return dir / "ca.cert.pem"; }
  fs::path ca_key() const { return dir / "private" / "ca.key.pem"; }
  fs::path identity_dir(const std::string& name) const { return dir / "identities" / name; }
  std::string system_name() const {
    std::ifstream in(dir / "system_name");
    std::string s;
    std::getline(in, s);
    return s;
  }

  /// S/MIME-signs `xml` (clear text, detached signature) with the CA into `out`.
  void sign(const fs::path& xml, const fs::path& out) const {
    openssl({"smime", "-sign", "-text", "-in", xml, "-out", out, "-signer", ca_cert(), "-inkey", ca_key()});
  }

  void init(const std::string& system) {
    if (fs::exists(ca_cert())) throw UsageError(dir.string() + " is already a keystore (it has ca.cert.pem)");
    fs::create_directories(dir / "private");
    fs::create_directories(dir / "identities");
    fs::permissions(dir / "private", fs::perms::owner_all, fs::perm_options::replace);
    write_file(dir / "system_name", system + "\n");
    openssl({"req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes", "-sha256",
             "-days", std::to_string(days), "-subj", "/CN=FUSE-SLAM keystore CA", "-keyout", ca_key(), "-out",
             ca_cert()});
    write_file(dir / "governance.xml", tr::governance_xml());
    sign(dir / "governance.xml", dir / "governance.p7s");
    for (const auto& [name, role] : tr::default_identities()) add_identity(name, role);
  }

  void add_identity(const std::string& name, const std::string& role) {
    require_keystore();
    const fs::path d = identity_dir(name);
    if (fs::exists(d / "cert.pem")) throw UsageError("identity '" + name + "' already exists in " + dir.string());
    fs::create_directories(d);
    const fs::path csr = d / "cert.csr";
    openssl({"req", "-new", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes", "-sha256", "-subj",
             "/CN=" + name, "-keyout", d / "key.pem", "-out", csr});
    openssl({"x509", "-req", "-in", csr, "-CA", ca_cert(), "-CAkey", ca_key(), "-CAcreateserial", "-CAserial",
             dir / "private" / "ca.srl", "-sha256", "-days", std::to_string(days), "-out", d / "cert.pem"});
    fs::remove(csr);
    fs::permissions(d / "key.pem", fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
    permissions(name, role);
  }

  void permissions(const std::string& name, const std::string& role) {
    require_keystore();
    const fs::path d = identity_dir(name);
    if (!fs::exists(d / "cert.pem")) throw UsageError("no identity '" + name + "' in " + dir.string());
    const auto now = std::chrono::system_clock::now();
    const tr::Validity validity{utc(now - std::chrono::hours(1)), utc(now + std::chrono::hours(24) * days)};
    write_file(d / "permissions.xml", tr::permissions_xml(name, tr::role_grant(role), system_name(), validity));
    write_file(d / "role", role + "\n");
    sign(d / "permissions.xml", d / "permissions.p7s");
  }

  void require_keystore() const {
    if (!fs::exists(ca_cert()) || !fs::exists(ca_key())) {
      throw UsageError(dir.string() + " is not a keystore with its CA key (run fuse-keystore init first)");
    }
  }
};

void print_roles() {
  for (const auto& role : tr::roles()) {
    const tr::Grant g = tr::role_grant(role);
    std::cout << role << "\n  publish:";
    for (const auto& t : g.publish) std::cout << " " << t;
    std::cout << "\n  subscribe:";
    for (const auto& t : g.subscribe) std::cout << " " << t;
    std::cout << "\n";
  }
  std::cout << "default identities (init):";
  for (const auto& [name, role] : tr::default_identities()) std::cout << " " << name << "=" << role;
  std::cout << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  auto app = fuse::cli::make_app("fuse-keystore", "Create the DDS Security keystore of a FUSE-SLAM system",
                                 "Layout and roles: docs/architecture.md, \"DDS Security\".");
  app->require_subcommand(1);
  Keystore ks;
  std::string system, name, role;
  std::string dir;
  auto* init = app->add_subcommand("init", "create the CA, the signed governance and the default identities");
  init->add_option("DIR", dir, "keystore directory (created)")->required();
  init->add_option("--system", system, "system name: the only DDS partition the grants allow (transport.system_name)");
  auto* add = app->add_subcommand("add-identity", "create one more identity with a role's grant");
  add->add_option("DIR", dir, "keystore directory")->required();
  add->add_option("NAME", name, "identity name (certificate CN; transport.security.identity)")->required();
  add->add_option("--role", role, "role: ingest|state|update|map|planner|operator|recorder|monitor|viz")->required();
  auto* perm = app->add_subcommand("permissions", "re-sign the grant of an existing identity for a role");
  perm->add_option("DIR", dir, "keystore directory")->required();
  perm->add_option("NAME", name, "identity name")->required();
  perm->add_option("--role", role, "role")->required();
  for (auto* sub : {init, add, perm}) {
    sub->add_option("--days", ks.days, "validity of certificates and grants in days")->check(CLI::Range(1, 36500));
  }
  app->add_subcommand("roles", "print what each role may publish and subscribe to");
  if (const std::optional<int> code = fuse::cli::parse(*app, argc, argv)) return *code;

  try {
    if (app->got_subcommand("roles")) {
      print_roles();
      return kExitDone;
    }
    ks.dir = dir;
    ::umask(077);  // private keys and the CA serial are never readable by others, even briefly
    if (!system.empty() && (system.size() > 64 || !fuse::has_only_plain_name_chars(system))) {
      return fuse::cli::usage_error(*app, "--system: must be at most 64 letters, digits, '_', '-' or '.'");
    }
    if (!name.empty() && (name.size() > 64 || !fuse::has_only_plain_name_chars(name))) {
      return fuse::cli::usage_error(*app, "NAME: must be at most 64 letters, digits, '_', '-' or '.'");
    }
    if (!role.empty()) {
      const auto& r = tr::roles();
      if (std::find(r.begin(), r.end(), role) == r.end()) {
        return fuse::cli::usage_error(*app, "--role: unknown role '" + role + "' (fuse-keystore roles lists them)");
      }
    }
    if (app->got_subcommand(init)) ks.init(system);
    if (app->got_subcommand(add)) ks.add_identity(name, role);
    if (app->got_subcommand(perm)) ks.permissions(name, role);
    // Public parts (CA certificate, signed documents, certificates) readable by the services.
    for (const auto& entry : fs::recursive_directory_iterator(ks.dir)) {
      const auto file = entry.path().filename().string();
      const bool secret = entry.path().parent_path().filename() == "private" || file == "key.pem" || file == "private";
      if (secret) continue;
      const auto mode = entry.is_directory() ? fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                                   fs::perms::others_read | fs::perms::others_exec
                                             : fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                                                   fs::perms::others_read;
      fs::permissions(entry.path(), mode, fs::perm_options::replace);
    }
    fs::permissions(ks.dir, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                fs::perms::others_read | fs::perms::others_exec,
                    fs::perm_options::replace);
    return kExitDone;
  } catch (const UsageError& e) {
    std::cerr << "fuse-keystore: " << e.what() << "\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << "fuse-keystore: " << e.what() << "\n";
    return kExitFailed;
  }
}
