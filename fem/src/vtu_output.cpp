// VTU output (docs/fem.md §7.2): one connected mesh of VTK Lagrange quadrilaterals, one VTK cell per
// solver cell, points shared between cells; the displacement as a 3-vector and its parts, the membrane
// forces in three frames and the charge density as point data, the electrode id as cell data; one
// file per mesh and a PVD series.
//
// Why not deal.II's DataOut: it writes every cell as its own patch with its own copies of the
// points (ParaView then sees a cloud of disconnected cells: no Connectivity region, seams under Warp
// By Vector), and its VTU point merging exists only for HDF5/XDMF output. Here each cell's nodes are
// the equispaced (p+1)² points VTK's Lagrange quadrilateral expects, evaluated through the solver's
// mapping and element, and nodes at the same place are one point.
#include "film_solver.hpp"

#include "pvdf/core/io.hpp"

#include <deal.II/base/quadrature.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/data_postprocessor.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <unordered_map>

namespace pvdf::fem::detail {

using namespace dealii;

/// VTU fields computed from the solution gradients: membrane forces in three frames and the
/// piezoelectric charge density d31·σ11 + d32·σ22.
class MembranePostprocessor : public DataPostprocessor<dim> {
 public:
  explicit MembranePostprocessor(const FilmSolver& solver) : solver_(solver) {}
  void evaluate_vector_field(const DataPostprocessorInputs::Vector<dim>& inputs,
                             std::vector<Vector<double>>& computed) const override;
  std::vector<std::string> get_names() const override;
  std::vector<DataComponentInterpretation::DataComponentInterpretation> get_data_component_interpretation()
      const override;
  UpdateFlags get_needed_update_flags() const override { return update_gradients | update_quadrature_points; }

 private:
  const FilmSolver& solver_;
};


void MembranePostprocessor::evaluate_vector_field(const DataPostprocessorInputs::Vector<dim>& inputs,
                                                  std::vector<Vector<double>>& computed) const {
  for (unsigned int q = 0; q < inputs.solution_gradients.size(); ++q) {
    Kinematics k;
    for (int a = 0; a < 2; ++a) {
      k.g[a] = inputs.solution_gradients[q][2][a];
      for (int b = 0; b < 2; ++b) k.H[a][b] = inputs.solution_gradients[q][a][b];
    }
    const MembraneForce n = solver_.membrane_force(k, inputs.evaluation_points[q]);
    for (int c = 0; c < 3; ++c) {
      computed[q](c) = n.global[c];
      computed[q](3 + c) = n.material[c];
      computed[q](6 + c) = n.polar[c];
    }
    computed[q](9) = solver_.charge_density(n);
  }
}

std::vector<std::string> MembranePostprocessor::get_names() const {
  // Scalars, one per component (a Voigt triple is not a VTK vector).
  return {"N_global_xx_N_per_m", "N_global_yy_N_per_m", "N_global_xy_N_per_m",
          "N_material_11_N_per_m", "N_material_22_N_per_m", "N_material_12_N_per_m",
          "N_polar_rr_N_per_m", "N_polar_tt_N_per_m", "N_polar_rt_N_per_m",
          "charge_density_C_per_m2"};
}

std::vector<DataComponentInterpretation::DataComponentInterpretation>
MembranePostprocessor::get_data_component_interpretation() const {
  return std::vector<DataComponentInterpretation::DataComponentInterpretation>(
      get_names().size(), DataComponentInterpretation::component_is_scalar);
}

namespace {

constexpr std::uint8_t vtk_lagrange_quadrilateral = 70;

/// Lexicographic (i, j) of the nodes of a degree-p VTK Lagrange quadrilateral, in VTK's node order:
/// corners counter-clockwise, then the nodes of the edges (0,1), (1,2), (3,2), (0,3), each from
/// its first corner to its second, then the interior row by row.
std::vector<std::array<unsigned int, 2>> vtk_lagrange_quad_nodes(unsigned int p) {
  std::vector<std::array<unsigned int, 2>> ij = {{0, 0}, {p, 0}, {p, p}, {0, p}};
  for (unsigned int i = 1; i < p; ++i) ij.push_back({i, 0});
  for (unsigned int j = 1; j < p; ++j) ij.push_back({p, j});
  for (unsigned int i = 1; i < p; ++i) ij.push_back({i, p});
  for (unsigned int j = 1; j < p; ++j) ij.push_back({0, j});
  for (unsigned int j = 1; j < p; ++j)
    for (unsigned int i = 1; i < p; ++i) ij.push_back({i, j});
  return ij;
}

/// Point numbering by position: nodes of neighbouring cells closer than `tolerance` are one point
/// (bins of the tolerance's size; the 3×3 neighbouring bins are searched, so a bin edge never splits
/// a pair).
class PointMerger {
 public:
  explicit PointMerger(double tolerance) : h_(tolerance) {}
  std::size_t index(const Point<dim>& x) {
    const long long bx = std::llround(x[0] / h_), by = std::llround(x[1] / h_);
    for (long long dx = -1; dx <= 1; ++dx) {
      for (long long dy = -1; dy <= 1; ++dy) {
        const auto range = bins_.equal_range(key(bx + dx, by + dy));
        for (auto it = range.first; it != range.second; ++it) {
          if (points_[it->second].distance(x) <= h_) return it->second;
        }
      }
    }
    bins_.emplace(key(bx, by), points_.size());
    points_.push_back(x);
    return points_.size() - 1;
  }
  const std::vector<Point<dim>>& points() const { return points_; }

