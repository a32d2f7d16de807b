// Scene → plain geometry for the mesher (private to pvdf::mesh): electrode regions, their
// feature sizes, and the probe footprints to embed (with the reason when one is left out).
#pragma once

#include "pvdf/core/planar.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/core/scene_geometry.hpp"

#include <string>
#include <vector>

namespace pvdf::mesh::detail {

// The electrode outline as a region and its feature size live with the scene reader's checks.
using pvdf::electrode_feature_size_m;
using pvdf::electrode_region;
/// "electrodes[1] (\"B\")" for messages.
std::string electrode_label(const pvdf::Scene& scene, std::size_t index);

/// A probe footprint disk.
struct Footprint {
  planar::Point center_m{0, 0};
  double radius_m = 0;
  std::string label;        ///< "loads[0]" or "extra probe 3"
  bool embed = true;        ///< false when it would make slivers (near-tangent to another outline)
  std::string note;         ///< why it is not embedded
};

/// The footprints of the scene's probe loads (when scene.mesh.embed_probes) followed by the
/// extra positions (disks of the scene's probe radius); each decided embed or not: a disk
/// within `sliver_gap_m` of tangency with the rim, an electrode outline or an earlier embedded
/// disk is left out (the fem integrates the load by quadrature anyway). Positions must have
/// been validated.
std::vector<Footprint> probe_footprints(const pvdf::Scene& scene, const std::vector<std::array<double, 2>>& extras,
                                        double sliver_gap_m);

/// validate_geometry with extra probe positions (disks of the scene's probe radius).
void validate_geometry(const pvdf::Scene& scene, const std::vector<std::array<double, 2>>& extras);

/// Number formatting for messages (6 significant digits).
std::string fmt(double x);

}  // namespace pvdf::mesh::detail
