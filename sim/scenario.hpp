// Scenario: the YAML file an instructor writes to set up an exercise (docs/formats.md). The schema,
// with every key, unit, range and default, is documented in config/scenarios/README.md.
//
// Every problem in the file (bad YAML, an unknown key, a wrong type, a missing required key, a value
// out of range) is an InputError naming the file, the 1-based line and column, and the key path,
// e.g. "skin.yaml:14:16: materials.dermis.poisson: 0.5 is out of range, expected -1 < poisson < 0.5".
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "base/source_location.hpp"
#include "fem/element.hpp"
#include "fem/material.hpp"
#include "mesh/generators.hpp"
#include "mesh/mesh.hpp"
#include "sim/snapshot.hpp"

namespace scalpel {

// The most tetrahedra a scenario's mesh may have, generated or read from a file: a replay holds
// about 2.2 kB per tetrahedron (mesh, cutter and tissue), so the limit keeps one within about 4.4 GB;
// beyond it a replay would run out of memory minutes in instead of being refused before it starts.
inline constexpr long long kMaxTetrahedra = 2'000'000;

enum class MeshKind { Box, Slab, File };

struct MeshSource {
  MeshKind kind = MeshKind::Slab;
  BoxSpec box;                        // kind == Box; box.region is 0
  std::string box_region = "tissue";  // kind == Box: the name of its single region
  SlabSpec slab;                      // kind == Slab; region id = layer index
  std::filesystem::path file;         // kind == File: .msh, .node, .ele or .vtu, resolved
  SourceLocation where;               // of the `mesh` key
};

// The material of one region, as named under `materials`.
struct RegionMaterial {
  std::string region;
  Material material;
  SourceLocation where;  // of the region's key
};

// The tissue model kind is fem's TissueKind (corotational or mass_spring).

struct TissueSection {
  TissueKind model = TissueKind::Corotational;
  // `model: rigid`: the tissue does not move and is never stepped; cuts open no gap. For cutting
  // volume data and sculpting (paper sections 7.1 and 7.3); materials are then optional.
  bool rigid = false;
  double rate = 60.0;                    // [Hz] tissue steps per second, time step 1 / rate
  double cg_tolerance = 1e-6;            // [-] CG stops at |r| <= tolerance * |b|
  int cg_max_iterations = 200;           // CG iterations per step
  int local_rings = 6;                   // rings around a cut solved first (TissueSettings), 0: off
  int threads = 2;                       // worker threads of the tissue step
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);  // [m/s^2]
  bool volume_springs = true;  // mass_spring only: each element's volume term (false: edge springs alone)
};

// An axis-aligned face of the mesh's rest bounding box.
enum class Side { XMin, XMax, YMin, YMax, ZMin, ZMax };

// One boundary condition: the nodes on a side of the mesh, or inside a box, are fixed in place.
struct FixedSelector {
  enum class Kind { Side, Box };
  Kind kind = Kind::Side;
  Side side = Side::ZMin;   // kind == Side
  Vec3 min = Vec3::Zero();  // kind == Box [m], rest positions, bounds included
  Vec3 max = Vec3::Zero();
  SourceLocation where;
};

// How the blade meets the tissue surface (docs/contact.md).
enum class ToolContactKind {
  None,    // it cuts whatever it meets
  Indent,  // it presses the surface in until the force under its edge or tip passes the region's
           // puncture_force, and cuts from then on (sim/indentation.hpp)
};