 private:
  static std::uint64_t key(long long bx, long long by) {
    return static_cast<std::uint64_t>(bx) * 0x9E3779B97F4A7C15ull ^ static_cast<std::uint64_t>(by);
  }
  double h_;
  std::unordered_multimap<std::uint64_t, std::size_t> bins_;
  std::vector<Point<dim>> points_;
};

/// A VTK XML data array in the appended raw block: header of the array, then its bytes.
struct AppendedArray {
  std::string xml_attributes;  // type, Name, NumberOfComponents
  std::string bytes;
};

template <typename T>
AppendedArray make_array(const std::string& type, const std::string& name, int n_components, const std::vector<T>& v) {
  AppendedArray a;
  a.xml_attributes = "type=\"" + type + "\"" + (name.empty() ? "" : " Name=\"" + name + "\"") +
                     " NumberOfComponents=\"" + std::to_string(n_components) + "\"";
  const std::uint64_t n_bytes = v.size() * sizeof(T);
  a.bytes.resize(sizeof n_bytes + n_bytes);
  std::memcpy(a.bytes.data(), &n_bytes, sizeof n_bytes);
  if (n_bytes > 0) std::memcpy(a.bytes.data() + sizeof n_bytes, v.data(), n_bytes);
  return a;
}

bool host_is_little_endian() {
  const std::uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

/// Writes an UnstructuredGrid VTU with every array appended raw (UInt64 size headers, host byte order).
void write_vtu_file(std::ostream& os, std::size_t n_points, std::size_t n_cells, const std::vector<AppendedArray>& point_data,
                    const std::vector<AppendedArray>& cell_data, const AppendedArray& points,
                    const std::vector<AppendedArray>& cells) {
  std::uint64_t offset = 0;
  auto declare = [&](const AppendedArray& a) {
    os << "        <DataArray " << a.xml_attributes << " format=\"appended\" offset=\"" << offset << "\"/>\n";
    offset += a.bytes.size();
  };
  os << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\""
     << (host_is_little_endian() ? "LittleEndian" : "BigEndian") << "\" header_type=\"UInt64\">\n"
     << "  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"" << n_points << "\" NumberOfCells=\"" << n_cells << "\">\n"
     << "      <PointData Scalars=\"w_m\" Vectors=\"displacement_m\">\n";
  for (const auto& a : point_data) declare(a);
  os << "      </PointData>\n      <CellData Scalars=\"electrode_id\">\n";
  for (const auto& a : cell_data) declare(a);
  os << "      </CellData>\n      <Points>\n";
  declare(points);
  os << "      </Points>\n      <Cells>\n";
  for (const auto& a : cells) declare(a);
  os << "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";
  for (const auto* group : {&point_data, &cell_data}) {
    for (const auto& a : *group) os.write(a.bytes.data(), static_cast<std::streamsize>(a.bytes.size()));
  }
  os.write(points.bytes.data(), static_cast<std::streamsize>(points.bytes.size()));
  for (const auto& a : cells) os.write(a.bytes.data(), static_cast<std::streamsize>(a.bytes.size()));
  os << "\n  </AppendedData>\n</VTKFile>\n";
}

}  // namespace

// Fields at the nodes of each cell's Lagrange quadrilateral: the displacement (u_x, u_y, w) is the
// finite-element solution there (continuous, so every cell gives a shared point the same value);
// the membrane forces and charge density come from gradients, which jump between cells, so a shared
// point carries the mean over the cells that meet there (exact integrals: `pvdfkit solve --json`).
std::string FilmSolver::write_vtu(int cycle, Model model) {
  current_model_ = model;
  pvdf::make_directories(options_.vtu_directory);
  const unsigned int p = options_.fe_degree;
  const auto nodes = vtk_lagrange_quad_nodes(p);
  std::vector<Point<dim>> unit_points;
  for (const auto& ij : nodes) unit_points.emplace_back(double(ij[0]) / p, double(ij[1]) / p);
  FEValues<dim> fe_values(*mapping_, *fe_, Quadrature<dim>(unit_points),
                          update_values | update_gradients | update_quadrature_points);
  MembranePostprocessor post(*this);
  const std::vector<std::string> post_names = post.get_names();
  const std::size_t n_post = post_names.size();

  PointMerger merger(1e-9 * radius_);
  const std::size_t n_nodes = unit_points.size();
  std::vector<std::int64_t> connectivity;
  std::vector<std::int32_t> electrode_id;
  std::vector<double> displacement, post_sum;  // per point: 3, n_post
  std::vector<int> n_cells_at_point;
  DataPostprocessorInputs::Vector<dim> inputs;
  inputs.solution_values.assign(n_nodes, Vector<double>(3));
  inputs.solution_gradients.assign(n_nodes, std::vector<Tensor<1, dim>>(3));
  std::vector<Vector<double>> computed(n_nodes, Vector<double>(n_post));
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    fe_values.reinit(cell);
    fe_values.get_function_values(solution_, inputs.solution_values);
    fe_values.get_function_gradients(solution_, inputs.solution_gradients);
    inputs.evaluation_points = fe_values.get_quadrature_points();
    post.evaluate_vector_field(inputs, computed);
    for (std::size_t q = 0; q < n_nodes; ++q) {
      const std::size_t i = merger.index(inputs.evaluation_points[q]);
      if (i == n_cells_at_point.size()) {
        n_cells_at_point.push_back(0);
        displacement.resize(3 * (i + 1), 0.0);
        post_sum.resize(n_post * (i + 1), 0.0);
      }
      ++n_cells_at_point[i];
      for (unsigned int c = 0; c < 3; ++c) displacement[3 * i + c] += inputs.solution_values[q](c);
      for (std::size_t f = 0; f < n_post; ++f) post_sum[n_post * i + f] += computed[q](f);
      connectivity.push_back(static_cast<std::int64_t>(i));
    }
    electrode_id.push_back(cell->material_id() == pvdf::mesh::film_material_id ? -1 : int(cell->material_id()) - 1);
  }
  const std::size_t n_points = n_cells_at_point.size(), n_cells = electrode_id.size();
  for (std::size_t i = 0; i < n_points; ++i) {
    for (unsigned int c = 0; c < 3; ++c) displacement[3 * i + c] /= n_cells_at_point[i];
    for (std::size_t f = 0; f < n_post; ++f) post_sum[n_post * i + f] /= n_cells_at_point[i];
  }

