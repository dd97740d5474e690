// The command line of every FUSE-SLAM binary: a CLI11 app that answers --help and --version
// (exit 0, on stdout) and turns a usage error into exit code 2 with the flag named on stderr.
// Include only in a binary's main or argument file (CLI11 is a large header).
#pragma once

#include <CLI/CLI.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace fuse::cli {

inline constexpr int kExitUsage = 2;

/// An app named `name` (the binary) with --version ("NAME (FUSE-SLAM) VERSION").
std::unique_ptr<CLI::App> make_app(const std::string& name, const std::string& description,
                                   const std::string& footer = "");

/// Parses argv. std::nullopt: go on. Otherwise the exit code to end with: 0 after --help or
/// --version (printed), kExitUsage after a usage error ("NAME: what, naming the flag" on stderr).
std::optional<int> parse(CLI::App& app, int argc, char** argv);

/// --set KEY=VALUE (repeatable), --domain N, --vendor V and --system NAME: the transport options of every binary
/// that talks DDS. Construct before parsing (it adds the options to `app`), read after.
class TransportFlags {
 public:
  explicit TransportFlags(CLI::App& app);
  /// The --set values, in order.
  const std::vector<std::string>& sets() const { return sets_; }
  /// --domain, --vendor and --system as the overrides transport.domain_id=N, transport.vendor=V
  /// and transport.system_name=NAME.
  std::vector<std::string> shorthands() const;
  /// shorthands() then sets(): a --set of the same key wins.
  std::vector<std::string> overrides() const;

 private:
  std::vector<std::string> sets_;
  std::optional<int> domain_;
  std::string vendor_;
  std::optional<std::string> system_;
};

/// Checks that an option's value is a finite number (CLI11 reads "inf" and "nan" as numbers).
const CLI::Validator& finite_number();

/// A usage error found after parsing (a value that does not check): printed as parse() does.
int usage_error(const CLI::App& app, const std::string& message);

}  // namespace fuse::cli
