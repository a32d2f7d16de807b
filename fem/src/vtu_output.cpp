// VTU output (docs/fem.md §7): the displacement, the membrane forces in three frames and the
// charge density as point data, the electrode id as cell data, one file per mesh and a PVD series.
#include "film_solver.hpp"

#include "pvdf/core/io.hpp"

#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/data_postprocessor.h>

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
  // Scalars, one per component: deal.II groups "vector" components in blocks of spacedim (2 here),
  // which would merge 3-component Voigt triples across fields.
  return {"N_global_xx_N_per_m", "N_global_yy_N_per_m", "N_global_xy_N_per_m",
          "N_material_11_N_per_m", "N_material_22_N_per_m", "N_material_12_N_per_m",
          "N_polar_rr_N_per_m", "N_polar_tt_N_per_m", "N_polar_rt_N_per_m",
          "charge_density_C_per_m2"};
}

std::vector<DataComponentInterpretation::DataComponentInterpretation>
MembranePostprocessor::get_data_component_interpretation() const {
  return std::vector<DataComponentInterpretation::DataComponentInterpretation>(
      10, DataComponentInterpretation::component_is_scalar);
}

std::string FilmSolver::write_vtu(int cycle, Model model) {
  current_model_ = model;
  pvdf::make_directories(options_.vtu_directory);
  DataOut<dim> data_out;
  data_out.attach_dof_handler(dof_handler_);
  // In-plane displacement as a 2-vector (ParaView pads it to 3-D), deflection w as a scalar.
  const std::vector<std::string> names = {"displacement_inplane_m", "displacement_inplane_m", "w_m"};
  const std::vector<DataComponentInterpretation::DataComponentInterpretation> interp = {
      DataComponentInterpretation::component_is_part_of_vector,
      DataComponentInterpretation::component_is_part_of_vector, DataComponentInterpretation::component_is_scalar};
  data_out.add_data_vector(solution_, names, DataOut<dim>::type_dof_data, interp);
  MembranePostprocessor post(*this);
  data_out.add_data_vector(solution_, post);
  Vector<float> electrode_id(triangulation_.n_active_cells());
  for (const auto& cell : triangulation_.active_cell_iterators()) {
    electrode_id(cell->active_cell_index()) =
        cell->material_id() == pvdf::mesh::film_material_id ? -1.0f : static_cast<float>(cell->material_id() - 1);
  }
  data_out.add_data_vector(electrode_id, "electrode_id", DataOut<dim>::type_cell_data);
  // Wrinkling: 0 taut, 1 wrinkled (uniaxial tension), 2 slack; all 0 without the tension-field membrane.
  const std::vector<float> cell_state = wrinkle_map(solution_, model).cell_state;
  const Vector<float> membrane_state(cell_state.begin(), cell_state.end());
  data_out.add_data_vector(membrane_state, "membrane_state", DataOut<dim>::type_cell_data);
  data_out.build_patches(*mapping_, options_.fe_degree, DataOut<dim>::curved_inner_cells);
  const std::string name = "film_cycle" + std::to_string(cycle) + ".vtu";
  const std::string path = options_.vtu_directory + "/" + name;
  pvdf::write_file_atomically(path, [&](std::ostream& os) { data_out.write_vtu(os); });
  pvd_records_.emplace_back(static_cast<double>(cycle), name);
  const std::string pvd = options_.vtu_directory + "/film.pvd";
  pvdf::write_file_atomically(pvd, [&](std::ostream& os) { DataOutBase::write_pvd_record(os, pvd_records_); });
  return path;
}

}  // namespace pvdf::fem::detail
