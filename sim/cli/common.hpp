// What the commands of the scalpelsim program share: where the bundled files are, the exit codes,
// Ctrl-C, the progress bar and the checks of an output before a command runs.
#pragma once

#include <atomic>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace scalpel::cli {

namespace fs = std::filesystem;

// Exit codes (README): 0 done, 1 mesh invariants broken, 2 bad input or usage, 3 any other error,
// 4 no graphics (built without the window, or no OpenGL 3.3 context), 5 warnings under --strict.
inline constexpr int kExitUsage = 2;
inline constexpr int kExitNoGraphics = 4;
inline constexpr int kExitStrict = 5;
inline constexpr int kExitExpectations = 6;  // `check`: a session did not show what its check file expects
inline constexpr int kExitSimulationFailed = 7;  // the run ended, but the tissue solve met NaN or infinity
inline constexpr int kExitNoDevice = 8;  // `record`: no device attached or accessible, nothing recorded

// A bundled file: in an installed layout beside the executable (PREFIX/bin/scalpelsim and
// PREFIX/share/scalpelsim/...), else from the working directory upwards, else in the source tree
// the program was built from.
[[nodiscard]] fs::path bundled(const fs::path& relative);
[[nodiscard]] fs::path default_scenario();

// Set by SIGINT and SIGTERM once on_interrupt is their handler: the recording or window stops.
extern std::atomic<bool> g_stop;
extern "C" void on_interrupt(int);

// A progress bar on stderr, `fraction` in [0, 1].
void print_progress(double fraction);

// An output folder the command will write, checked before anything runs: created if missing, and
// refused (bad input) when it is a file or not writable.
void check_output_dir(const fs::path& dir, const std::string& option);
// An output file: its folder must exist and be writable, and it must not be a folder.
void check_output_file(const fs::path& file, const std::string& option);

// A command that needs OpenGL in a build without it.
struct NoGraphics : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace scalpel::cli