// The scalpel blade is the segment from its back point to its tip in the tool frame (docs/state_machine.md);
// only its front (the side it moves towards) is sharp.
struct ToolSettings {
  std::string name = "scalpel";
  Vec3 blade_back = Vec3(0.0, 0.0, 0.02);  // [m] tool frame
  Vec3 blade_tip = Vec3::Zero();           // [m] tool frame
  // Unit direction the sharp edge faces, tool frame, across the blade; none: the blade's motion
  // (every crossing is forward, Eq. 1).
  std::optional<Vec3> blade_edge;
  // The blade's flats and the handle (sim/tool_body.hpp), pushed against with contact: indent.
  double blade_width = 0.0;    // [m] from the edge to the spine, across the blade; 0: no flats
  double handle_radius = 0.0;  // [m] 0: no handle
  double handle_length = 0.0;  // [m] from the blade's back point, along the blade away from the tip
  // Force per length of blade inside the tissue, against the blade's motion [N/m]: the hand feels
  // it and the tissue is dragged by it (sim/simulation.hpp).
  double cutting_resistance = 350.0;
  ToolContactKind contact = ToolContactKind::None;
};

enum class DeviceKind { Mock, Hid, Libusb, Mouse };

// Device space -> world: p_world = rotation * (scale * p_device) + offset; orientations are
// composed with `rotation` (q_world = rotation * q_device).
struct DeviceMapping {
  double scale = 1.0;                                            // [-]
  Vec3 offset = Vec3::Zero();                                    // [m]
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // unit
};

struct DeviceSettings {
  DeviceKind kind = DeviceKind::Mock;
  std::string profile;  // device profile name; empty: the kind's default
  DeviceMapping mapping;
  double rate = 1000.0;       // [Hz] haptic loop
  int queue_capacity = 4096;  // tool samples between the haptic and the simulation thread
};

struct SimulationSettings {
  double visual_rate = 60.0;       // [Hz] simulation frames per second
  std::optional<double> duration;  // [s] stop after this long; none: when the input ends
  // Recursive continuation of cuts that reach earlier cuts (paper section 6): the deepest level;
  // 0: off, an earlier cut keeps its one-level subdivision (CutOptions::max_recursion_depth).
  int cut_recursion_depth = 8;
};

// One target incision, on the tissue surface in rest coordinates.
struct Incision {
  std::vector<Vec3> path;    // [m] polyline, >= 2 points
  double tolerance = 0.002;  // [m] allowed lateral distance of the cut from the path
  double depth_min = 0.0;    // [m] accepted depth of the cut below the tissue surface
  double depth_max = 0.0;    // [m]
  SourceLocation where;
};

// What the score requires to pass (docs/scoring.md, where each one is defined).
struct PassThresholds {
  double score = 70.0;         // [0, 100] at least
  double coverage = 0.95;      // [-] of each target's length cut, at least
  double depth_in_band = 0.9;  // [-] of each incision's length cut within its depth band, at least
  double bevel_deg = 15.0;     // [deg] mean tilt of the blade's plane from the surface normal, at most
  int strokes = 2;             // per incision, at most
  double economy = 2.0;        // tool path in the tissue over the targets' length, at most
  std::optional<double> time;  // [s] with the blade in the tissue, at most; none: not a condition
  double force_min = 0.0;      // [N] band of the force on the hand while cutting
  double force_max = 5.0;      // [N]
  double force_in_band = 0.9;  // [-] of the time spent cutting, at least
  double collateral = 0.10;    // [-] of the cut area outside every target's band, at most
};

// The exercise, used for scoring: one or more incisions, regions the blade must not cut into, and the
// thresholds to pass.
struct Task {
  std::vector<Incision> incisions;  // in the order they are to be made
  std::vector<std::string> protected_regions;
  PassThresholds pass;
  // false: the incisions only guide the log generator and the picture (sculpting, volume data);
  // no score is kept.
  bool scored = true;
  SourceLocation where;
  SourceLocation protected_where;  // of the `protected` key
};

// A scalar volume attached to the mesh (paper section 7.1): sampled onto the nodes at load as the
// mesh field `field`, carried through every cut, written as point data and shown through a colour map.
struct VolumeSource {
  std::filesystem::path file;  // .nrrd or .nhdr, resolved
  std::string field = "value";
  // [m] where the grid's first and last samples lie; none: the file's own geometry.
  std::optional<std::array<Vec3, 2>> box;
  // The values the colour map's ends stand for; none: the volume's smallest and largest.
  std::optional<std::array<double, 2>> range;
  ColourMap colour_map = ColourMap::Viridis;
  SourceLocation where;  // of the `volume` key
};

