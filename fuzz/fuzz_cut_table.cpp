// The state machine script's parser on the bytes as a script, then what `scalpelsim states --table`
// does with it: the reachable states listed and drawn.
#include <cstddef>
#include <cstdint>
#include <string>

#include "base/input_error.hpp"
#include "cutting/cut_table.hpp"
#include "cutting/state_graph.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  scalpel::CutTable table;
  try {
    table = scalpel::parse_cut_table(std::string(reinterpret_cast<const char*>(data), size), "fuzz.cut");
  } catch (const scalpel::InputError&) {
    return 0;  // a malformed script, reported to the user: expected
  }
  (void)scalpel::state_listing(table);
  (void)scalpel::state_dot(table);
  return 0;
}
