// The commands of the scalpelsim program, one function each (sim/main.cpp reads the command line):
// those on recorded sessions and files in session_commands.cpp, those on devices and the window in
// device_commands.cpp. Each returns the program's exit code (sim/cli/common.hpp) or throws.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "sim/log_generator.hpp"

namespace scalpel::cli {

struct ImageArgs {
  bool images = false;
  std::size_t every = 0;
  std::string size = "1200x900";
};

int cmd_replay(const std::string& scenario_arg, const std::string& log_arg, const std::string& out,
               bool no_progress, bool strict, std::size_t mesh_every, bool exports,
               const ImageArgs& image_args);
int cmd_check(const std::string& check_path, const std::string& out, const std::string& junit);
int cmd_report(const std::vector<std::string>& sessions, const std::string& out);
int cmd_validate(const std::string& path, bool strict);
int cmd_states(const std::string& table_path, bool dot);
int cmd_inspect(const std::string& path, bool as_json);
int cmd_make_log(const std::string& scenario_path, const std::string& out, const IncisionMotion& motion);
int cmd_make_volume(const std::string& out);

int cmd_devices(const std::string& profiles_dir, bool all);
struct RecordArgs {
  std::string scenario, device, profiles_dir, serial, path, replay_log, out;
  double duration = 0.0, wait = 0.0;
  bool unpaced = false;
};
int cmd_record(const RecordArgs& a);
struct TrainArgs {
  std::string scenario, device = "pointer", replay_log, record, serial, path, profiles_dir, size = "1024x640",
                        screenshot;
  double speed = 1.0, close_after = 0.0;
  bool transparent = false, wireframe = false, close_at_end = false;
};

int cmd_train(const TrainArgs& a);

}  // namespace scalpel::cli
