#include "fuse/cli/cli.hpp"

#include <cmath>
#include <iostream>
#include <string>

#include "fuse/core/version.hpp"

namespace fuse::cli {

std::unique_ptr<CLI::App> make_app(const std::string& name, const std::string& description,
                                   const std::string& footer) {
  auto app = std::make_unique<CLI::App>(description, name);
  app->set_version_flag("--version", version_line(name));
  // An option given twice: the later one wins (repeatable ones, like --set, say TakeAll).
  app->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  if (!footer.empty()) app->footer(footer);
  return app;
}

namespace {
/// `name` is an option of the app or of one of its subcommands (at any depth).
bool knows_option(const CLI::App& app, const std::string& name) {
  if (app.get_option_no_throw(name) != nullptr) return true;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    if (knows_option(*sub, name)) return true;
  }
  return false;
}
}  // namespace

std::optional<int> parse(CLI::App& app, int argc, char** argv) {
  // An unknown flag is named first, before a missing required option hides it.
  for (int i = 1; i < argc; ++i) {
    const std::string token = argv[i];
    if (token.size() <= 2 || token.rfind("--", 0) != 0) continue;
    const std::string name = token.substr(0, token.find('='));
    if (!knows_option(app, name)) return usage_error(app, "unknown option " + name);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    return 0;
  } catch (const CLI::CallForVersion&) {
    std::cout << version_line(app.get_name()) << "\n";
    return 0;
  } catch (const CLI::ParseError& e) {
    return usage_error(app, e.what());
  }
  return std::nullopt;
}

int usage_error(const CLI::App& app, const std::string& message) {
  std::cerr << app.get_name() << ": " << message << "\n"
            << "Run " << app.get_name() << " --help for the options.\n";
  return kExitUsage;
}

TransportFlags::TransportFlags(CLI::App& app) {
  app.add_option("--set", sets_, "override a config value (repeatable), e.g. --set transport.domain_id=7")
      ->type_name("KEY=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app.add_option("--domain", domain_, "DDS domain id: --set transport.domain_id=N")->type_name("N");
  app.add_option("--vendor", vendor_, "DDS implementation, fastdds or cyclonedds: --set transport.vendor=V")
      ->type_name("V")
      ->check(CLI::IsMember({"fastdds", "cyclonedds"}));
  app.add_option("--system", system_, "the system's name, its DDS partition: --set transport.system_name=NAME")
      ->type_name("NAME");
}

std::vector<std::string> TransportFlags::shorthands() const {
  std::vector<std::string> out;
  if (domain_) out.push_back("transport.domain_id=" + std::to_string(*domain_));
  if (!vendor_.empty()) out.push_back("transport.vendor=" + vendor_);
  if (system_) out.push_back("transport.system_name=\"" + *system_ + "\"");  // quoted: a string whatever it looks like
  return out;
}

std::vector<std::string> TransportFlags::overrides() const {
  std::vector<std::string> out = shorthands();
  out.insert(out.end(), sets_.begin(), sets_.end());
  return out;
}

const CLI::Validator& finite_number() {
  static const CLI::Validator validator(
      [](std::string& text) {
        double v = 0.0;
        if (CLI::detail::lexical_cast(text, v) && std::isfinite(v)) return std::string();
        return "'" + text + "' is not a finite number";
      },
      "", "FINITE");
  return validator;
}

}  // namespace fuse::cli
