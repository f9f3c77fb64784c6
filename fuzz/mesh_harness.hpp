// What `scalpelsim inspect` does with a mesh file a user gives it, for the mesh readers' harnesses:
// the mesh read from the bytes, then its summary and the invariant checks.
#pragma once

#include <string>

#include "base/input_error.hpp"
#include "mesh/io/mesh_io.hpp"
#include "mesh/quality.hpp"
#include "mesh/validate.hpp"

namespace scalpel::fuzz {

template <class Read>
void inspect_mesh(Read read) {
  TetMesh mesh;
  try {
    mesh = read();
  } catch (const InputError&) {
    return;  // a malformed file, reported to the user: expected
  }
  const MeshSummary s = summarize(mesh);
  (void)validate(mesh, {.reference_volume = s.rest_volume});
}

}  // namespace scalpel::fuzz
