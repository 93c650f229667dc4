// `drivetap profiles`: the built-in drive profiles listed, profile files checked (TOML;
// docs/reference.md "Drive profiles").
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "app/commands.hpp"
#include "app/common.hpp"
#include "drive/profile.hpp"

namespace drivetap::app {
namespace {

// Lists the built-in drive profiles and checks the given profile files (errors: file:line: key).
int run_profiles(const std::vector<std::string>& files) {
  auto show = [](const DriveProfile& p, std::string_view where) {
    std::printf("%-8s %-44s %3zu registers  %s\n", p.id.c_str(), p.name.c_str(), p.registers.size(),
                std::string(where).c_str());
  };
  for (const BuiltinProfileText& b : builtin_profile_texts()) {
    ProfileError e;
    auto p = parse_profile(b.text, b.file, &e);
    if (!p) die(fmt::format("built-in profile {}", e.text()), 1);
    show(*p, fmt::format("(built in: {})", b.file));
  }
  for (const std::string& f : files) {
    ProfileError e;
    auto p = load_profile_file(f, &e);
    if (!p) die(e.text(), 1);
    show(*p, f);
  }
  return 0;
}

}  // namespace

Command add_profiles_command(CLI::App& app) {
  auto files = std::make_shared<std::vector<std::string>>();
  CLI::App* profiles = app.add_subcommand(
      "profiles", "List the built-in drive profiles and check profile files (TOML)");
  profiles->add_option("file", *files, "Profile files to check");
  return {profiles, [files] { return run_profiles(*files); }};
}

}  // namespace drivetap::app
