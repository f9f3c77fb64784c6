#include "sim/cli/common.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "base/input_error.hpp"

namespace scalpel::cli {

fs::path bundled(const fs::path& relative) {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share/scalpelsim" / relative;
    if (fs::exists(installed)) return installed;
  }
  for (fs::path dir = fs::current_path(); !dir.empty(); dir = dir.parent_path()) {
    if (fs::exists(dir / relative)) return dir / relative;
    if (dir == dir.parent_path()) break;
  }
  return fs::path(SCALPEL_SOURCE_DIR) / relative;
}

fs::path default_scenario() {
  return bundled("config/scenarios/skin_incision.yaml");
}

std::atomic<bool> g_stop{false};
extern "C" void on_interrupt(int) {
  g_stop.store(true);
}

void print_progress(double fraction) {
  constexpr int kWidth = 40;
  const int filled = static_cast<int>(fraction * kWidth);
  std::fprintf(stderr, "\r[%.*s%*s] %3d%%", filled, "########################################",
               kWidth - filled, "", static_cast<int>(fraction * 100));
  if (fraction >= 1.0) std::fprintf(stderr, "\n");
}

void check_output_dir(const fs::path& dir, const std::string& option) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir))
    throw InputError(option, 0, 0, option,
                     "'" + dir.string() + "' is not a folder that can be created" +
                         (ec ? " (" + ec.message() + ")" : std::string()));
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw InputError(option, 0, 0, option, "cannot write in '" + dir.string() + "': " + std::strerror(errno));
}

void check_output_file(const fs::path& file, const std::string& option) {
  if (fs::is_directory(file))
    throw InputError(option, 0, 0, option, "'" + file.string() + "' is a folder, expected a file");
  const fs::path dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
  if (!fs::is_directory(dir))
    throw InputError(option, 0, 0, option, "the folder '" + dir.string() + "' does not exist");
  if (::access(dir.c_str(), W_OK | X_OK) != 0 || (fs::exists(file) && ::access(file.c_str(), W_OK) != 0))
    throw InputError(option, 0, 0, option, "cannot write '" + file.string() + "': " + std::strerror(errno));
}

}  // namespace scalpel::cli