  // Point data: displacement_m = (u_x, u_y, w), the field Warp By Vector takes; its parts under the
  // names earlier files used; then the postprocessor's scalars.
  std::vector<double> inplane(3 * n_points, 0.0), w(n_points), xyz(3 * n_points, 0.0);
  for (std::size_t i = 0; i < n_points; ++i) {
    inplane[3 * i] = displacement[3 * i];
    inplane[3 * i + 1] = displacement[3 * i + 1];
    w[i] = displacement[3 * i + 2];
    xyz[3 * i] = merger.points()[i][0];
    xyz[3 * i + 1] = merger.points()[i][1];
  }
  std::vector<AppendedArray> point_data = {make_array("Float64", "displacement_m", 3, displacement),
                                           make_array("Float64", "displacement_inplane_m", 3, inplane),
                                           make_array("Float64", "w_m", 1, w)};
  std::vector<double> field(n_points);
  for (std::size_t f = 0; f < n_post; ++f) {
    for (std::size_t i = 0; i < n_points; ++i) field[i] = post_sum[n_post * i + f];
    point_data.push_back(make_array("Float64", post_names[f], 1, field));
  }
  std::vector<std::int64_t> offsets(n_cells);
  for (std::size_t c = 0; c < n_cells; ++c) offsets[c] = static_cast<std::int64_t>((c + 1) * n_nodes);
  const std::vector<std::uint8_t> types(n_cells, vtk_lagrange_quadrilateral);
  const std::vector<AppendedArray> cells = {make_array("Int64", "connectivity", 1, connectivity),
                                            make_array("Int64", "offsets", 1, offsets),
                                            make_array("UInt8", "types", 1, types)};

  // Wrinkling: 0 taut, 1 wrinkled (uniaxial tension), 2 slack; all 0 without the tension-field membrane.
  const std::vector<float> cell_state = wrinkle_map(solution_, model).cell_state;
  std::vector<std::int32_t> membrane_state(n_cells, 0);
  for (std::size_t c = 0; c < n_cells && c < cell_state.size(); ++c) membrane_state[c] = static_cast<std::int32_t>(cell_state[c]);

  const std::string name = "film_cycle" + std::to_string(cycle) + ".vtu";
  const std::string path = options_.vtu_directory + "/" + name;
  pvdf::write_file_atomically(path, [&](std::ostream& os) {
    write_vtu_file(os, n_points, n_cells, point_data, {make_array("Int32", "electrode_id", 1, electrode_id),
                                                           make_array("Int32", "membrane_state", 1, membrane_state)},
                   make_array("Float64", "", 3, xyz), cells);
  });
  pvd_records_.emplace_back(static_cast<double>(cycle), name);
  const std::string pvd = options_.vtu_directory + "/film.pvd";
  pvdf::write_file_atomically(pvd, [&](std::ostream& os) { DataOutBase::write_pvd_record(os, pvd_records_); });
  return path;
}

}  // namespace pvdf::fem::detail