// A rigid move of a piece at a time of the session (volume data, paper section 7.1): the piece that
// holds `point` (its tetrahedra, and all joined to them by a node), turned by `rotation` about its
// centroid, then shifted by `translation`; or, with `undo`, the last move still standing taken back.
// Only with rigid tissue.
// What a scenario's move does to a piece (volume data and sculpting, paper sections 7.1 and 7.3).
enum class PieceAction : std::uint8_t {
  Move,    // turns and shifts it
  Undo,    // takes back the last move still standing
  Delete,  // removes it from the mesh
};

struct PieceMove {
  double at = 0.0;  // [s] session time: applied at the end of the first frame at or after it
  PieceAction action = PieceAction::Move;
  Vec3 point = Vec3::Zero();        // [m] where the piece is now (Move, Delete)
  Vec3 translation = Vec3::Zero();  // [m]
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  SourceLocation where;
};

struct Scenario {
  std::filesystem::path file;  // the scenario file, as given
  std::string name;
  std::string description;
  MeshSource mesh;
  std::vector<RegionMaterial> materials;  // file order
  SourceLocation materials_where;         // of the `materials` key
  TissueSection tissue;
  std::vector<FixedSelector> fixed;
  ToolSettings tool;
  DeviceSettings device;
  SimulationSettings simulation;
  std::optional<Task> task;
  std::optional<VolumeSource> volume;
  std::vector<PieceMove> moves;              // in time order
  std::optional<std::filesystem::path> log;  // default pose log, resolved
};

// Reads and checks a scenario file; relative paths in it are resolved against its folder.
[[nodiscard]] Scenario load_scenario(const std::filesystem::path& path);
// The same from text: `file_name` names it in errors, `base_dir` resolves relative paths.
[[nodiscard]] Scenario parse_scenario(const std::string& text, const std::string& file_name,
                                      const std::filesystem::path& base_dir);

// The mesh of a generated scenario (mesh.kind Box or Slab) via make_box / make_slab.
// Throws std::logic_error for a file mesh.
[[nodiscard]] TetMesh build_generated_mesh(const Scenario& scenario);

// Region name -> region id.
using RegionIds = std::map<std::string, int>;

// The region names of a generated mesh: slab layer i -> i, the box's region -> 0. Empty for a
// file mesh.
[[nodiscard]] RegionIds generated_region_ids(const Scenario& scenario);

// The material of every region id in `region_ids_in_mesh`. A material's name resolves through
// `names` (for file meshes e.g. Gmsh physical names supplied by the reader) and otherwise through
// the form "region_<id>". InputError naming the `materials` key when a name matches no region,
// two names resolve to one region, or a region of the mesh has no material.
[[nodiscard]] std::map<int, Material> resolve_materials(const Scenario& scenario, const RegionIds& names,
                                                        const std::vector<int>& region_ids_in_mesh);
// The same for the regions of the tetrahedra of `mesh`.
[[nodiscard]] std::map<int, Material> resolve_materials(const Scenario& scenario, const RegionIds& names,
                                                        const TetMesh& mesh);

// The nodes fixed by scenario.fixed, by their rest positions, sorted and unique. A side is matched
// within 1e-9 of the bounding box diagonal. InputError naming `fixed[i]` for a selector that
// selects no node.
[[nodiscard]] std::vector<NodeId> select_fixed_nodes(const Scenario& scenario, const TetMesh& mesh);

[[nodiscard]] const char* to_string(TissueKind m);
[[nodiscard]] const char* to_string(DeviceKind k);
[[nodiscard]] const char* to_string(Side s);

}  // namespace scalpel
